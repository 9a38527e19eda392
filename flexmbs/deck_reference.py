"""The deck's key tables, generated from the deck reader itself (the documentation's deck reference).

Nothing here restates a key: every deck in ``models/`` is read by
:func:`reference.io.deck.load_deck` with a recording :class:`~reference.io.deck_reader.Reader`,
which notes every table's allowed and required keys (``Reader.keys``), every value's check
(``Reader.number``, ``vector``, ``integer``, ``choice`` …, with their ranges and options), the
value the reader used when a deck left a key out (its default), and which keys name nodes or time
functions.  The keys of the kinds (time functions, springs) and of the algorithms come from the
registries the reader looks them up in (``TIME_FUNCTIONS``, ``SPRING_KEYS``, ``ALGORITHMS``).  The
message column is the reader's own message for a wrong value of that key.  Keys and tables that no
gallery deck uses (a joint's ``reference``, ``[[prescribed_displacements]]``) are read from the small
decks of :data:`PROBES` as well; the free keys of ``[checks.NAME]``, which the reader passes on to
``flexmbs report``, are those the gallery decks use.  A key's meaning is the deck page's own
(its ``| key | meaning |`` tables, ``docs/deck.md``), or, for the tables that page describes in prose,
:data:`MEANINGS`.

``python -m flexmbs.deck_reference`` prints the Markdown; the documentation build writes it into
the deck reference page (``docs/conf.py``).
"""

from __future__ import annotations

import re
from contextlib import contextmanager
from pathlib import Path

import numpy as np

import reference.io.deck as deck_module
from reference.algorithms import ALGORITHMS
from reference.io.deck_connectors import SPRING_KEYS
from reference.io.deck_reader import DeckError, Reader
from reference.io.deck_reduce import collecting

ROOT = Path(__file__).resolve().parent.parent
NAMED = {"sections", "time_functions", "checks", "crosscheck"}
"""Tables of named entries (``[sections.NAME]``): the name is not a key."""
KINDS = {"time_functions": "kind", "springs": "kind", "solver": "algorithm"}
"""Tables whose keys depend on the value of one key: one key table per value."""
COMMON_KEYS = {"[solver]": ("backend",)}
"""Keys that every value of such a table's key takes: rows of the table itself, beside that key."""
SUBTABLES = {"reduce"}
"""Tables of fixed keys inside an entry (``[[beams]]``'s ``reduce``): each key a row ``reduce.modes`` of the
entry's table."""
_ENTRY = re.compile(r"^(?P<table>[a-z_]+)(?P<index>\[\d+\])?(?:\.(?P<rest>.+))?$")
_BAD = {"number": "x", "integer": 0, "vector": [1.0], "direction": [0.0, 0.0, 0.0], "rotation": [1.0, 1.0, 0.0, 0.0],
        "string": 1, "boolean": "yes", "choice": "?", "label": "a/b"}
