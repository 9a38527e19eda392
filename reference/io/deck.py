"""Model decks (TOML): reading and validation.

The deck is the preprocessor's file of the paper's Domain (§4.3): it lists
sections, nodes, beams, boundary conditions, loads and their time functions,
initial conditions and the solver settings.  Every key is documented in
``docs/deck.md``.  Anything wrong — a typo, a missing reference, a
non-positive stiffness, an unstable time step — raises :class:`DeckError`
with one message naming the file, the entry and the fix.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
import unicodedata
from pathlib import Path

import numpy as np

from reference.algorithms import ALGORITHMS, SolverSettings
from reference.domain import Domain
from reference.elements import Section
from reference.expressions import ExpressionError
from reference.forces import KINDS as SPRING_KINDS
from reference.forces import Bushing, PointToPoint, Rotational
from reference.interactions import (
    Clamp, Constant, Expression, FixedCoordinates, Gravity, LineLoad, NodalLoad, PiecewiseLinear, Ramp, Sine,
    SmoothStep, Step,
)
from reference.joints import Jacobian, MasterSlave
from reference.joints.joint import ROWS as JOINT_KINDS
from reference.monitor import SAFETY
from reference.observables import ObservableError
from reference.observables import parse as parse_observable


class DeckError(ValueError):
    """A deck that cannot be run; the message names the file, the entry and the fix."""


TOP_LEVEL = {"meta", "sections", "time_functions", "nodes", "beams", "rigid_bodies", "joints", "clamps", "fixed",
             "loads", "line_loads", "springs", "gravity", "initial_velocities", "solver", "checks", "crosscheck"}
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
SPRING_KEYS = {
    "point_to_point": (["body_i", "point_i", "stiffness"],
                       ["body_j", "point_j", "damping", "rest_length", "force_function"]),
    "rotational": (["body_i", "stiffness"], ["body_j", "axis", "reference", "damping", "rest_angle"]),
    "bushing": (["body_i", "point", "stiffness"], ["body_j", "axis", "reference", "damping"]),
}
DOF_NAMES = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}
OVERRIDES = {"t_end", "dt", "refine"}

MAX_BYTES = 4 * 2**20
"""Largest deck file [bytes]: decks are hand-written; this bounds the parser's time and memory."""
MAX_NESTING = 32
"""Deepest nesting of arrays and inline tables, and most parts of one dotted key (``a.b.c``)."""
MAX_ELEMENTS = 100_000
"""Most Beam2 elements in one model, after ``refine`` (about 1 GB of model and scratch memory)."""
MAX_STEPS = 10**9
"""Default limit on the number of time steps; ``solver.max_steps`` raises it."""
SUGGEST = 0.8
"""Fraction of the critical estimate used for the dt the messages suggest."""
MAX_MAGNITUDE = 1e30
"""Every number is 0 or of magnitude in [1e-30, 1e30]: no consistent set of units needs more, and the
products the model forms of such numbers (inertias, constraint matrices) stay finite."""
MESSAGE_VALUE = 60
"""Longest rendering of an offending value in a message [characters]."""

_TOKEN = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:\\.|[^"\\\n])*"|\'[^\'\n]*\'|#[^\n]*'
                    r"|[\[{]|[\]}]|(?<![0-9])\.|\.(?![0-9])|\n")


MESSAGE_CHARS = 300
"""Longest message after the file name [characters]."""


def _clip(text: str, n: int) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def _show(value) -> str:
    """``repr(value)``, abbreviated to :data:`MESSAGE_VALUE` characters (huge lists stay readable)."""
    text = repr(value)
    if len(text) <= MESSAGE_VALUE:
        return text
    size = f" ({len(value)} items)" if isinstance(value, (list, dict, str)) else ""
    return text[: MESSAGE_VALUE - 10] + "…" + text[-5:] + size


def _structure_problem(text: str) -> str:
    """Why ``text`` is too deeply nested for the TOML parser, or ``""``.

    Scans brackets and dots outside strings and comments: more than :data:`MAX_NESTING` open
    ``[``/``{`` at once, or a dotted key of more than :data:`MAX_NESTING` parts on one line,
    would send :mod:`tomllib` into deep recursion or gigabytes of nested tables.
    """
    depth = deepest = dots = 0
    line = 1
    for m in _TOKEN.finditer(text):
        tok = m.group()
        if tok in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return f"line {line}: arrays or inline tables nested more than {MAX_NESTING} deep"
        elif tok in "]}":
            depth = max(depth - 1, 0)
        elif tok == ".":
            dots += 1
            if dots >= MAX_NESTING:
                return f"line {line}: a dotted key of more than {MAX_NESTING} parts"
        elif tok == "\n":
            line, dots = line + 1, 0
        else:
            line += tok.count("\n")
    return ""


