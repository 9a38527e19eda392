"""Model decks (TOML): reading and validation.

The deck is the preprocessor's file of the paper's Domain (§4.3): it lists
sections, nodes, beams, boundary conditions, loads and their time functions,
initial conditions and the solver settings.  Every key is documented in
``docs/deck.md``.  Anything wrong — a typo, a missing reference, a
non-positive stiffness, an unstable time step — raises :class:`DeckError`
with one message naming the file, the entry and the fix.

:func:`load_deck` reads the file (:func:`reference.io.deck_reader.read_toml`),
applies the overrides, then reads the model's tables into a
:class:`~reference.domain.Domain`, one function per table, and the solution's
(``[solver]``, ``[checks]``, ``[crosscheck]``: :mod:`reference.io.deck_solution`);
the checks and messages are those of :class:`reference.io.deck_reader.Reader`.
It returns a :class:`Deck`: the Domain, which is all the engine needs, and
beside it what only the verification reads (``[meta]``, ``[checks]``,
``[crosscheck]``, the deck's text and path).
"""

from __future__ import annotations

import difflib
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from reference.domain import Domain
from reference.elements import Section
from reference.elements.families import DEFAULT_FAMILY, ELEMENT_FAMILIES
from reference.expressions import ExpressionError
from reference.interactions import (Clamp, Constant, Expression, FixedCoordinates, Gravity, LineLoad, NodalLoad,
                                    PiecewiseLinear, Ramp, Sine, SmoothStep, Step)
from reference.io.deck_connectors import read_joints, read_prescribed_displacements, read_springs
from reference.io.deck_parameters import read_sensitivities
from reference.io.deck_reader import DeckError, Reader, override_value, read_toml, show
from reference.io.deck_reduce import read_reduce
from reference.io.deck_solution import check_backend, read_checks, read_solver
from reference.joints.formulations import refusal as formulation_refusal
from reference.validation import LabelError, ModelWarning

TOP_LEVEL = {"meta", "sections", "time_functions", "nodes", "beams", "rigid_bodies", "joints", "clamps", "fixed",
             "loads", "line_loads", "springs", "gravity", "initial_velocities", "solver", "checks", "crosscheck",
             "prescribed_displacements", "sensitivities"}
SECTION_KEYS = ["EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ1", "rhoJ2", "rhoJ3"]
TIME_FUNCTIONS = {
    "constant": (Constant, ["value"], {}),
    "ramp": (Ramp, ["t0", "t1"], {"v0": 0.0, "v1": 1.0}),
    "step": (Step, ["t0"], {"v0": 0.0, "v1": 1.0}),
    "piecewise_linear": (PiecewiseLinear, ["times", "values"], {}),
    "sine": (Sine, ["amplitude", "omega"], {"phase": 0.0, "offset": 0.0}),
    "smooth_step": (SmoothStep, ["t0", "t1"], {"v0": 0.0, "v1": 1.0}),
    "expression": (Expression, ["expr"], {}),
}
DOF_NAMES = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}
OVERRIDES = {"t_end", "dt", "refine"}

MAX_ELEMENTS = 100_000
"""Most Beam2 elements in one model, after ``refine`` (about 1 GB of model and scratch memory)."""


@dataclass
class Deck:
    """A deck as read: the model to solve and the tables the verification reads beside it.

    Attributes
    ----------
    domain : Domain
        The ready-to-solve model.
    path : str
        The deck file.
    text : str
        Its text, as read (written into the results files).
    metadata : dict
        ``[meta]`` (``name``, ``description``, ``provenance`` …).
    checks, crosscheck : dict
        ``[checks.NAME]`` and ``[crosscheck.NAME]`` by name, their observables checked against the model.
    sensitivities : dict
        ``[sensitivities]``: ``parameters`` and ``outputs`` (lists of str), checked
        (:func:`reference.io.deck_parameters.read_sensitivities`); {} without the table.
    """

    domain: Domain
    path: str
    text: str
    metadata: dict = field(default_factory=dict)
    checks: dict = field(default_factory=dict)
    crosscheck: dict = field(default_factory=dict)
    sensitivities: dict = field(default_factory=dict)

    def solve(self, **kwargs):
        """:meth:`Domain.solve <reference.domain.Domain.solve>` with a results file that records this deck."""
        return self.domain.solve(deck=self, **kwargs)