"""A wrong value for each check, to show the reader's message for it."""
_SECTION = """[sections.bar]
EA = 1.0
GA2 = 1.0
GA3 = 1.0
GJ = 1.0
EI2 = 1.0
EI3 = 1.0
rhoA = 1.0
rhoJ1 = 0.01
rhoJ2 = 0.01
rhoJ3 = 0.01
"""
"""The probes' section."""
PROBES = ("""
[meta]
name = "probe"
""" + _SECTION + """[time_functions.turn]
kind = "ramp"
t0 = 0.0
t1 = 1.0
[[beams]]
label = "crank"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
section = "bar"
rigid = true
[[rigid_bodies]]
label = "slider"
mass = 1.0
inertia = [0.01, 0.01, 0.01]
position = [2.0, 0.0, 0.0]
[[joints]]
kind = "revolute"
body_i = "crank"
point = [0.0, 0.0, 0.0]
reference = [1.0, 0.0, 0.0]
[[joints]]
kind = "rotation_drive"
body_i = "crank"
point = [0.0, 0.0, 0.0]
reference = [1.0, 0.0, 0.0]
time_function = "turn"
formulation = "augmented_lagrangian"
penalty = 1e9
iterations = 50
tolerance = 1e-12
[[prescribed_displacements]]
label = "push"
node = "slider"
direction = [1.0, 0.0, 0.0]
point = [2.0, 0.0, 0.0]
time_function = "turn"
[[fixed]]
node = "slider"
dofs = ["y", "z", "rx", "ry", "rz"]
[solver]
dt = 0.001
t_end = 0.01
""", """
[meta]
name = "sensitivity_probe"
""" + _SECTION + """[[beams]]
label = "b"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
elements = 2
section = "bar"
[[clamps]]
node = "b:start"
[[loads]]
node = "b:end"
force = [0.0, 0.0, -1.0]
[solver]
algorithm = "static"
t_end = 1.0
load_steps = 1
[sensitivities]
parameters = ["sections.bar.EI2", "loads[0].force"]
outputs = ["position:b:end"]
""", """
[meta]
name = "probe_reduce"
""" + _SECTION + """[[beams]]
label = "blade"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
elements = 2
section = "bar"
reduce = { modes = 2, interfaces = ["blade:start"] }
[solver]
dt = 0.001
t_end = 0.01
""")
"""Decks that use what no gallery deck does (a joint's ``reference``, a drive's default ``mode``, an
augmented-Lagrangian joint's keys, ``[[prescribed_displacements]]``, ``[sensitivities]``, a beam's ``reduce``): read
with the gallery so that their keys are typed too (a deck that reduces a beam within
:func:`reference.io.deck_reduce.collecting`, past the reader's refusal)."""

