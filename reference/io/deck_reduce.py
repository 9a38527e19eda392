"""The ``reduce`` key of ``[[beams]]``: a flexible beam described by a floating frame and a few modes (issue 39).

A deck marks a beam for reduction with
``reduce = { modes = 6, interfaces = ["coupler:start", "coupler:end"], basis = "craig_bampton" }``:

- ``modes``: the fixed-interface normal modes kept (Craig–Bampton) or the elastic modes kept (free-free): a
  count (the lowest that many) or a list of mode numbers (1 the lowest, in frequency order);
- ``interfaces``: node references of the beam (docs/deck.md, "Node references") where joints, springs and loads
  attach; a Craig–Bampton basis keeps their six coordinates each, so it needs at least one;
- ``basis``: ``"craig_bampton"`` (default) or ``"free_free"`` (:mod:`reference.reduced.craig_bampton`);
- ``stiffening``: ``true`` adds the centrifugal stress stiffness of the modes
  (:func:`reference.reduced.stiffening.spin_stiffness`) to the modal stiffness, at the frame's current spin;
- ``second_order``: ``true`` adds the modes' second-order stiffness
  (:func:`reference.reduced.stiffening.modal_third_derivatives`): the stress stiffness of the body's own deformation;
- ``third_order``: ``true`` adds, with it, the modes' third-order stiffness
  (:func:`reference.reduced.stiffening.modal_fourth_derivatives`): the strain energy to fourth order in the modal
  coordinates, where a beam's shortening by its own bending stiffens it;
- ``modal_derivatives``: ``true`` adds to a Craig–Bampton basis the static modal derivatives of its modes
  (:func:`reference.reduced.stiffening.derivative_modes`): their second-order displacement field, e.g. the axial
  relaxation of a bent beam's membrane strain.

:func:`read_reduce` checks the key (one line ``FILE: beams[i].reduce…: problem; fix`` for a node that does not
exist or is not the beam's, more modes than the mesh has, a rigid bar, an unknown key), then the run: the
reference path only (``[solver] backend = "reference"`` or ``"auto"``), an algorithm of :data:`RUNS`, joints,
springs and loads at interface nodes only (:func:`reference.reduced.attachments.attachment_problem`); it builds
each body (:class:`reference.reduced.body.ReducedBody`) and registers them with the Domain
(:mod:`reference.reduced.registry`), where the backend's choice finds them.
:func:`reference.io.reduced_deck.reduced_bodies` reads a deck past those run checks (:func:`collecting`) and
returns each reduced beam's body, its modes and invariants, so that the reduction can be inspected from the deck.
"""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from typing import NamedTuple

from reference.reduced.body import ReducedBody
from reference.reduced.craig_bampton import (beam_matrices, craig_bampton, enriched, floating_modes, free_free,
                                             interface_positions)
from reference.reduced.invariants import invariants
from reference.reduced.registry import RUNS, register
from reference.reduced.stiffening import (derivative_modes, modal_fourth_derivatives, modal_third_derivatives,
                                          spin_stiffness)
from reference.reduced.attachments import attachment_problem

BASES = ("craig_bampton", "free_free")
"""The reduced bases a deck may name (:mod:`reference.reduced.craig_bampton`)."""

_COLLECT: ContextVar = ContextVar("reduce_collect", default=None)
"""Set by :func:`collecting` to a dict that :func:`read_reduce` fills instead of checking the run."""


class Reduction(NamedTuple):
    """One beam's ``reduce`` table as read: ``label``; ``modes`` the count kept or the mode numbers kept (a tuple,
    :func:`reference.reduced.craig_bampton.kept_modes`); ``interfaces`` their positions
    along the beam (:func:`reference.reduced.craig_bampton.interface_positions`); ``basis`` one of :data:`BASES`;
    ``beam`` its :class:`~reference.reduced.craig_bampton.BeamMatrices`; ``stiffening`` whether the modal stiffness
    takes the centrifugal stress stiffness, ``second_order`` the modes' second-order stiffness, ``third_order`` also
    their third-order stiffness, ``modal_derivatives`` the basis enriched by its modes' modal derivatives (``domain``
    the Domain their tangents are taken from)."""

    label: str
    modes: int | tuple
    interfaces: tuple
    basis: str
    beam: object
    stiffening: bool = False
    domain: object = None
    second_order: bool = False
    third_order: bool = False
    modal_derivatives: bool = False


def _split(message: str, prefix: str) -> tuple[str, str]:
    """A ``"prefix: problem; fix"`` message of :mod:`reference.reduced.craig_bampton` as ``(problem, fix)``."""
    message = message.removeprefix(f"{prefix}: ")
    problem, _, fix = message.partition("; ")
    return problem, fix


