"""The ``reduce`` key of ``[[beams]]``: a flexible beam described by a floating frame and a few modes (issue 39).

A deck marks a beam for reduction with
``reduce = { modes = 6, interfaces = ["coupler:start", "coupler:end"], basis = "craig_bampton" }``:

- ``modes``: the fixed-interface normal modes kept (Craig–Bampton) or the elastic modes kept (free-free);
- ``interfaces``: node references of the beam (docs/deck.md, "Node references") where joints, springs and loads
  attach; a Craig–Bampton basis keeps their six coordinates each, so it needs at least one;
- ``basis``: ``"craig_bampton"`` (default) or ``"free_free"`` (:mod:`reference.reduced.craig_bampton`).

:func:`read_reduce` checks the key (one line ``FILE: beams[i].reduce…: problem; fix`` for a node that does not
exist or is not the beam's, more modes than the mesh has, a rigid bar, an unknown key) and then refuses the deck:
the reduced body (:class:`reference.reduced.body.ReducedBody`) is built but not yet run by the algorithms.
:func:`reference.io.reduced_deck.reduced_bodies` reads a deck past that refusal (:func:`collecting`) and
returns each reduced beam's body, its modes and invariants, so that the reduction can be inspected from the deck.
"""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from typing import NamedTuple

from reference.reduced.body import ReducedBody
from reference.reduced.craig_bampton import (beam_matrices, craig_bampton, floating_modes, free_free,
                                             interface_positions)
from reference.reduced.invariants import invariants

BASES = ("craig_bampton", "free_free")
"""The reduced bases a deck may name (:mod:`reference.reduced.craig_bampton`)."""

_COLLECT: ContextVar = ContextVar("reduce_collect", default=None)
"""Set by :func:`collecting` to a dict that :func:`read_reduce` fills instead of refusing the deck."""


class Reduction(NamedTuple):
    """One beam's ``reduce`` table as read: ``label``; ``modes`` the count kept; ``interfaces`` their positions
    along the beam (:func:`reference.reduced.craig_bampton.interface_positions`); ``basis`` one of :data:`BASES`;
    ``beam`` its :class:`~reference.reduced.craig_bampton.BeamMatrices`."""

    label: str
    modes: int
    interfaces: tuple
    basis: str
    beam: object


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


def _modes(rd, table: dict, entry: str, basis: str, beam, interfaces: tuple) -> int:
    """The mode count, checked against what the mesh has (the interior's coordinates for Craig–Bampton, the
    ``6 n − 6`` elastic modes of a free beam of ``n`` nodes)."""
    n_nodes = len(beam.nodes)
    if basis == "craig_bampton":
        most, have = 6 * (n_nodes - len(interfaces)), f"its {n_nodes} nodes less {len(interfaces)} interface nodes"
        least = 0
    else:
        most, have, least = 6 * n_nodes - 6, f"its {n_nodes} free nodes", 1
    modes = rd.integer(table["modes"], f"{entry}.modes", minimum=0)
    if not least <= modes <= most:
        raise rd.fail(f"{entry}.modes", f"{modes!r} modes asked of beam {beam.label!r}, whose mesh has {most} "
                      f"({have})", f"ask {least} to {most}, or refine the mesh (more elements)")
    return modes


def read_reduce(rd, deck: dict, domain) -> dict:
    """Check every ``[[beams]]`` entry's ``reduce`` table of the TOML table ``deck`` against the built ``domain``
    (its beams and nodes); return label → :class:`Reduction` while :func:`collecting`, else refuse a
    deck that reduces a beam (the algorithms do not run reduced bodies yet).

    Raises
    ------
    reference.io.deck_reader.DeckError
        One line naming the entry: an unknown key (did you mean), a rigid bar marked for reduction, an interface
        node that does not exist or is not the beam's, more modes than the mesh has, or the refusal.
    """
    found = {}
    for i, bm in enumerate(rd.items(deck, "beams")):
        if not isinstance(bm, dict) or "reduce" not in bm:
            continue
        entry = f"beams[{i}].reduce"
        table = bm["reduce"]
        rd.keys(table, entry, required=["modes"], optional=["interfaces", "basis"])
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
        found[beam.label] = Reduction(beam.label, _modes(rd, table, entry, basis, beam, interfaces), interfaces,
                                      basis, beam)
    collect = _COLLECT.get()
    if found and collect is None:
        first = next(i for i, bm in enumerate(deck["beams"]) if isinstance(bm, dict) and "reduce" in bm)
        raise rd.fail(f"beams[{first}].reduce", "reduced bodies are built (modes, invariants) but not yet run by "
                      "the algorithms", "remove reduce to run the full beam, or read them with "
                      "reference.io.reduced_deck.reduced_bodies")
    if collect is not None:
        collect.update(found)
    return found


def reduced_body(reduction: Reduction) -> ReducedBody:
    """The :class:`~reference.reduced.body.ReducedBody` of one beam's :class:`Reduction`: Craig–Bampton's
    basis turned into floating-frame modes (:func:`~reference.reduced.craig_bampton.floating_modes`, the frame's
    mean axes), or the free-free modes; invariants about the centre of mass."""
    beam = reduction.beam
    if reduction.basis == "craig_bampton":
        modes = floating_modes(beam, craig_bampton(beam, reduction.interfaces, reduction.modes))
    else:
        modes = free_free(beam, reduction.modes)
    return ReducedBody(reduction.label, beam, modes, invariants(beam, modes), interfaces=reduction.interfaces)


@contextmanager
def collecting():
    """Within the ``with`` block, :func:`read_reduce` puts each deck's reductions (label → :class:`Reduction`)
    into the dict yielded instead of refusing the deck (a context variable: a deck read in another thread or
    task is refused as usual)."""
    collect = {}
    token = _COLLECT.set(collect)
    try:
        yield collect
    finally:
        _COLLECT.reset(token)