MEANINGS = {
    "[sections.NAME]": {
        "EA": "axial stiffness [N]", "GA2": "shear stiffness along section axis 2 [N]",
        "GA3": "shear stiffness along section axis 3 [N]", "GJ": "torsional stiffness [N m²]",
        "EI2": "bending stiffness about section axis 2 [N m²]", "EI3": "bending stiffness about section axis 3 [N m²]",
        "rhoA": "mass per length [kg/m]", "rhoJ1": "rotary inertia per length about the beam axis (axis 1) [kg m]",
        "rhoJ2": "rotary inertia per length about section axis 2 [kg m]",
        "rhoJ3": "rotary inertia per length about section axis 3 [kg m]"},
    "[time_functions.NAME]": {
        "kind": "the function's form; its parameters are in the table of that kind below",
        "value": "the constant value", "t0": "start of the change [s] (static: load factor)",
        "t1": "end of the change [s] (static: load factor)", "v0": "value before `t0`", "v1": "value after `t1` (or `t0`)",
        "times": "increasing times of the table [s]", "values": "the values at `times` (linear in between, held outside)",
        "amplitude": "amplitude A of `offset + A sin(omega t + phase)`", "omega": "angular frequency [rad/s]",
        "phase": "phase φ [rad]", "offset": "constant added to the sine",
        "expr": "a formula in `t` (sympy's parser, never executed as Python), e.g. `\"sin(3*t)**2\"`"},
    "[[nodes]]": {
        "label": "a unique name, used in references and in the results file",
        "position": "inertial coordinates [m]",
        "rotation": "initial orientation of the node frame, Euler parameters `[e0, e1, e2, e3]`; default: the "
                    "section frame of the first beam at the node"},
    "[[rigid_bodies]]": {
        "label": "a unique name (references, results)", "mass": "mass [kg]",
        "inertia": "inertia about the centre of mass, body frame [kg m²]: the diagonal `[J1, J2, J3]` or a 3×3 list",
        "position": "centre of mass, inertial [m]", "rotation": "initial orientation, Euler parameters `[e0, e1, e2, e3]`",
        "points": "named points of the body (a table), inertial coordinates at t = 0; joints and loads refer to "
                  "them as `body.NAME`",
        "points.NAME": "one named point: 3 inertial coordinates at t = 0 [m]"},
    "[[beams]]": {
        "reduce.modes": "in `reduce`, required: the modes kept — fixed-interface normal modes (Craig–Bampton) "
                        "or elastic modes (free-free); a count (the lowest) or a list of mode numbers (1 the lowest)",
        "reduce.interfaces": "in `reduce`: node references of the beam where joints, springs and loads attach "
                             "(Craig–Bampton keeps their six coordinates each: at least one)",
        "reduce.basis": "in `reduce`: `craig_bampton` (fixed-interface and constraint modes) or `free_free`",
        "reduce.stiffening": "in `reduce`: `true` adds the modes' centrifugal stress stiffness at the frame's spin "
                             "(a body turning about its first interface); default `false`",
        "reduce.second_order": "in `reduce`: `true` adds the modes' second-order stiffness (the stress stiffness of "
                               "the body's own deformation, e.g. an axial force stiffening bending); default `false`",
        "reduce.third_order": "in `reduce`: `true` adds, with `second_order`, the modes' third-order stiffness (the "
                              "strain energy to fourth order: a beam's shortening by its own bending stiffening it); "
                              "default `false`",
        "reduce.modal_derivatives": "in `reduce`: `true` adds to a Craig–Bampton basis the static modal derivatives of "
                                    "its modes (their second-order displacement field, e.g. a bent beam's axial "
                                    "relaxation); default `false`"},
    "[[clamps]]": {"node": "the node or body whose six coordinates are fixed"},
    "[[fixed]]": {"node": "the node or body", "dofs": "the fixed coordinates: `x`, `y`, `z` (inertial translations), "
                                                      "`rx`, `ry`, `rz` (rotations about the body axes)"},
    "[gravity]": {"g": "gravitational acceleration, inertial [m/s²], acting on every nodal mass"},
    "[[loads]]": {
        "node": "the loaded node or body", "force": "force [N] (exactly one of `force` and `moment`)",
        "moment": "moment [N m] (exactly one of `force` and `moment`)",
        "frame": "`inertial`: a dead load fixed in space; `body`: a follower load turning with the node",
        "time_function": "scales the load (default: constant 1)",
        "point": "a force's point of application, inertial at t = 0, fixed in the body after (its moment about "
                 "the node is added)"},
    "[[line_loads]]": {
        "beam": "a flexible beam's label", "force_per_length": "distributed force [N/m]",
        "moment_per_length": "distributed moment [N m/m]",
        "frame": "`inertial` (dead) or `body` (components in each node's section frame: a follower load)",
        "time_function": "scales the load (default: constant 1)"},
    "[[springs]]": {
        "kind": "the force element; its keys are in the table of that kind below",
        "label": "name used in messages and results", "body_i": "the first body (a node reference)",
        "body_j": "the second body, or `\"ground\"` (the default)",
        "point_i": "attachment on body i, inertial at t = 0, body-fixed after [m]",
        "point_j": "attachment on body j (default the origin), inertial at t = 0, body-fixed after [m]",
        "point": "the bushing's point, inertial at t = 0 [m]",
        "stiffness": "k: [N/m] point to point, [N m/rad] rotational; a bushing's six values (3 in N/m, 3 in N m/rad)",
        "damping": "c, in the stiffness's units times s (default 0)",
        "rest_length": "ℓ0 [m] (default: the initial distance)",
        "force_function": "a time function: an actuator force f_a(t) [N] added to the spring's",
        "axis": "the axis u3 (default z)", "reference": "u1 of the element's frame (optional)",
        "rest_angle": "φ0 [rad] (default 0)"},
    "[[initial_velocities]]": {
        "node": "the node or body", "velocity": "translational velocity, inertial [m/s]",
        "angular_velocity": "angular velocity, body frame [rad/s]"},
    "[solver]": {"algorithm": "the algorithm (the keys of each are in its table below); default "
                              "`staggered_central_difference`"},
    "[checks.NAME]": {
        "description": "what is checked (free text)", "observable": "an observable of docs/observables.md, checked "
                                                                   "against the model when the deck is loaded",
        "reference": "the reference value's source", "value": "the reference value(s)",
        "tolerance": "the largest accepted difference",
        "relative_to": "what `tolerance` is a fraction of, in words (e.g. `model size`, `closed-form frequency`)",
        "at": "the time (load factor) the check is made at", "reason": "why this tolerance",
        "node": "the node the check is about"},
}
"""Meanings of the keys of the tables that the deck page describes in prose (``docs/deck.md`` tables the
others' keys, and :func:`page_meanings` reads them from there)."""