def load_deck(path, overrides: dict | None = None) -> Deck:
    """Read and validate a deck; return it as a :class:`Deck` holding a ready-to-solve Domain.

    Parameters
    ----------
    path : path-like
    overrides : dict, optional
        ``t_end``, ``dt`` (replace the deck's; a step smaller by a whole factor
        keeps the deck's output times), ``refine`` (an integer multiplying every
        flexible beam's element count; the step is divided and the output
        interval multiplied by it, so output times stay the same); and any deck
        value by its dotted name (``solver.damping``, ``sections.NAME.EI2``,
        ``beams.0.elements``; see :func:`reference.io.deck_reader.override_value`),
        validated as if written in the deck.

    Raises
    ------
    DeckError
        ``FILE: ENTRY: problem; fix``, for the first problem found.
    """
    path = Path(path)
    text, deck = read_toml(path)
    rd = Reader(path)
    written = _written_families(deck)
    overrides = dict(overrides or {})
    for key in list(overrides):
        if "." in key:
            override_value(deck, key, overrides.pop(key), rd)
        elif key not in OVERRIDES:
            raise DeckError(f"{path}: unknown override {show(key)}; valid: {', '.join(sorted(OVERRIDES))} or the "
                            "dotted name of a deck value, e.g. solver.damping or sections.NAME.EI2")
    refine = rd.integer(overrides.get("refine", 1), "override refine (--refine)", maximum=MAX_ELEMENTS,
                        fix=f"a model has at most {MAX_ELEMENTS} elements")
    rd.keys(deck, "deck", optional=sorted(TOP_LEVEL))

    domain, metadata = _meta(rd, deck)
    sections = _sections(rd, deck)
    refs = _References(rd, domain, _time_functions(rd, deck))
    _nodes(rd, deck, domain)
    _beams(rd, deck, domain, refs, sections, refine)
    _rigid_bodies(rd, deck, domain)
    _boundary_conditions(rd, deck, domain, refs)
    _loads(rd, deck, domain, refs)
    read_joints(rd, deck, domain, refs)
    read_prescribed_displacements(rd, deck, domain, refs)
    read_springs(rd, deck, domain, refs)
    _initial_velocities(rd, deck, refs)
    refs.renumbered(written)
    algorithm, algo_cls = read_solver(rd, deck, domain, overrides, refine)
    checks, crosscheck = read_checks(rd, deck, domain)
    sensitivities = read_sensitivities(rd, deck, domain, algorithm)
    try:
        model = domain.initialization()
    except ValueError as exc:
        raise rd.fail("model", str(exc)) from None
    algo = domain.algorithm()
    problem = algo.refusal(model) or formulation_refusal(domain.joints, algorithm)
    if problem:
        raise rd.fail("solver.algorithm", f"{algorithm!r} cannot run this model: {problem}")
    problem = algo.setting_problem(model)
    if problem:
        raise rd.fail(*problem)
    check_backend(rd, domain, algo, model)
    read_reduce(rd, deck, domain)
    return Deck(domain, str(path), text, metadata, checks, crosscheck, sensitivities)


def _written_families(deck: dict) -> dict:
    """Beam label → its ``element`` family as the deck's text gives it (before overrides), for the beams
    whose label and family are strings (the rest are refused when read)."""
    beams = deck.get("beams", [])
    return {bm["label"]: bm.get("element", DEFAULT_FAMILY) for bm in beams if isinstance(bm, dict)
            and isinstance(bm.get("label"), str) and isinstance(bm.get("element", DEFAULT_FAMILY), str)
            and bm.get("element", DEFAULT_FAMILY) in ELEMENT_FAMILIES} if isinstance(beams, list) else {}