def _interfaces(rd, table: dict, entry: str, domain, beam) -> tuple:
    """The interface nodes' positions along ``beam``, each reference checked by its own entry."""
    refs = table.get("interfaces", [])
    if not isinstance(refs, list):
        raise rd.fail(f"{entry}.interfaces", "expected an array of node references",
                      'write it as interfaces = ["BEAM:start", "BEAM:end"]')
    found = []
    for j, ref in enumerate(refs):
        sub = f"{entry}.interfaces[{j}]"
        if not isinstance(ref, (str, int)) or isinstance(ref, bool):
            raise rd.fail(sub, f"expected a node reference, got {ref!r}", 'e.g. "BEAM:start" or a node label')
        try:
            (position,) = interface_positions(domain, beam, [ref])
        except ValueError as exc:
            raise rd.fail(sub, *_split(str(exc), "reduce.interfaces")) from None
        if position in found:
            raise rd.fail(sub, f"node {ref!r} named twice", "name each interface once")
        found.append(position)
    return tuple(found)


def _modes(rd, table: dict, entry: str, basis: str, beam, interfaces: tuple):
    """The modes kept: a count (the lowest that many) or a list of mode numbers (1 the lowest, in frequency order),
    checked against what the mesh has (the interior's coordinates for Craig–Bampton, the ``6 n − 6`` elastic modes of
    a free beam of ``n`` nodes)."""
    n_nodes = len(beam.nodes)
    if basis == "craig_bampton":
        most, have = 6 * (n_nodes - len(interfaces)), f"its {n_nodes} nodes less {len(interfaces)} interface nodes"
        least = 0
    else:
        most, have, least = 6 * n_nodes - 6, f"its {n_nodes} free nodes", 1
    value = table["modes"]
    if isinstance(value, list):
        numbers = [rd.integer(m, f"{entry}.modes[{k}]", minimum=1) for k, m in enumerate(value)]
        if len(set(numbers)) != len(numbers) or len(numbers) < least:
            raise rd.fail(f"{entry}.modes", f"mode numbers {numbers} repeat one or name none",
                          "name each mode once (1 the lowest), e.g. modes = [1, 2, 3, 4, 9]")
        if max(numbers) > most:
            raise rd.fail(f"{entry}.modes", f"mode {max(numbers)} asked of beam {beam.label!r}, whose mesh has "
                          f"{most} ({have})", f"name modes 1 to {most}, or refine the mesh (more elements)")
        return tuple(sorted(numbers))
    modes = rd.integer(value, f"{entry}.modes", minimum=0)
    if not least <= modes <= most:
        raise rd.fail(f"{entry}.modes", f"{modes!r} modes asked of beam {beam.label!r}, whose mesh has {most} "
                      f"({have})", f"ask {least} to {most}, or refine the mesh (more elements)")
    return modes


def read_reduce(rd, deck: dict, domain) -> dict:
    """Check every ``[[beams]]`` entry's ``reduce`` table of the TOML table ``deck`` against the built ``domain``
    (its beams and nodes); return label → :class:`Reduction`; outside :func:`collecting`, check the run
    (:func:`_check_run`) and register the bodies with ``domain``.

    Raises
    ------
    reference.io.deck_reader.DeckError
        One line naming the entry: an unknown key (did you mean), a rigid bar marked for reduction, an interface
        node that does not exist or is not the beam's, more modes than the mesh has, the compiled backend, an
        algorithm that does not run reduced bodies, a joint, spring or load at a node that is not an interface.
    """
    found = {}
    for i, bm in enumerate(rd.items(deck, "beams")):
        if not isinstance(bm, dict) or "reduce" not in bm:
            continue
        entry = f"beams[{i}].reduce"
        table = bm["reduce"]
        rd.keys(table, entry, required=["modes"], optional=["interfaces", "basis", "stiffening", "second_order",
                                                                 "third_order", "modal_derivatives"])
        if bm.get("rigid", False) is True:
            raise rd.fail(entry, "a rigid bar is one rigid body, it has no modes to reduce", "remove reduce or rigid")
        basis = rd.choice(table.get("basis", BASES[0]), f"{entry}.basis", BASES, "basis")
        try:
            beam = beam_matrices(domain, bm["label"])
        except ValueError as exc:
            raise rd.fail(entry, *_split(str(exc), "reduce")) from None
        interfaces = _interfaces(rd, table, entry, domain, beam)
        if basis == "craig_bampton" and not interfaces:
            raise rd.fail(f"{entry}.interfaces", "a Craig–Bampton basis needs at least one interface node",
                          'name one (e.g. interfaces = ["BEAM:start"]) or write basis = "free_free"')
        stiffening = rd.boolean(table.get("stiffening", False), f"{entry}.stiffening")
        if stiffening and not interfaces:
            raise rd.fail(f"{entry}.stiffening", "the centrifugal stress state needs the node the body turns about",
                          "name it first in interfaces (the hub)")
        second = rd.boolean(table.get("second_order", False), f"{entry}.second_order")
        third = rd.boolean(table.get("third_order", False), f"{entry}.third_order")
        if third and not second:
            raise rd.fail(f"{entry}.third_order", "the third-order stiffness continues the second-order one",
                          "add second_order = true")
        derivatives = rd.boolean(table.get("modal_derivatives", False), f"{entry}.modal_derivatives")
        if derivatives and basis != "craig_bampton":
            raise rd.fail(f"{entry}.modal_derivatives", "modal derivatives are taken with the interfaces held",
                          'use basis = "craig_bampton" (the default), or remove modal_derivatives')
        found[beam.label] = Reduction(beam.label, _modes(rd, table, entry, basis, beam, interfaces), interfaces,
                                      basis, beam, stiffening, domain, second, third, derivatives)
    collect = _COLLECT.get()
    if collect is not None:
        collect.update(found)
    elif found:
        first = next(i for i, bm in enumerate(deck["beams"]) if isinstance(bm, dict) and "reduce" in bm)
        _check_run(rd, f"beams[{first}].reduce", domain, found)
        register(domain, {label: (reduced_body(r), r.beam.nodes) for label, r in found.items()})
    return found