def _split(entry: str):
    """(table pattern, key) of an entry such as ``beams[2].section`` or ``sections.arm.EA``; None if not a key."""
    m = _ENTRY.match(entry)
    if not m or " " in entry:
        return None
    table, rest = m["table"], m["rest"]
    if m["index"]:
        pattern = f"[[{table}]]"
    elif table in NAMED:
        if rest is None or "." not in rest:
            return (f"[{table}.NAME]", None) if rest else None
        rest = rest.split(".", 1)[1]
        pattern = f"[{table}.NAME]"
    else:
        pattern = f"[{table}]"
    if rest is None:
        return pattern, None
    key = re.sub(r"\[\d+\]$", "", rest)
    if "." in key:  # rigid_bodies[i].points.NAME, beams[i].reduce.modes
        head, _, _ = key.partition(".")
        return pattern, key if head in SUBTABLES else f"{head}.NAME"
    return pattern, key


class _Recorder(Reader):
    """A deck reader that notes what it checks (the vocabulary of :class:`Reader`)."""

    def __init__(self, path, book):
        super().__init__(path)
        self.book = book
        self.present: dict[str, set] = {}
        self.depth = 0

    def keys(self, table, entry, required=(), optional=()):
        if isinstance(table, dict):
            self.present[entry] = set(table)
            where = _split(entry)
            if where and where[1] in SUBTABLES:  # its keys are rows of the entry's table, each optional there
                self.book.table(where[0], (), [f"{where[1]}.{k}" for k in [*required, *optional]], table)
            elif where:
                self.book.table(where[0], required, optional, table)
        return super().keys(table, entry, required, optional)

    def _note(self, check, value, entry, **how):
        where = _split(entry) if self.depth == 0 else None
        if not where or where[1] is None:
            return
        parent, _, key = entry.rpartition(".")
        key = re.sub(r"\[\d+\]$", "", key)
        if re.search(r"\[\d+\]$", entry):  # an item of a list checked one by one
            check = f"list of {check}s"
        absent = parent in self.present and key not in self.present[parent]
        self.book.value(where[0], where[1], check, how, value if absent else _GIVEN)

    def _nested(self, method, *args, **kwargs):
        self.depth += 1
        try:
            return method(*args, **kwargs)
        finally:
            self.depth -= 1

    def number(self, value, entry, positive=False, nonnegative=False):
        self._note("number", value, entry, positive=positive, nonnegative=nonnegative)
        return super().number(value, entry, positive, nonnegative)

    def integer(self, value, entry, minimum=1, maximum=None, fix=""):
        self._note("integer", value, entry, minimum=minimum, maximum=maximum)
        return super().integer(value, entry, minimum, maximum, fix)

    def vector(self, value, entry, n=3):
        self._note("vector", value, entry, n=n)
        return self._nested(super().vector, value, entry, n)

    def direction(self, value, entry):
        self._note("direction", value, entry)
        return self._nested(super().direction, value, entry)

    def rotation(self, value, entry):
        self._note("rotation", value, entry)
        return self._nested(super().rotation, value, entry)

    def string(self, value, entry):
        self._note("string", value, entry)
        return super().string(value, entry)

    def boolean(self, value, entry):
        self._note("boolean", value, entry)
        return super().boolean(value, entry)

    def choice(self, value, entry, options, what="value", describe=""):
        self._note("choice", value, entry, options=tuple(options), what=what, describe=describe)
        return super().choice(value, entry, options, what, describe)

    def label(self, value, entry):
        self._note("label", value, entry)
        return self._nested(super().label, value, entry)