def warm_up(path, dt: float, overrides: dict | None = None) -> float:
    """Solve the deck at ``path`` (with ``overrides``) for two steps of ``dt``; return the seconds it took.

    A process's first solve loads (or compiles) the engine's numba kernels: a solve
    timed after this one measures the solve alone.
    """
    t0 = time.perf_counter()
    load_deck(path, overrides={**(overrides or {}), "t_end": 2 * dt, "dt": dt}).domain.solve()
    return time.perf_counter() - t0


class _References:
    """Node and time-function references, resolved against what the deck has defined so far.

    ``tfs``: the time functions by name; ``beams`` (label → its nodes) is
    filled by :func:`_beams`, so that a beam is known to the tables read after
    it (docs/deck.md, "Node references").
    """

    def __init__(self, rd: Reader, domain: Domain, tfs: dict):
        self.rd, self.domain, self.tfs = rd, domain, tfs
        self.beams: dict = domain.beams
        self.numbered: list = []
        self.families: dict = {}
        """The element family of every flexible beam, by label."""
        """``(entry, reference, beam, i)`` of every numeric reference ``BEAM:i``, i > 0."""

    def renumbered(self, written: dict) -> str:
        """The line warning of the numeric references ``BEAM:i`` (i > 0) whose node depends on the element
        family (issue 38: ``b:4`` is mid-span of a 4-element beam3, the tip of a Beam2), also issued as a
        :class:`~reference.validation.ModelWarning`; ``""`` if none.  A reference is warned about when its beam's
        family has more than two nodes per element (the numbers count the middle nodes), or when its family
        has another count of nodes per element than the deck's own, ``written`` (beam label → family
        name as written, before overrides: ``--element``, a sweep of ``beams.K.element``)."""
        moved = []
        for entry, ref, beam, i in self.numbered:
            nodes = self.beams[beam]
            family, own = (ELEMENT_FAMILIES[name] for name in (self.families[beam], written.get(beam, DEFAULT_FAMILY)))
            if family.n_nodes > 2 or family.n_nodes != own.n_nodes:
                moved.append((entry, ref, beam, i, len(nodes) - 1, family.family))
        if not moved:
            return ""
        entry, ref, beam, i, segments, family = moved[0]
        more = f" (and {len(moved) - 1} more)" if len(moved) > 1 else ""
        line = (f"{entry}: {show(ref)}{more} counts the nodes of {family} elements: node {i} of 0…{segments}, "
                f"at {i / segments:.3g} of the beam; with another element family the same number is another "
                f"node: write '{beam}:start', '{beam}:mid' or '{beam}:end' for a place that does not depend on it")
        warnings.warn(line, ModelWarning, stacklevel=3)
        return line

    def node(self, ref, entry):
        """The node named by ``ref``: a node label, ``BEAM:start``, ``BEAM:mid``, ``BEAM:end`` or ``BEAM:i``
        (:meth:`reference.domain.Domain.node`, its problem and fix in the reader's line); a numeric
        ``BEAM:i`` (i > 0) is kept in :attr:`numbered` for :meth:`renumbered`."""
        rd = self.rd
        if not isinstance(ref, str):
            raise rd.fail(entry, f"expected a node reference (a label like 'beam:end'), got {show(ref)}")
        try:
            node = self.domain.node(ref)
        except LabelError as exc:
            raise rd.fail(entry, exc.problem, exc.fix) from None
        beam, _, which = ref.rpartition(":")
        nodes = self.beams.get(beam, [])
        if which.isascii() and which.isdigit() and 0 < int(which) < len(nodes) and nodes[int(which)] is node:
            self.numbered.append((entry, ref, beam, int(which)))
        return node

    def time_function(self, table, entry):
        """The time function named by ``table['time_function']`` (or ``force_function``; None if absent)."""
        rd, tfs = self.rd, self.tfs
        key = next((k for k in ("time_function", "force_function") if k in table), None)
        if key is None:
            return None
        name = rd.string(table[key], f"{entry}.{key}")
        if name not in tfs:
            close = difflib.get_close_matches(name, list(tfs), n=1)
            raise rd.fail(f"{entry}.{key}", f"no time function {show(name)}",
                          f"did you mean '{close[0]}'?" if close else f"defined: {', '.join(tfs) or 'none'}")
        return tfs[name]