def reduced_body(reduction: Reduction) -> ReducedBody:
    """The :class:`~reference.reduced.body.ReducedBody` of one beam's :class:`Reduction`: Craig–Bampton's
    basis turned into floating-frame modes (:func:`~reference.reduced.craig_bampton.floating_modes`, the frame's
    mean axes), enriched first by the modes' modal derivatives where asked, or the free-free modes; invariants about
    the centre of mass."""
    beam = reduction.beam
    if reduction.basis == "craig_bampton":
        basis = craig_bampton(beam, reduction.interfaces, reduction.modes)
        if reduction.modal_derivatives:
            basis = enriched(beam, basis, derivative_modes(reduction.domain, beam, basis))
        modes = floating_modes(beam, basis)
    else:
        modes = free_free(beam, reduction.modes)
    body = ReducedBody(reduction.label, beam, modes, invariants(beam, modes), interfaces=reduction.interfaces)
    if reduction.stiffening:
        body.spin_stiffness = spin_stiffness(reduction.domain, beam, modes, reduction.interfaces)
    if reduction.second_order:
        body.cubic = modal_third_derivatives(reduction.domain, beam, modes)
    if reduction.third_order:
        body.quartic = modal_fourth_derivatives(reduction.domain, beam, modes)
    return body


def _check_run(rd, entry: str, domain, found: dict) -> None:
    """The run of a deck with reduced beams: the reference path (``solver.backend`` "reference" or "auto"), an
    algorithm that runs them (:data:`RUNS`: generalized-α at a fixed step, modes about the reference state);
    joints, springs and loads only at the interface nodes."""
    if domain.solver.backend == "compiled":
        raise rd.fail(entry, "reduced bodies run on the reference path only",
                      'set backend = "reference" (or "auto") in [solver]')
    if domain.solver.algorithm not in RUNS:
        raise rd.fail(entry, f"reduced bodies run in {', '.join(RUNS)}, not in {domain.solver.algorithm!r}",
                      "choose one of them in [solver], or remove reduce")
    solver = domain.solver
    if solver.algorithm == "generalized_alpha" and getattr(solver, "error_tolerance", None) is not None:
        raise rd.fail(entry, "generalized-α runs reduced bodies at the fixed step dt (no error control)",
                      "remove error_tolerance from [solver]")
    if solver.algorithm == "modes" and getattr(solver, "about", "reference") != "reference":
        raise rd.fail(entry, "modes of a model with reduced bodies are taken about the reference state only",
                      'remove about from [solver] (or set about = "reference")')
    problem = attachment_problem(domain.model, {label: (r.beam.nodes, r.interfaces) for label, r in found.items()},
                                 [n.label for n in domain.nodes])
    if problem:
        raise rd.fail(entry, *problem)


@contextmanager
def collecting():
    """Within the ``with`` block, :func:`read_reduce` puts each deck's reductions (label → :class:`Reduction`)
    into the dict yielded instead of checking the run and registering the bodies (a context variable: a deck read
    in another thread or task is checked as usual)."""
    collect = {}
    token = _COLLECT.set(collect)
    try:
        yield collect
    finally:
        _COLLECT.reset(token)