_GIVEN = object()


class _Book:
    """What the recording reader saw, by table pattern and key, in the order the reader reads them."""

    def __init__(self):
        self.tables: dict[str, dict] = {}
        self.sequences: list[list[str]] = []
        self.kind: dict[str, str] = {}

    def start(self):
        """A new deck: the order of its tables is noted apart."""
        self.sequences.append([])

    @property
    def order(self) -> list[str]:
        """The tables in the reader's order: every deck's order of its tables merged (a topological sort)."""
        after = {p: set() for p in self.tables}
        for seq in self.sequences:
            for first, then in zip(seq, seq[1:]):
                after[then].add(first)
        order, left = [], list(self.tables)
        while left:
            ready = next((p for p in left if after[p] <= set(order)), left[0])
            order.append(ready)
            left.remove(ready)
        return order

    def table(self, pattern, required, optional, table):
        if self.sequences and pattern not in self.sequences[-1]:
            self.sequences[-1].append(pattern)
        t = self.tables.setdefault(pattern, {})
        for key in list(required) + list(optional):
            t.setdefault(key, {"required": set(), "checks": {}, "defaults": []})["required"].add(key in required)
        disc = KINDS.get(pattern.strip("[]").split(".")[0])
        self.kind[pattern] = table.get(disc, "") if disc else ""

    def value(self, pattern, key, check, how, default):
        t = self.tables.setdefault(pattern, {})
        k = t.setdefault(key, {"required": set(), "checks": {}, "defaults": []})
        k["checks"].setdefault(check, how)
        if default is not _GIVEN:
            k["defaults"].append((self.kind.get(pattern, ""), default))

    def free(self, pattern, key, value):
        """A key the reader passes on unchecked (``[checks.NAME]``): its type from the value a deck gives."""
        k = self.tables.setdefault(pattern, {}).setdefault(key, {"required": {False}, "checks": {}, "defaults": []})
        kind = ("true or false" if isinstance(value, bool) else "a number" if isinstance(value, (int, float)) else
                "a list" if isinstance(value, list) else "observable text" if key == "observable" else "text")
        k["checks"].setdefault(kind, {})  # not a check of the reader's vocabulary: no message for a wrong value

    def node(self, entry, kind):
        where = _split(entry)
        if where and where[1]:
            t = self.tables.setdefault(where[0], {})
            t.setdefault(where[1], {"required": set(), "checks": {}, "defaults": []})["checks"].setdefault(kind, {})


@contextmanager
def _recording(book):
    """Node and time-function references are resolved by the deck module's reference table: note them too."""
    refs = deck_module._References
    node, tf = refs.node, refs.time_function

    def noted_node(self, ref, entry):
        book.node(entry, "node")
        return node(self, ref, entry)

    def noted_tf(self, table, entry):
        for key in ("time_function", "force_function"):
            if key in table:
                book.node(f"{entry}.{key}", "time function")
        return tf(self, table, entry)

    refs.node, refs.time_function = noted_node, noted_tf
    reader = deck_module.Reader
    try:
        yield
    finally:
        refs.node, refs.time_function = node, tf
        deck_module.Reader = reader


def record(decks=None) -> _Book:
    """Read every deck (default: ``models/*.toml`` and :data:`PROBES`) with the recording reader."""
    import tempfile

    book = _Book()
    with _recording(book), collecting(), tempfile.TemporaryDirectory() as scratch:
        deck_module.Reader = lambda path: _Recorder(path, book)
        paths = decks or sorted((ROOT / "models").glob("*.toml"))
        if decks is None:
            for i, text in enumerate(PROBES):
                (Path(scratch) / f"probe{i}.toml").write_text(text, encoding="utf-8")
            paths = [*paths, *sorted(Path(scratch).glob("probe*.toml"))]
        for path in paths:
            book.start()
            deck = deck_module.load_deck(path)
            for spec in deck.checks.values():  # free keys, passed on to `flexmbs report`
                for key, value in spec.items():
                    book.free("[checks.NAME]", key, value)
    return book