def _meta(rd: Reader, deck: dict) -> tuple[Domain, dict]:
    """``[meta]``: the Domain, named, and the table."""
    meta = deck.get("meta", {})
    rd.keys(meta, "meta", required=["name"], optional=["description", "units", "provenance", "notes"])
    for key in ("description", "units", "notes"):
        if key in meta:
            rd.string(meta[key], f"meta.{key}")
    if "provenance" in meta and not isinstance(meta["provenance"], (str, dict)):
        raise rd.fail("meta.provenance", f"expected a string or a table, got {show(meta['provenance'])}",
                      'e.g. provenance = { paper = "...", figures = "...", data = "..." }')
    return Domain(rd.label(meta["name"], "meta.name"), meta.get("description", "")), dict(meta)


def _sections(rd: Reader, deck: dict) -> dict:
    """``[sections.NAME]``: name → :class:`~reference.elements.Section`; a section that only ``rigid = true``
    beams use needs only its mass data (``rhoA``, ``rhoJ1``…``rhoJ3``)."""
    beams = deck.get("beams", [])
    beams = [bm for bm in beams if isinstance(bm, dict) and isinstance(bm.get("section"), str)] \
        if isinstance(beams, list) else []
    rigid_only = {bm["section"] for bm in beams if bm.get("rigid", False) is True} - \
        {bm["section"] for bm in beams if bm.get("rigid", False) is not True}
    sections = {}
    for name, sec in rd.tables(deck, "sections").items():
        entry = f"sections.{name}"
        if name not in rigid_only or not isinstance(sec, dict) or set(SECTION_KEYS[:6]) <= set(sec):
            rd.keys(sec, entry, required=SECTION_KEYS)
            values = {k: rd.number(sec[k], f"{entry}.{k}", positive=True) for k in SECTION_KEYS}
            sections[name] = Section(**values)
        else:
            rd.keys(sec, entry, required=SECTION_KEYS[6:], optional=SECTION_KEYS[:6])
            values = {k: rd.number(sec[k], f"{entry}.{k}", positive=True) for k in SECTION_KEYS if k in sec}
            sections[name] = Section(**values)
    return sections


def _time_functions(rd: Reader, deck: dict) -> dict:
    """``[time_functions.NAME]``: name → time function (:mod:`reference.interactions`)."""
    tfs = {}
    for name, tf in rd.tables(deck, "time_functions").items():
        entry = f"time_functions.{name}"
        if not isinstance(tf, dict):
            raise rd.fail(entry, f"expected a table, got {show(tf)}", f"write it as [{entry}] with kind = ...")
        if "kind" not in tf:
            raise rd.fail(entry, "missing required key 'kind'", f"one of: {', '.join(TIME_FUNCTIONS)}")
        kind = rd.choice(tf["kind"], f"{entry}.kind", TIME_FUNCTIONS, "kind")
        cls, required, optional = TIME_FUNCTIONS[kind]
        rd.keys(tf, entry, required=["kind"] + required, optional=list(optional))
        args = {}
        for k in required + list(optional):
            v = tf.get(k, optional.get(k))
            if k == "expr":
                args[k] = rd.string(v, f"{entry}.expr")
            elif k in ("times", "values"):
                if not isinstance(v, list) or len(v) < 2:
                    raise rd.fail(f"{entry}.{k}", "expected a list of at least two numbers")
                args[k] = [rd.number(x, f"{entry}.{k}[{i}]") for i, x in enumerate(v)]
            else:
                args[k] = rd.number(v, f"{entry}.{k}")
        if kind == "piecewise_linear":
            if len(args["times"]) != len(args["values"]):
                raise rd.fail(entry, "times and values have different lengths")
            if np.any(np.diff(args["times"]) <= 0):
                raise rd.fail(f"{entry}.times", "must be strictly increasing")
        if kind in ("ramp", "smooth_step") and not args["t1"] > args["t0"]:
            raise rd.fail(entry, "t1 must be greater than t0")
        try:
            tfs[name] = cls(**args)
        except ExpressionError as exc:
            raise rd.fail(f"{entry}.expr", str(exc), "write a formula in t, e.g. expr = \"sin(3*t)**2\"") from None
    return tfs