class _Reader:
    """Validation helpers that know the file name for their messages."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, entry: str, problem: str, fix: str = "") -> DeckError:
        """``FILE: ENTRY: problem; fix``; the part after the file name is kept to :data:`MESSAGE_CHARS`."""
        entry = _clip(entry, 60)
        room = MESSAGE_CHARS - len(entry) - 4
        if len(problem) + len(fix) > room:
            fix = _clip(fix, max(room // 3, room - len(problem)))
            problem = _clip(problem, room - len(fix))
        return DeckError(f"{self.path}: {entry}: {problem}" + (f"; {fix}" if fix else ""))

    def label(self, value, entry: str) -> str:
        """A name used in references, messages and file names: printable, no path separators."""
        self.string(value, entry)
        bad = [c for c in value if unicodedata.category(c)[0] == "C" or c in "/\\"]
        if not value.strip() or bad or value in (".", "..") or len(value) > 200:
            raise self.fail(entry, f"unusable name {_show(value)}",
                            "give 1–200 printable characters without '/' or '\\' (e.g. 'arm_2')")
        return value

    def keys(self, table, entry: str, required=(), optional=()) -> None:
        if not isinstance(table, dict):
            raise self.fail(entry, f"expected a table, got {type(table).__name__}")
        allowed = list(required) + list(optional)
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1)
                hint = f"did you mean '{close[0]}'?" if close else f"valid keys: {', '.join(allowed)}"
                raise self.fail(f"{entry}.{key}", "unknown key", hint)
        for key in required:
            if key not in table:
                raise self.fail(entry, f"missing required key '{key}'", f"required keys: {', '.join(required)}")

    def number(self, value, entry: str, positive=False, nonnegative=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(entry, f"expected a number, got {_show(value)}")
        if value != 0 and not 1.0 / MAX_MAGNITUDE <= abs(value) <= MAX_MAGNITUDE:
            raise self.fail(entry, f"{value:g} is outside the range of the format (0 or a magnitude from "
                            f"{1 / MAX_MAGNITUDE:g} to {MAX_MAGNITUDE:g})", "check the units")
        if positive and not value > 0:
            raise self.fail(entry, f"must be positive, got {_show(value)}", "give a value > 0")
        if nonnegative and value < 0:
            raise self.fail(entry, f"must not be negative, got {_show(value)}")
        return float(value)

    def integer(self, value, entry: str, minimum=1, maximum=None, fix: str = "") -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(entry, f"expected an integer ≥ {minimum}, got {_show(value)}")
        if maximum is not None and value > maximum:
            raise self.fail(entry, f"{value} is above the limit of {maximum}", fix)
        return int(value)

    def vector(self, value, entry: str, n=3) -> np.ndarray:
        if not isinstance(value, list) or len(value) != n:
            raise self.fail(entry, f"expected a list of {n} numbers, got {_show(value)}")
        return np.array([self.number(v, f"{entry}[{i}]") for i, v in enumerate(value)])

    def direction(self, value, entry: str) -> np.ndarray:
        """A non-zero 3-vector (a joint axis, a section axis)."""
        vec = self.vector(value, entry)
        if not math.hypot(*vec) > 0.0:
            raise self.fail(entry, "a direction cannot be the zero vector", "give a non-zero direction, e.g. [0, 0, 1]")
        return vec

    def rotation(self, value, entry: str) -> np.ndarray:
        """Euler parameters of unit norm (within 1e-6)."""
        rot = self.vector(value, entry, 4)
        norm = math.hypot(*rot)
        if not abs(norm - 1.0) <= 1e-6:
            raise self.fail(entry, f"Euler parameters must have unit norm, got |q| = {norm:.6g}",
                            "normalise them (identity: [1, 0, 0, 0])")
        return rot

    def string(self, value, entry: str) -> str:
        if not isinstance(value, str):
            raise self.fail(entry, f"expected a string, got {_show(value)}")
        return value

    def boolean(self, value, entry: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(entry, f"expected true or false, got {_show(value)}")
        return value

    def choice(self, value, entry: str, options, what: str = "value", describe: str = "") -> str:
        """A string that must be one of ``options``; the fix is a close match or the list (or ``describe``)."""
        if not isinstance(value, str) or value not in options:
            close = difflib.get_close_matches(value, list(options), n=1) if isinstance(value, str) else []
            raise self.fail(entry, f"unknown {what} {_show(value)}",
                            f"did you mean '{close[0]}'?" if close else describe or f"one of: {', '.join(options)}")
        return value

    def tables(self, parent, key, entry: str | None = None) -> dict:
        """A table of named entries (``[sections.NAME]``, ``points.NAME``)."""
        value = parent.get(key, {})
        if not isinstance(value, dict):
            raise self.fail(entry or key, f"expected a table of named entries, got {_show(value)}",
                            f"write it as [{key}.NAME]" if entry is None else "write it as {NAME = ..., ...}")
        return value

    def items(self, deck, key) -> list:
        value = deck.get(key, [])
        if not isinstance(value, list):
            raise self.fail(key, "expected an array of tables", f"write it as [[{key}]]")
        return value


def _whole_steps(t_end: float, dt: float) -> bool:
    steps = t_end / dt
    if not steps < 2.0**62:
        return False
    return abs(steps - round(steps)) <= 1e-9 * max(steps, 1.0) and round(steps) >= 1


def _suggest_dt(t_end: float, limit: float) -> str:
    """A step ≤ ``limit`` that divides ``t_end``: a round number (1, 2, 2.5, 4, 5 × 10^k) if one
    does, else t_end / N to full precision."""
    if not (limit > 0.0 and math.isfinite(limit) and t_end / limit < 2.0**62):
        return f"a step that gives at most {MAX_STEPS:.0e} steps to t_end = {t_end:g}"
    for k in range(math.floor(math.log10(limit)), math.floor(math.log10(limit)) - 3, -1):
        for m in (5.0, 4.0, 2.5, 2.0, 1.0):
            dt = float(f"{m}e{k}")
            if dt <= limit and _whole_steps(t_end, dt):
                return f"dt = {dt:g} ({round(t_end / dt)} steps to t_end = {t_end:g})"
    n = math.ceil(t_end / limit)
    return f"dt = {t_end / n!r} ({n} steps to t_end = {t_end:g})"


def _override_scalar(deck: dict, key: str, value, rd: _Reader) -> None:
    """Set the deck value named ``key`` (dotted: tables by name, arrays of tables by index,
    e.g. ``solver.damping``, ``sections.rollup.EI2``, ``beams.0.elements``) to ``value``.

    The target's table must exist; the value must be a number, string or boolean and, when the
    deck gives the entry, of the same kind.  The deck is then validated as written.
    """
    entry = f"override {key}"
    if not isinstance(value, (int, float, str)):  # bool is an int
        raise rd.fail(entry, f"expected a number, a string or a boolean, got {value!r}")
    parts = key.split(".")
    if any(not p for p in parts):
        raise rd.fail(entry, "empty part in the dotted name", "write e.g. solver.damping")
    table = deck
    for depth, part in enumerate(parts[:-1]):
        here = ".".join(parts[: depth + 1])
        if isinstance(table, list):
            if not part.isdigit() or int(part) >= len(table):
                raise rd.fail(entry, f"{here}: no entry {part!r} in an array of {len(table)}",
                              f"index it 0 … {len(table) - 1}")
            table = table[int(part)]
        elif isinstance(table, dict) and part in table and isinstance(table[part], (dict, list)):
            table = table[part]
        else:
            options = [k for k, v in table.items() if isinstance(v, (dict, list))] if isinstance(table, dict) else []
            close = difflib.get_close_matches(part, options, n=1)
            raise rd.fail(entry, f"the deck has no table {here!r}",
                          f"did you mean '{close[0]}'?" if close else f"tables here: {', '.join(options) or 'none'}")
    if not isinstance(table, dict):
        raise rd.fail(entry, f"{'.'.join(parts[:-1])} is an array", "name one of its entries by index, e.g. beams.0.elements")
    old = table.get(parts[-1])
    if isinstance(old, (dict, list)):
        raise rd.fail(entry, f"{key} is a table or an array, not a single value", "name one of its values")
    kind = lambda v: "boolean" if isinstance(v, bool) else "number" if isinstance(v, (int, float)) else "string"  # noqa: E731
    if old is not None and kind(old) != kind(value):
        raise rd.fail(entry, f"the deck's {key} is a {kind(old)}, the override a {kind(value)} ({value!r})",
                      f"give a {kind(old)}")
    table[parts[-1]] = value


def _observable(rd: _Reader, text, entry: str, domain: Domain):
    """Check an observable text against the model (``reference/observables.py``): one-line DeckError."""
    if not isinstance(text, str):
        raise rd.fail(entry, f"expected an observable text, got {_show(text)}",
                      "e.g. 'position:beam:end'; free text goes in 'description' (docs/observables.md)")
    try:
        return parse_observable(text, domain)
    except ObservableError as exc:
        raise rd.fail(entry, f"{text!r}: {exc}", "" if ";" in str(exc) else "see docs/observables.md") from None


def load_deck(path, overrides: dict | None = None) -> Domain:
    """Read and validate a deck; return a ready-to-solve :class:`~reference.domain.Domain`.

    Parameters
    ----------
    path : path-like
    overrides : dict, optional
        ``t_end``, ``dt`` (replace the deck's; a step smaller by a whole factor
        keeps the deck's output times), ``refine`` (an integer multiplying every
        flexible beam's element count; the step is divided and the output
        interval multiplied by it, so output times stay the same); and any deck
        value by its dotted name (``solver.damping``, ``sections.NAME.EI2``,
        ``beams.0.elements``; see :func:`_override_scalar`), validated as if written
        in the deck.
    """
    path = Path(path)
    if not path.is_file():
        raise DeckError(f"{path}: no such deck file" + ("" if not path.exists() else " (it is a directory)"))
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise DeckError(f"{path}: the file is {size / 2**20:.1f} MB, above the deck limit of "
                        f"{MAX_BYTES / 2**20:.0f} MB; is it a deck? (decks are hand-written TOML of a few kB)")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise DeckError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); "
                        "save the deck as UTF-8") from None
    rd = _Reader(path)
    problem = _structure_problem(text)
    if problem:
        raise DeckError(f"{path}: {problem}; flatten the structure (a deck needs at most 3 levels)")
    try:
        deck = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DeckError(f"{path}: not valid TOML: {exc}") from None
    except (RecursionError, MemoryError):
        raise DeckError(f"{path}: not a usable deck: too deeply nested for the TOML parser; "
                        "flatten the structure") from None
    overrides = dict(overrides or {})
    for key in list(overrides):
        if "." in key:
            _override_scalar(deck, key, overrides.pop(key), rd)
        elif key not in OVERRIDES:
            raise DeckError(f"{path}: unknown override {key!r}; valid: {', '.join(sorted(OVERRIDES))} or the "
                            "dotted name of a deck value, e.g. solver.damping or sections.NAME.EI2")
    refine = rd.integer(overrides.get("refine", 1), "override refine")


    for key in overrides:
        if key not in OVERRIDES:
            raise DeckError(f"{path}: unknown override {_show(key)}; valid: {', '.join(sorted(OVERRIDES))}")
    refine = rd.integer(overrides.get("refine", 1), "override refine (--refine)", maximum=MAX_ELEMENTS,
                        fix=f"a model has at most {MAX_ELEMENTS} elements")
    rd.keys(deck, "deck", optional=sorted(TOP_LEVEL))

    meta = deck.get("meta", {})
    rd.keys(meta, "meta", required=["name"], optional=["description", "units", "provenance", "notes"])
    for key in ("description", "units", "notes"):
        if key in meta:
            rd.string(meta[key], f"meta.{key}")
    if "provenance" in meta and not isinstance(meta["provenance"], (str, dict)):
        raise rd.fail("meta.provenance", f"expected a string or a table, got {_show(meta['provenance'])}",
                      'e.g. provenance = { paper = "...", figures = "...", data = "..." }')
    domain = Domain(rd.label(meta["name"], "meta.name"), meta.get("description", ""))
    domain.metadata = dict(meta)
    domain.deck_text, domain.deck_path = text, str(path)

    sections = {}
    for name, sec in rd.tables(deck, "sections").items():
        entry = f"sections.{name}"
        rd.keys(sec, entry, required=SECTION_KEYS)
        values = {k: rd.number(sec[k], f"{entry}.{k}", positive=True) for k in SECTION_KEYS}
        sections[name] = Section(**values)

    tfs = {}
    for name, tf in rd.tables(deck, "time_functions").items():
        entry = f"time_functions.{name}"
        if not isinstance(tf, dict):
            raise rd.fail(entry, f"expected a table, got {_show(tf)}", f"write it as [{entry}] with kind = ...")
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

    beams = {}

    def node_ref(ref, entry):
        if not isinstance(ref, str):
            raise rd.fail(entry, f"expected a node reference (a label like 'beam:end'), got {_show(ref)}")
        if ":" in ref:
            beam, _, which = ref.rpartition(":")
            if beam in beams:
                nodes = beams[beam]
                if which == "start":
                    return nodes[0]
                if which == "end":
                    return nodes[-1]
                if which.isascii() and which.isdigit() and int(which) < len(nodes):
                    return nodes[int(which)]
                raise rd.fail(entry, f"beam '{beam}' has no node {_show(which)}",
                              f"use '{beam}:start', '{beam}:end' or an index 0…{len(nodes) - 1}")
        try:
            return domain.node(ref)
        except KeyError:
            labels = [n.label for n in domain.nodes]
            close = difflib.get_close_matches(ref, labels + [f"{b}:start" for b in beams] + [f"{b}:end" for b in beams], n=1)
            raise rd.fail(entry, f"no node {_show(ref)}", f"did you mean '{close[0]}'?" if close else
                          "reference a node label or '<beam>:start', '<beam>:end', '<beam>:<i>'") from None

    def time_function(table, entry):
        """The time function named by ``table['time_function']`` (None if absent)."""
        key = next((k for k in ("time_function", "force_function") if k in table), None)
        if key is None:
            return None
        name = rd.string(table[key], f"{entry}.{key}")
        if name not in tfs:
            close = difflib.get_close_matches(name, list(tfs), n=1)
            raise rd.fail(f"{entry}.{key}", f"no time function {_show(name)}",
                          f"did you mean '{close[0]}'?" if close else f"defined: {', '.join(tfs) or 'none'}")
        return tfs[name]

    for i, nd in enumerate(rd.items(deck, "nodes")):
        entry = f"nodes[{i}]"
        rd.keys(nd, entry, required=["label", "position"], optional=["rotation"])
        rot = rd.rotation(nd["rotation"], f"{entry}.rotation") if "rotation" in nd else None
        label = rd.label(nd["label"], f"{entry}.label")
        if label in domain._labels:
            raise rd.fail(f"{entry}.label", f"duplicate node label {_show(label)}")
        domain.add_node(rd.vector(nd["position"], f"{entry}.position"), rot, label)

    for i, bm in enumerate(rd.items(deck, "beams")):
        entry = f"beams[{i}]"
        rd.keys(bm, entry, required=["label", "elements", "section"],
                optional=["start", "end", "start_node", "end_node", "axis2", "rigid", "center"])
        label = rd.label(bm["label"], f"{entry}.label")
        if label in beams:
            raise rd.fail(f"{entry}.label", f"duplicate beam label {_show(label)}")
        rigid = rd.boolean(bm.get("rigid", False), f"{entry}.rigid")
        n = rd.integer(bm["elements"], f"{entry}.elements") * (1 if rigid else refine)
        if len(domain.elements) + n > MAX_ELEMENTS:
            raise rd.fail(f"{entry}.elements", f"{n} elements" + (f" (× refine {refine})" if refine > 1 else "")
                          + f" would exceed the limit of {MAX_ELEMENTS} elements in a model",
                          "use fewer elements (memory and run time grow with the count)")
        sec_name = rd.string(bm["section"], f"{entry}.section")
        if sec_name not in sections:
            close = difflib.get_close_matches(sec_name, list(sections), n=1)
            raise rd.fail(f"{entry}.section", f"no section {_show(sec_name)}",
                          f"did you mean '{close[0]}'?" if close else f"defined sections: {', '.join(sections) or 'none'}")
        ends = []
        for side in ("start", "end"):
            if (side in bm) == (f"{side}_node" in bm):
                raise rd.fail(entry, f"give exactly one of '{side}' (coordinates) and '{side}_node' (a node reference)")
            if side in bm:
                ends.append((rd.vector(bm[side], f"{entry}.{side}"), None))
            else:
                node = node_ref(bm[f"{side}_node"], f"{entry}.{side}_node")
                ends.append((node.position, node))
        if np.linalg.norm(ends[1][0] - ends[0][0]) <= 0.0:
            raise rd.fail(entry, "start and end coincide (zero-length beam)")
        axis2 = rd.direction(bm.get("axis2", [0.0, 1.0, 0.0]), f"{entry}.axis2")
        center = rd.vector(bm["center"], f"{entry}.center") if "center" in bm else None
        if center is not None and rigid:
            raise rd.fail(f"{entry}.center", "a rigid bar is straight", "remove `center` or `rigid`")
        try:
            if rigid:
                if ends[0][1] is not None or ends[1][1] is not None:
                    raise ValueError("a rigid bar is a body of its own: give start/end coordinates, "
                                     "and join it to other bodies with [[joints]]")
                domain.add_rigid_bar(label, ends[0][0], ends[1][0], sections[sec_name], axis2)
            else:
                beams[label] = domain.add_beam(label, ends[0][0], ends[1][0], n, sections[sec_name], axis2,
                                               start_node=ends[0][1], end_node=ends[1][1], center=center)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None

    for i, rb in enumerate(rd.items(deck, "rigid_bodies")):
        entry = f"rigid_bodies[{i}]"
        rd.keys(rb, entry, required=["label", "mass", "inertia", "position"], optional=["rotation", "points"])
        label = rd.label(rb["label"], f"{entry}.label")
        if label in domain._labels:
            raise rd.fail(f"{entry}.label", f"duplicate label {_show(label)}")
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
            domain.add_rigid_body(label, mass, J, position, rot, points)
        except ValueError as exc:
            raise rd.fail(entry, str(exc), "mass > 0 and a positive definite inertia") from None

    for i, cl in enumerate(rd.items(deck, "clamps")):
        entry = f"clamps[{i}]"
        rd.keys(cl, entry, required=["node"])
        domain.add_interaction(Clamp(node_ref(cl["node"], f"{entry}.node")))
    for i, fx in enumerate(rd.items(deck, "fixed")):
        entry = f"fixed[{i}]"
        rd.keys(fx, entry, required=["node", "dofs"])
        if not isinstance(fx["dofs"], list) or not fx["dofs"]:
            raise rd.fail(f"{entry}.dofs", "expected a non-empty list", f"names: {', '.join(DOF_NAMES)}")
        dofs = []
        for d in fx["dofs"]:
            dofs.append(DOF_NAMES[rd.choice(d, f"{entry}.dofs", DOF_NAMES, "coordinate",
                                            f"names: {', '.join(DOF_NAMES)}")])
        domain.add_interaction(FixedCoordinates(node_ref(fx["node"], f"{entry}.node"), tuple(dofs)))

    for i, ld in enumerate(rd.items(deck, "loads")):
        entry = f"loads[{i}]"
        rd.keys(ld, entry, required=["node"], optional=["force", "moment", "frame", "time_function", "point"])
        if ("force" in ld) == ("moment" in ld):
            raise rd.fail(entry, "give exactly one of 'force' and 'moment'")
        moment = "moment" in ld
        vec = rd.vector(ld["moment" if moment else "force"], f"{entry}.{'moment' if moment else 'force'}")
        frame = ld.get("frame", "inertial")
        if frame not in ("inertial", "body"):
            raise rd.fail(f"{entry}.frame", f"unknown frame {_show(frame)}",
                          "'inertial' (a dead load) or 'body' (a follower load)")
        tf = time_function(ld, entry) or Constant(1.0)
        point = None
        if "point" in ld:
            if moment:
                raise rd.fail(f"{entry}.point", "a moment has no point of application",
                              "give 'point' with a force only (a moment acts on the whole body)")
            point = rd.vector(ld["point"], f"{entry}.point")
        domain.add_interaction(NodalLoad(node_ref(ld["node"], f"{entry}.node"), vec, moment, frame == "body", tf,
                                         point))
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
            rd.vector(ll.get("moment_per_length", [0.0, 0.0, 0.0]), f"{entry}.moment_per_length"),
            frame == "body", time_function(ll, entry) or Constant(1.0)))
    if "gravity" in deck:
        rd.keys(deck["gravity"], "gravity", required=["g"])
        domain.add_interaction(Gravity(rd.vector(deck["gravity"]["g"], "gravity.g")))

    for i, jt in enumerate(rd.items(deck, "joints")):
        entry = f"joints[{i}]"
        rd.keys(jt, entry, required=["kind", "body_i", "point"],
                optional=["label", "body_j", "axis", "reference", "epsilon", "formulation", "time_function", "mode"])
        kind = rd.string(jt["kind"], f"{entry}.kind")
        if kind not in JOINT_KINDS:
            close = difflib.get_close_matches(kind, list(JOINT_KINDS), n=1)
            raise rd.fail(f"{entry}.kind", f"unknown joint kind {_show(kind)}",
                          f"did you mean '{close[0]}'?" if close else f"one of: {', '.join(JOINT_KINDS)}")
        formulation = jt.get("formulation", "jacobian")
        if formulation not in ("jacobian", "master_slave"):
            raise rd.fail(f"{entry}.formulation", f"unknown joint formulation {_show(formulation)}",
                          "'jacobian' (Lagrange multipliers, stabilised) or 'master_slave' (elimination; "
                          "spherical and revolute joints, slave = body_i a beam node)")
        body_i = node_ref(jt["body_i"], f"{entry}.body_i")
        body_j = None
        if jt.get("body_j", "ground") != "ground":
            body_j = node_ref(jt["body_j"], f"{entry}.body_j")
        if body_j is body_i:
            raise rd.fail(entry, "body_i and body_j are the same body")
        drive = kind.endswith("_drive")
        if drive and "time_function" not in jt:
            raise rd.fail(entry, f"a {kind} needs a time_function (the prescribed motion or its rate)")
        if not drive and ("time_function" in jt or "mode" in jt):
            raise rd.fail(entry, "time_function and mode apply to rotation_drive and displacement_drive only")
        tf = None
        if drive:
            name = rd.string(jt["time_function"], f"{entry}.time_function")
            if name not in tfs:
                raise rd.fail(f"{entry}.time_function", f"no time function {_show(name)}", f"defined: {', '.join(tfs) or 'none'}")
            tf = tfs[name]
        mode = jt.get("mode", "position")
        if mode not in ("position", "velocity"):
            raise rd.fail(f"{entry}.mode", f"unknown mode {_show(mode)}",
                          "'position' (the time function is the angle/displacement) or 'velocity' (its rate)")
        if tf is not None and mode == "velocity" and isinstance(tf, Expression) and not tf.with_integral:
            try:
                tf = tfs[jt["time_function"]] = Expression(tf.expr, with_integral=True)
            except ExpressionError as exc:
                raise rd.fail(f"time_functions.{jt['time_function']}.expr", str(exc)) from None
        eps = rd.number(jt.get("epsilon", 0.0), f"{entry}.epsilon", nonnegative=True)
        reference = rd.vector(jt["reference"], f"{entry}.reference") if "reference" in jt else None
        label = rd.label(jt.get("label", f"{kind}:{i}"), f"{entry}.label")
        point = rd.vector(jt["point"], f"{entry}.point")
        axis = rd.direction(jt.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis")
        if reference is not None:
            reference = rd.direction(jt["reference"], f"{entry}.reference")
        try:
            domain.add_joint(kind, body_i, body_j, point, axis, reference,
                             formulation=Jacobian(eps) if formulation == "jacobian" else MasterSlave(),
                             time_function=tf, mode=mode, label=label)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None

    for i, sp in enumerate(rd.items(deck, "springs")):
        entry = f"springs[{i}]"
        if not isinstance(sp, dict) or "kind" not in sp:
            raise rd.fail(entry, "missing required key 'kind'", f"one of: {', '.join(SPRING_KINDS)}")
        kind = rd.choice(sp["kind"], f"{entry}.kind", SPRING_KINDS, "spring kind")
        required, optional = SPRING_KEYS[kind]
        rd.keys(sp, entry, required=["kind"] + required, optional=["label"] + optional)
        label = rd.string(sp.get("label", f"{kind}:{i}"), f"{entry}.label")
        body_i = node_ref(sp["body_i"], f"{entry}.body_i")
        body_j = None if sp.get("body_j", "ground") == "ground" else node_ref(sp["body_j"], f"{entry}.body_j")
        if body_j is body_i:
            raise rd.fail(entry, "body_i and body_j are the same body", "connect two bodies, or a body and \"ground\"")
        if kind == "bushing":
            stiffness = rd.vector(sp["stiffness"], f"{entry}.stiffness", 6)
            damping = rd.vector(sp.get("damping", [0.0] * 6), f"{entry}.damping", 6)
            for name, values in (("stiffness", stiffness), ("damping", damping)):
                if np.any(values < 0.0):
                    raise rd.fail(f"{entry}.{name}", f"must not be negative, got {values.tolist()}",
                                  "give six values ≥ 0 (three translational, three rotational)")
        else:
            stiffness = rd.number(sp["stiffness"], f"{entry}.stiffness", nonnegative=True)
            damping = rd.number(sp.get("damping", 0.0), f"{entry}.damping", nonnegative=True)
        try:
            if kind == "point_to_point":
                rest = sp.get("rest_length")
                element = PointToPoint(
                    body_i, rd.vector(sp["point_i"], f"{entry}.point_i"), body_j,
                    rd.vector(sp.get("point_j", [0.0, 0.0, 0.0]), f"{entry}.point_j"), stiffness, damping,
                    None if rest is None else rd.number(rest, f"{entry}.rest_length", positive=True),
                    time_function(sp, entry), label)
            elif kind == "rotational":
                element = Rotational(
                    body_i, body_j, rd.vector(sp.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis"), stiffness, damping,
                    rd.number(sp.get("rest_angle", 0.0), f"{entry}.rest_angle"),
                    rd.vector(sp["reference"], f"{entry}.reference") if "reference" in sp else None, label)
            else:
                element = Bushing(
                    body_i, body_j, rd.vector(sp["point"], f"{entry}.point"),
                    rd.vector(sp.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis"),
                    rd.vector(sp["reference"], f"{entry}.reference") if "reference" in sp else None,
                    stiffness, damping, label)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None
        domain.add_force_element(element)

    for i, iv in enumerate(rd.items(deck, "initial_velocities")):
        entry = f"initial_velocities[{i}]"
        rd.keys(iv, entry, required=["node"], optional=["velocity", "angular_velocity"])
        node = node_ref(iv["node"], f"{entry}.node")
        if "velocity" in iv:
            node.velocity = rd.vector(iv["velocity"], f"{entry}.velocity")
        if "angular_velocity" in iv:
            node.angular_velocity = rd.vector(iv["angular_velocity"], f"{entry}.angular_velocity")

    if "solver" not in deck:
        raise rd.fail("solver", "missing [solver] table", "give at least dt and t_end")
    sv = deck["solver"]
    if not isinstance(sv, dict):
        raise rd.fail("solver", f"expected a table, got {type(sv).__name__}")
    algorithm = rd.choice(sv.get("algorithm", SolverSettings.algorithm), "solver.algorithm", ALGORITHMS, "algorithm")
    algo_cls = ALGORITHMS[algorithm]
    rd.keys(sv, "solver", required=algo_cls.deck_required, optional=["algorithm", *algo_cls.deck_optional])
    dt_entry = "dt override (--dt)" if "dt" in overrides else "solver.dt"
    t_entry = "t_end override (--t-end)" if "t_end" in overrides else "solver.t_end"
    t_end = rd.number(overrides.get("t_end", sv["t_end"]), t_entry, positive=True)
    load_steps = rd.integer(sv.get("load_steps", 1), "solver.load_steps")
    # the explicit step shrinks with the refined mesh; an implicit step does not
    mesh_factor = refine if algo_cls.explicit else 1
    deck_dt = rd.number(sv["dt"], "solver.dt", positive=True) / mesh_factor if "dt" in sv else t_end / load_steps
    dt = rd.number(overrides.get("dt", deck_dt), dt_entry, positive=True)
    # keep the deck's output times when the step is overridden by a whole factor
    ratio = deck_dt / dt
    output_scale = int(round(ratio)) if 1 <= ratio < 2.0**62 and abs(ratio - round(ratio)) < 1e-9 else 1
    rho_inf = rd.number(sv.get("rho_inf", 0.8), "solver.rho_inf", nonnegative=True)
    if rho_inf > 1.0:
        raise rd.fail("solver.rho_inf", f"must lie in [0, 1], got {rho_inf!r}",
                      "1 keeps every frequency undamped, 0 annihilates the highest in one step; 0.8 is usual")
    domain.solver = SolverSettings(
        algorithm=algorithm, dt=dt, t_end=t_end,
        damping=rd.number(sv.get("damping", 0.0), "solver.damping", nonnegative=True),
        output_every=rd.integer(sv.get("output_every", 1), "solver.output_every") * mesh_factor * output_scale,
        consistent_initial_velocities=rd.boolean(sv.get("consistent_initial_velocities", False),
                                                 "solver.consistent_initial_velocities"),
        load_steps=load_steps, rho_inf=rho_inf,
        tolerance=rd.number(sv["tolerance"], "solver.tolerance", positive=True) if "tolerance" in sv else None,
        max_iterations=rd.integer(sv["max_iterations"], "solver.max_iterations") if "max_iterations" in sv else None,
    )
    max_steps = rd.integer(sv.get("max_steps", MAX_STEPS), "solver.max_steps")
    unsafe = rd.boolean(sv.get("allow_unsafe_dt", False), "solver.allow_unsafe_dt")
    if not domain.elements and not domain.nodes:
        raise rd.fail("deck", "the deck defines no nodes or beams")
    crit = domain.critical_time_step()
    if not crit > 0.0:
        raise rd.fail("sections", f"the critical time step of the mesh is {crit:g} (a stiffness so large against "
                      "the mass that no step is stable)", "check the units of the section data")
    if algo_cls.explicit and dt > SAFETY * crit and not unsafe:
        raise rd.fail(dt_entry, f"dt = {dt:g} is above the critical time step {crit:.4g} of the explicit scheme "
                      f"× {SAFETY:g} (the safety margin)",
                      f"use dt ≤ {SUGGEST * crit:.3g}, e.g. {_suggest_dt(t_end, SUGGEST * crit)}"
                      if t_end / (SUGGEST * crit) <= max_steps else
                      f"a stable step needs {t_end / (SUGGEST * crit):.3g} steps, above the limit of {max_steps:.3g}: "
                      "check the units of the section data, or raise solver.max_steps")
    steps = t_end / dt
    if not steps <= max_steps:
        raise rd.fail(t_entry if "t_end" in overrides else dt_entry if "dt" in overrides else "solver",
                      f"t_end / dt = {t_end:g} / {dt:g} = {steps:.3g} steps, above the limit of {max_steps:.3g}",
                      "use a larger dt or a shorter t_end, or raise solver.max_steps if the run is meant")
    if not _whole_steps(t_end, dt):
        steps = t_end / dt
        raise rd.fail(t_entry, f"t_end = {t_end:g} is not a whole number of steps dt = {dt:g} ({steps:.6g} steps)",
                      f"use t_end = {max(round(steps), 1) * dt:.10g} or {_suggest_dt(t_end, dt)}")
    checks = rd.tables(deck, "checks")
    for name, spec in checks.items():
        if not isinstance(spec, dict):
            raise rd.fail(f"checks.{name}", f"expected a table, got {_show(spec)}", f"write it as [checks.{name}]")
        if "observable" in spec:
            _observable(rd, spec["observable"], f"checks.{name}.observable", domain)
    domain.checks = checks
    crosscheck = rd.tables(deck, "crosscheck")
    for name, spec in crosscheck.items():
        entry = f"crosscheck.{name}"
        rd.keys(spec, entry, required=["observable", "tolerance", "reason"], optional=["relative_to", "refine"])
        _observable(rd, spec["observable"], f"{entry}.observable", domain)
        rd.number(spec["tolerance"], f"{entry}.tolerance", positive=True)
        rd.string(spec["reason"], f"{entry}.reason")
        if spec.get("relative_to", "absolute") not in ("length", "peak", "absolute"):
            raise rd.fail(f"{entry}.relative_to", f"unknown scale {_show(spec['relative_to'])}", "'length', 'peak' or 'absolute'")
        rd.integer(spec.get("refine", 1), f"{entry}.refine")
    domain.crosscheck = crosscheck
    try:
        model = domain.initialization()
    except ValueError as exc:
        raise rd.fail("model", str(exc)) from None
    problem = algo_cls.refusal(model)
    if problem:
        raise rd.fail("solver.algorithm", f"{algorithm!r} cannot run this model: {problem}")
    return domain