def page_meanings(page: Path = ROOT / "docs" / "deck.md") -> dict[str, dict[str, str]]:
    """The meaning of each key in the deck page's ``| key | meaning |`` tables, by the table named in the heading
    above (``### `[[joints]]```); a row may name several keys (`` `start` / `start_node` ``)."""
    out: dict[str, dict[str, str]] = {}
    pattern, rows = None, False
    for line in page.read_text(encoding="utf-8").splitlines():
        if m := re.match(r"^#{2,4} `(\[\[?[a-z_]+(?:\.NAME)?\]\]?)`", line):
            pattern, rows = m[1], False
        elif line.startswith("#"):
            pattern, rows = (pattern if line.startswith("####") else None), False
        elif line.startswith("| key | meaning |"):
            rows = True
        elif rows and line.startswith("|") and pattern:
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            if len(cells) == 2 and set(cells[0]) - set("-"):
                for key in re.findall(r"`([A-Za-z_0-9]+)`", cells[0]):
                    out.setdefault(pattern, {})[key] = cells[1]
        else:
            rows = False
    return out


def _type(checks: dict) -> str:
    """The check of a key in words (its type and range)."""
    words = []
    for check, how in checks.items():
        if check == "number":
            words.append("number > 0" if how["positive"] else "number ≥ 0" if how["nonnegative"] else "number")
        elif check == "integer":
            words.append(f"integer ≥ {how['minimum']}" + (f", ≤ {how['maximum']:g}" if how["maximum"] else ""))
        elif check == "vector":
            words.append(f"{how['n']} numbers")
        elif check == "direction":
            words.append("3 numbers, not all 0")
        elif check == "rotation":
            words.append("4 numbers (Euler parameters), unit norm")
        elif check == "choice":
            words.append("one of " + ", ".join(f"`{o}`" for o in how["options"]))
        elif check == "label":
            words.append("name (1–200 printable characters, no `/` or `\\`)")
        elif check in ("node", "time function"):
            words.append(f"{check} reference")
        else:
            words.append(check)
    if "string" in checks and len(words) > 1:  # a label or a choice is a string checked further
        words.remove("string")
    return "; ".join(dict.fromkeys(words))


def _message(key: str, checks: dict) -> str:
    """The reader's message for a wrong value of the key (its first value check)."""
    for check, how in checks.items():
        if check not in _BAD:
            continue
        rd = Reader(Path("deck.toml"))
        method = getattr(rd, check)
        bad = -1.0 if check == "number" and (how.get("positive") or how.get("nonnegative")) else _BAD[check]
        kwargs = {k: v for k, v in how.items() if k in ("positive", "nonnegative", "minimum", "maximum", "n")}
        args = (how["options"], how["what"], how["describe"]) if check == "choice" else ()
        try:
            method(bad, key, *args, **kwargs)
        except DeckError as exc:
            return str(exc)
    return ""