def _nodes(rd: Reader, deck: dict, domain: Domain) -> None:
    """``[[nodes]]``."""
    for i, nd in enumerate(rd.items(deck, "nodes")):
        entry = f"nodes[{i}]"
        rd.keys(nd, entry, required=["label", "position"], optional=["rotation"])
        rot = rd.rotation(nd["rotation"], f"{entry}.rotation") if "rotation" in nd else None
        label = rd.label(nd["label"], f"{entry}.label")
        if label in domain._labels:
            raise rd.fail(f"{entry}.label", f"duplicate node label {show(label)}")
        domain.add_node(rd.vector(nd["position"], f"{entry}.position"), rotation=rot, label=label)


def _beams(rd: Reader, deck: dict, domain: Domain, refs: _References, sections: dict, refine: int) -> None:
    """``[[beams]]``: flexible beams (meshed, ``refine`` times the elements) and rigid bars."""
    beams = refs.beams
    for i, bm in enumerate(rd.items(deck, "beams")):
        entry = f"beams[{i}]"
        rigid = isinstance(bm, dict) and bm.get("rigid", False) is True  # a rigid bar has no elements
        rd.keys(bm, entry, required=["label", "section"] if rigid else ["label", "elements", "section"],
                optional=["start", "end", "start_node", "end_node", "axis2", "rigid", "center", "elements", "element",
                          "reduce"])
        label = rd.label(bm["label"], f"{entry}.label")
        if label in beams:
            raise rd.fail(f"{entry}.label", f"duplicate beam label {show(label)}")
        rigid = rd.boolean(bm.get("rigid", False), f"{entry}.rigid")
        n = rd.integer(bm.get("elements", 1), f"{entry}.elements") * (1 if rigid else refine)
        if len(domain.elements) + n > MAX_ELEMENTS:
            raise rd.fail(f"{entry}.elements", f"{n} elements" + (f" (× refine {refine})" if refine > 1 else "")
                          + f" would exceed the limit of {MAX_ELEMENTS} elements in a model",
                          "use fewer elements (memory and run time grow with the count)")
        sec_name = rd.string(bm["section"], f"{entry}.section")
        if sec_name not in sections:
            close = difflib.get_close_matches(sec_name, list(sections), n=1)
            raise rd.fail(f"{entry}.section", f"no section {show(sec_name)}",
                          f"did you mean '{close[0]}'?" if close else f"defined sections: {', '.join(sections) or 'none'}")
        ends = []
        for side in ("start", "end"):
            if (side in bm) == (f"{side}_node" in bm):
                raise rd.fail(entry, f"give exactly one of '{side}' (coordinates) and '{side}_node' (a node reference)")
            if side in bm:
                ends.append((rd.vector(bm[side], f"{entry}.{side}"), None))
            else:
                node = refs.node(bm[f"{side}_node"], f"{entry}.{side}_node")
                ends.append((node.position, node))
        if np.linalg.norm(ends[1][0] - ends[0][0]) <= 0.0:
            raise rd.fail(entry, "start and end coincide (zero-length beam)")
        axis2 = rd.direction(bm["axis2"], f"{entry}.axis2") if "axis2" in bm else None
        center = rd.vector(bm["center"], f"{entry}.center") if "center" in bm else None
        if center is not None and rigid:
            raise rd.fail(f"{entry}.center", "a rigid bar is straight", "remove `center` or `rigid`")
        family = rd.choice(bm.get("element", DEFAULT_FAMILY), f"{entry}.element", ELEMENT_FAMILIES, "element family")
        if rigid and "element" in bm:
            raise rd.fail(f"{entry}.element", "a rigid bar has no elements", "remove `element` or `rigid`")
        try:
            if rigid:
                if ends[0][1] is not None or ends[1][1] is not None:
                    raise ValueError("a rigid bar is a body of its own: give start/end coordinates, "
                                     "and join it to other bodies with [[joints]]")
                domain.add_rigid_bar(label, ends[0][0], ends[1][0], sections[sec_name], axis2=axis2)
            else:
                domain.add_beam(label, ends[0][0], ends[1][0], n, sections[sec_name], axis2=axis2,
                                start_node=ends[0][1], end_node=ends[1][1], center=center, element=family)
                refs.families[label] = family
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None


def _rigid_bodies(rd: Reader, deck: dict, domain: Domain) -> None:
    """``[[rigid_bodies]]``."""
    for i, rb in enumerate(rd.items(deck, "rigid_bodies")):
        entry = f"rigid_bodies[{i}]"
        rd.keys(rb, entry, required=["label", "mass", "inertia", "position"], optional=["rotation", "points"])
        label = rd.label(rb["label"], f"{entry}.label")
        if label in domain._labels:
            raise rd.fail(f"{entry}.label", f"duplicate label {show(label)}")
        mass = rd.number(rb["mass"], f"{entry}.mass", positive=True)
        inertia = rb["inertia"]
        if isinstance(inertia, list) and len(inertia) == 3 and all(isinstance(r, list) for r in inertia):
            J = np.array([rd.vector(r, f"{entry}.inertia[{k}]") for k, r in enumerate(inertia)])
        else:
            J = np.diag(rd.vector(inertia, f"{entry}.inertia"))
        scale = float(np.abs(J).max())
        if not np.all(np.abs(J - J.T) <= 1e-12 * scale):
            raise rd.fail(f"{entry}.inertia", "the inertia matrix is not symmetric", "give J[a][b] = J[b][a]")
        with np.errstate(all="ignore"):
            eig = np.linalg.eigvalsh(J / scale) if scale > 0.0 and math.isfinite(scale) else np.zeros(3)
        if not np.all(eig > 1e-12):
            raise rd.fail(f"{entry}.inertia", "the inertia matrix is not positive definite",
                          "give positive principal moments, e.g. [J1, J2, J3] with every Ji > 0")
        rot = rd.rotation(rb["rotation"], f"{entry}.rotation") if "rotation" in rb else None
        points = {name: rd.vector(p, f"{entry}.points.{name}")
                  for name, p in rd.tables(rb, "points", f"{entry}.points").items()}
        position = rd.vector(rb["position"], f"{entry}.position")
        try:
            domain.add_rigid_body(label, mass, J, position, rotation=rot, points=points)
        except ValueError as exc:
            raise rd.fail(entry, str(exc), "mass > 0 and a positive definite inertia") from None


def _boundary_conditions(rd: Reader, deck: dict, domain: Domain, refs: _References) -> None:
    """``[[clamps]]`` and ``[[fixed]]``."""
    for i, cl in enumerate(rd.items(deck, "clamps")):
        entry = f"clamps[{i}]"
        rd.keys(cl, entry, required=["node"])
        domain.add_interaction(Clamp(refs.node(cl["node"], f"{entry}.node")))
    for i, fx in enumerate(rd.items(deck, "fixed")):
        entry = f"fixed[{i}]"
        rd.keys(fx, entry, required=["node", "dofs"])
        if not isinstance(fx["dofs"], list) or not fx["dofs"]:
            raise rd.fail(f"{entry}.dofs", "expected a non-empty list", f"names: {', '.join(DOF_NAMES)}")
        dofs = []
        for d in fx["dofs"]:
            dofs.append(DOF_NAMES[rd.choice(d, f"{entry}.dofs", DOF_NAMES, "coordinate",
                                            f"names: {', '.join(DOF_NAMES)}")])
        domain.add_interaction(FixedCoordinates(refs.node(fx["node"], f"{entry}.node"), tuple(dofs)))