def _default(info: dict, declared=None, kind=None) -> str:
    if declared is not None:
        return f"`{declared!r}`"
    values = [v for k, v in info["defaults"] if kind is None or k == kind] or [v for _, v in info["defaults"]]
    if not values:
        return ""
    shown = {repr(v.tolist() if isinstance(v, np.ndarray) else v) for v in values}
    return f"`{shown.pop()}`" if len(shown) == 1 else "depends on the deck"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _rows(pattern: str, keys, info: dict, meanings: dict, required=None, declared=None, kind=None) -> list[str]:
    lines = ["| key | meaning | required | type and range | default when left out | message for a wrong value |",
             "|---|---|---|---|---|---|"]
    for key in keys:
        k = info.get(key, {"required": set(), "checks": {}, "defaults": []})
        req = (key in required) if required is not None else (
            "yes" if k["required"] == {True} else "in some cases" if True in k["required"] else "no")
        req = {True: "yes", False: "no"}.get(req, req)
        table = pattern.strip("[]")
        entry = f"{table}[0].{key}" if pattern.startswith("[[") else f"{table}.{key}"
        default = "" if req == "yes" else _default(k, (declared or {}).get(key), kind)
        lines.append(f"| `{key}` | {meanings.get(key, '')} | {req} | {_cell(_type(k['checks']))} | {_cell(default)} | "
                     f"{_cell(_message(entry, k['checks']))} |")
    return lines


def markdown(book: _Book | None = None, deck_page: str = "docs/deck.md") -> str:
    """The deck's key tables as Markdown (one section per table, in the order the reader reads them);
    ``deck_page`` the link to the deck's prose."""
    book = book or record()
    out = ["Generated from the deck reader (`flexmbs/deck_reference.py`) when the documentation is built: "
           "a *type* is the reader's check of the value, a *default* the value it uses when the key is left out "
           "(\"depends on the deck\": computed from other keys), a *message* what it answers for a wrong value. "
           f"The *meaning* is [the deck page]({deck_page})'s, which says more.", ""]
    up = deck_page.rpartition("/")[0]
    page = {pattern: {k: re.sub(r"\]\((?!https?:|#|\.\./)([^)]+)\)", rf"]({up}/\1)" if up else r"](\1)", v)
                      for k, v in keys.items()} for pattern, keys in page_meanings().items()}
    meanings = {p: {**MEANINGS.get(p, {}), **page.get(p, {})} for p in {*MEANINGS, *page, *book.tables}}
    meanings["[deck]"] = {p.strip("[]").split(".")[0]: f"the `{p}` table{'s' if '.NAME' in p else ''}, below"
                          for p in book.tables if p != "[deck]"}
    kind_tables = {"[time_functions.NAME]": {k: (req, list(opt), opt) for k, (_, req, opt) in
                                             deck_module.TIME_FUNCTIONS.items()},
                   "[[springs]]": {k: (req, opt, {}) for k, (req, opt) in SPRING_KEYS.items()},
                   "[solver]": {name: (list(cls.deck_required), list(cls.deck_optional), {})
                                for name, cls in ALGORITHMS.items()}}
    for pattern in book.order:
        info, meaning = book.tables[pattern], meanings.get(pattern, {})
        out += [f"## `{pattern}`" if pattern != "[deck]" else "## The deck's tables", ""]
        if pattern == "[checks.NAME]":
            out += ["Read by `flexmbs report`: the reader checks `observable` against the model and passes the other "
                    "keys on; the keys below are those the gallery's decks use.", ""]
        if pattern in kind_tables:
            disc = KINDS[pattern.strip("[]").split(".")[0]]
            out += _rows(pattern, [disc, *COMMON_KEYS.get(pattern, ())], info, meaning) + [""]
            for kind, (req, opt, declared) in kind_tables[pattern].items():
                out += [f"### `{disc} = \"{kind}\"`", ""]
                out += _rows(pattern, [k for k in [*req, *opt] if k != disc], info, meaning, set(req), declared,
                             kind) + [""]
        elif pattern == "[deck]":  # the deck's tables: each an array of tables, a table of named tables or a table
            kinds = {p.strip("[]").split(".")[0]: "array of tables `[[…]]`" if p.startswith("[[") else
                     "named tables `[….NAME]`" if ".NAME" in p else "table `[…]`" for p in book.tables}
            for key in info:
                info[key]["checks"].setdefault(kinds.get(key, "table"), {})
            out += _rows(pattern, list(info), info, meaning) + [""]
        else:
            out += _rows(pattern, list(info), info, meaning) + [""]
    return "\n".join(out)


if __name__ == "__main__":
    print(markdown())