def _loads(rd: Reader, deck: dict, domain: Domain, refs: _References) -> None:
    """``[[loads]]``, ``[[line_loads]]`` and ``[gravity]``."""
    beams = refs.beams
    for i, ld in enumerate(rd.items(deck, "loads")):
        entry = f"loads[{i}]"
        rd.keys(ld, entry, required=["node"], optional=["force", "moment", "frame", "time_function", "point"])
        if ("force" in ld) == ("moment" in ld):
            raise rd.fail(entry, "give exactly one of 'force' and 'moment'")
        moment = "moment" in ld
        vec = rd.vector(ld["moment" if moment else "force"], f"{entry}.{'moment' if moment else 'force'}")
        frame = ld.get("frame", "inertial")
        if frame not in ("inertial", "body"):
            raise rd.fail(f"{entry}.frame", f"unknown frame {show(frame)}",
                          "'inertial' (a dead load) or 'body' (a follower load)")
        tf = refs.time_function(ld, entry) or Constant(1.0)
        point = None
        if "point" in ld:
            if moment:
                raise rd.fail(f"{entry}.point", "a moment has no point of application",
                              "give 'point' with a force only (a moment acts on the whole body)")
            point = rd.vector(ld["point"], f"{entry}.point")
        domain.add_interaction(NodalLoad(refs.node(ld["node"], f"{entry}.node"), vec, moment=moment,
                                         follower=frame == "body", time_function=tf, point=point))
    for i, ll in enumerate(rd.items(deck, "line_loads")):
        entry = f"line_loads[{i}]"
        rd.keys(ll, entry, required=["beam"], optional=["force_per_length", "moment_per_length", "frame",
                                                        "time_function"])
        beam = rd.string(ll["beam"], f"{entry}.beam")
        if beam not in beams:
            close = difflib.get_close_matches(beam, list(beams), n=1)
            raise rd.fail(f"{entry}.beam", f"no flexible beam {beam!r}",
                          f"did you mean '{close[0]}'?" if close else f"beams: {', '.join(beams) or 'none'}")
        if "force_per_length" not in ll and "moment_per_length" not in ll:
            raise rd.fail(entry, "give force_per_length and/or moment_per_length")
        frame = rd.choice(ll.get("frame", "inertial"), f"{entry}.frame", ("inertial", "body"), "frame",
                          "'inertial' (a dead load) or 'body' (section-frame components, a follower load)")
        domain.add_interaction(LineLoad(
            beams[beam],
            rd.vector(ll.get("force_per_length", [0.0, 0.0, 0.0]), f"{entry}.force_per_length"),
            moment_per_length=rd.vector(ll.get("moment_per_length", [0.0, 0.0, 0.0]), f"{entry}.moment_per_length"),
            follower=frame == "body", time_function=refs.time_function(ll, entry) or Constant(1.0)))
    if "gravity" in deck:
        rd.keys(deck["gravity"], "gravity", required=["g"])
        domain.add_interaction(Gravity(rd.vector(deck["gravity"]["g"], "gravity.g")))


def _initial_velocities(rd: Reader, deck: dict, refs: _References) -> None:
    """``[[initial_velocities]]``."""
    for i, iv in enumerate(rd.items(deck, "initial_velocities")):
        entry = f"initial_velocities[{i}]"
        rd.keys(iv, entry, required=["node"], optional=["velocity", "angular_velocity"])
        node = refs.node(iv["node"], f"{entry}.node")
        if "velocity" in iv:
            node.velocity = rd.vector(iv["velocity"], f"{entry}.velocity")
        if "angular_velocity" in iv:
            node.angular_velocity = rd.vector(iv["angular_velocity"], f"{entry}.angular_velocity")
