"""A seeded mutation fuzzer of model decks: the reader answers a DeckError in one line, or a valid model.

Every case takes a base deck (the shipped models, the documented example, :data:`EVERY_TABLE`), applies
one to three mutations — of its structure (drop, add, retype, rescale, duplicate a key or an entry,
swap in a value from :data:`VOCABULARY` or from :data:`NASTY`) or of its text (cut, repeat or garble a
line) — writes it and calls :func:`reference.io.deck.load_deck`, sometimes with overrides.  The property
(:func:`check`): either a :class:`DeckError` whose message is one line of at most ``MAX_CHARS``
characters naming the file, or a model that initialises and takes a few steps (a non-finite run is a
:class:`SolverDiverged`, not a crash) — no other exception, no warning, no case over ``TIME_LIMIT``.

``python tests/fuzz_decks.py --cases 10000`` (``make fuzz``) runs it at length and prints the counts,
the slowest case and the peak memory; the test suite runs 1,000 cases (``tests/test_fuzz.py``).

New deck keys and tables enter the fuzzer in one place: add them to :data:`VOCABULARY` (table → key →
sample values; a table name ending in ``[]`` is an array of tables, ``.*`` a table of named entries),
and, for a new table, an entry using it to :data:`EVERY_TABLE`.  Every ``models/*.toml`` is a base deck.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import random
import resource
import signal
import sys
import threading
import time
import tomllib
import warnings
from pathlib import Path

from reference.jit import CompileTimer

ROOT = Path(__file__).resolve().parent.parent
MAX_CHARS = 300
TIME_LIMIT = 10.0
"""Per-case limit [s] (wall time, numba's compilation left out; a case normally takes milliseconds)."""
STEPS = 3
"""Steps run on an accepted deck."""

EVERY_TABLE = """
[meta]
name = "every_table"
description = "One entry of every table of the format (the fuzzer's base deck)"
units = "N, m, s"
provenance = { paper = "none", data = "made up for the fuzzer" }
notes = "small and stable"

[sections.s]
EA = 1e3
GA2 = 1e3
GA3 = 1e3
GJ = 1.0
EI2 = 1.0
EI3 = 1.0
rhoA = 1.0
rhoJ1 = 2e-2
rhoJ2 = 1e-2
rhoJ3 = 1e-2

[time_functions.c]
kind = "constant"
value = 1.0
[time_functions.r]
kind = "ramp"
t0 = 0.0
t1 = 0.01
[time_functions.st]
kind = "step"
t0 = 0.005
[time_functions.pl]
kind = "piecewise_linear"
times = [0.0, 0.01, 0.02]
values = [0.0, 1.0, 1.0]
[time_functions.sn]
kind = "sine"
amplitude = 1.0
omega = 10.0
[time_functions.ss]
kind = "smooth_step"
t0 = 0.0
t1 = 0.01
[time_functions.ex]
kind = "expression"
expr = "1 - exp(-100*t)"
[time_functions.tiny]
kind = "ramp"
t0 = 0.0
t1 = 0.02
v1 = 1e-4

[[nodes]]
label = "hub"
position = [0.0, 0.0, 0.0]
rotation = [1.0, 0.0, 0.0, 0.0]

[[beams]]
label = "b"
start_node = "hub"
end = [1.0, 0.0, 0.0]
elements = 4
section = "s"
axis2 = [0.0, 1.0, 0.0]

[[beams]]
label = "bar"
start = [1.0, 0.0, 0.0]
end = [2.0, 0.0, 0.0]
elements = 1
section = "s"
rigid = true

[[rigid_bodies]]
label = "rb"
mass = 1.0
inertia = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
position = [0.0, 2.0, 0.0]
rotation = [1.0, 0.0, 0.0, 0.0]
points = { tip = [0.0, 2.5, 0.0] }

[[clamps]]
node = "hub"

[[fixed]]
node = "bar"
dofs = ["rx"]

[[loads]]
node = "b:end"
force = [0.0, 0.0, 1e-3]
frame = "inertial"
time_function = "r"

[[loads]]
node = "b:2"
moment = [0.0, 1e-4, 0.0]
frame = "body"
time_function = "ss"

[[line_loads]]
beam = "b"
force_per_length = [0.0, 0.0, 1e-4]
moment_per_length = [0.0, 0.0, 0.0]
frame = "inertial"
time_function = "ex"

[[springs]]
label = "p2p"
kind = "point_to_point"
body_i = "rb"
point_i = [0.0, 2.5, 0.0]
body_j = "ground"
point_j = [0.0, 3.0, 0.0]
stiffness = 1.0
damping = 0.01
rest_length = 0.5
force_function = "c"

[[springs]]
kind = "rotational"
body_i = "b:end"
body_j = "bar"
axis = [0.0, 0.0, 1.0]
reference = [1.0, 0.0, 0.0]
stiffness = 0.1
damping = 0.0
rest_angle = 0.0

[[springs]]
kind = "bushing"
body_i = "rb"
body_j = "ground"
point = [0.0, 2.0, 0.0]
axis = [0.0, 0.0, 1.0]
reference = [1.0, 0.0, 0.0]
stiffness = [1.0, 1.0, 1.0, 0.1, 0.1, 0.1]
damping = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]

[gravity]
g = [0.0, 0.0, -9.81]

[[joints]]
label = "ball"
kind = "spherical"
body_i = "bar"
body_j = "b:end"
point = [1.0, 0.0, 0.0]
epsilon = 0.0
formulation = "jacobian"

[[joints]]
label = "pin"
kind = "revolute"
body_i = "rb"
body_j = "ground"
point = [0.0, 2.0, 0.0]
axis = [0.0, 0.0, 1.0]
reference = [1.0, 0.0, 0.0]

[[joints]]
label = "motor"
kind = "rotation_drive"
body_i = "rb"
point = [0.0, 2.0, 0.0]
axis = [0.0, 0.0, 1.0]
time_function = "sn"
mode = "velocity"

[[prescribed_displacements]]
label = "push"
node = "b:2"
direction = [0.0, 0.0, 1.0]
time_function = "tiny"

[[initial_velocities]]
node = "rb"
velocity = [0.0, 0.0, 0.0]
angular_velocity = [0.0, 0.0, 0.5]

[solver]
algorithm = "staggered_central_difference"
dt = 1e-3
t_end = 0.02
damping = 0.1
output_every = 5
consistent_initial_velocities = true
max_steps = 1000000
allow_unsafe_dt = false

[checks.tip]
description = "the tip"
observable = "position:b:end"
node = "b:end"
reference = "none"
tolerance = 0.1
relative_to = "length"
reason = "made up"

[crosscheck.tip]
observable = "position:b:end"
tolerance = 0.1
relative_to = "length"
refine = 1
reason = "made up"
"""

VOCABULARY = {
    "": {"meta": [{"name": "x"}], "solver": [{"dt": 1e-3, "t_end": 0.01}], "gravity": [{"g": [0.0, 0.0, -9.81]}],
         "line_loads": [[{"beam": "b", "force_per_length": [0.0, 0.0, 1.0]}]],
         "springs": [[{"kind": "rotational", "body_i": "rb", "stiffness": 1.0}]]},
    "meta": {"name": ["m", "a b", "ü"], "description": ["d"], "units": ["SI"], "provenance": ["p", {"paper": "x"}],
             "notes": ["n"]},
    "sections.*": {k: [1.0, 1e3, 1e-3] for k in ("EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ1", "rhoJ2",
                                                  "rhoJ3")},
    "time_functions.*": {"kind": ["constant", "ramp", "step", "piecewise_linear", "sine", "smooth_step", "expression"],
                         "expr": ["sin(3*t)**2", "t", "1 - exp(-t)"],
                         "value": [1.0], "t0": [0.0, 0.01], "t1": [0.01, 0.0], "v0": [0.0], "v1": [1.0, 2.0],
                         "times": [[0.0, 1.0], [1.0, 0.0], [0.0]], "values": [[0.0, 1.0], [1.0]],
                         "amplitude": [1.0], "omega": [10.0], "phase": [0.5], "offset": [0.1]},
    "nodes[]": {"label": ["n2", "hub", "b:1"], "position": [[0.0, 1.0, 0.0]],
                "rotation": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]},
    "beams[]": {"label": ["c", "b"], "start": [[0.0, 0.0, 1.0]], "end": [[1.0, 0.0, 1.0]],
                "start_node": ["hub", "b:end", "rb"], "end_node": ["b:2", "hub"], "elements": [1, 2, 8],
                "section": ["s", "steel_rod", "rollup"], "axis2": [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
                "rigid": [True, False], "center": [[0.5, 0.5, 0.0], [1.5, 0.0, 0.5], [0.0, 0.0, 0.0]],
                "element": ["beam2", "beam3", "beam2_se3"],
                "reduce": [{"modes": 2, "interfaces": ["b:start"]}, {"modes": 3, "basis": "free_free"},
                           {"modes": 99, "interfaces": ["b:end", "hub"]}, {"modes": 1, "interface": ["b:0"]},
                           {"modes": 0, "interfaces": ["c:start", "c:end"], "basis": "craig"},
                           {"modes": 2, "interfaces": ["b:start"], "stiffening": True},
                           {"modes": 2, "interfaces": ["b:start", "b:end"], "second_order": True},
                           {"modes": [1, 2, 5], "interfaces": ["b:start", "b:end"], "second_order": True,
                            "third_order": True},
                           {"modes": [2, 2], "interfaces": ["b:start"]}, {"modes": [0, 99], "basis": "free_free"},
                           {"modes": 2, "interfaces": ["b:start"], "third_order": True},
                           {"modes": 2, "interfaces": ["b:start", "b:end"], "modal_derivatives": True},
                           {"modes": 2, "basis": "free_free", "modal_derivatives": True}]},
    "rigid_bodies[]": {"label": ["rb2", "rb"], "mass": [1.0, 1e-6], "inertia": [[1.0, 2.0, 3.0]],
                       "position": [[0.0, 0.0, 3.0]], "rotation": [[0.0, 0.0, 0.0, 1.0]],
                       "points": [{"p": [0.0, 0.0, 0.0]}, {}]},
    "joints[]": {"kind": ["spherical", "revolute", "universal", "cylindrical", "translational", "fixed",
                          "rotation_drive", "displacement_drive", "prescribed_displacement"],
                 "label": ["j", "pin"], "body_i": ["rb", "bar", "b:end", "b:start", "hub", "ground"],
                 "body_j": ["ground", "rb", "b:end", "bar"], "point": [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]],
                 "axis": [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], "reference": [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
                 "epsilon": [0.0, 1e-8, 1e-6], "formulation": ["jacobian", "master_slave", "augmented_lagrangian"],
                 "penalty": [1e9, 1.0, 0.0], "iterations": [1, 50, 0], "tolerance": [1e-12, 0.0],
                 "time_function": ["sn", "r", "up"], "mode": ["position", "velocity"],
                 "intended_offset": [True, False, 1]},
    "prescribed_displacements[]": {"label": ["push", "pin"], "node": ["b:end", "rb", "bar", "hub", "b:1"],
                                   "direction": [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
                                   "point": [[1.0, 0.0, 0.0], [0.0, 2.5, 0.0]],
                                   "time_function": ["tiny", "sn", "up", "r"], "epsilon": [1e-6]},
    "clamps[]": {"node": ["hub", "b:start", "rb", "bar", "b:mid"]},
    "fixed[]": {"node": ["bar", "rb", "b:1"], "dofs": [["x"], ["x", "y", "z"], ["rz", "rx"]]},
    "loads[]": {"node": ["b:end", "rb", "bar", "b:mid"], "force": [[0.0, 0.0, 1.0]], "moment": [[0.0, 1.0, 0.0]],
                "frame": ["inertial", "body"], "time_function": ["r", "sn", "up", "ex"], "point": [[0.0, 2.5, 0.0]]},
    "line_loads[]": {"beam": ["b", "bar", "rb"], "force_per_length": [[0.0, 0.0, 1.0]],
                     "moment_per_length": [[0.0, 1.0, 0.0]], "frame": ["inertial", "body"],
                     "time_function": ["r", "ex", "up"]},
    "springs[]": {"kind": ["point_to_point", "rotational", "bushing"], "label": ["s", "p2p"],
                  "body_i": ["rb", "b:end", "bar", "hub"], "body_j": ["ground", "rb", "b:2"],
                  "point_i": [[0.0, 2.5, 0.0]], "point_j": [[0.0, 3.0, 0.0], [0.0, 2.5, 0.0]],
                  "point": [[0.0, 2.0, 0.0]], "stiffness": [1.0, 0.0, [1.0, 1.0, 1.0, 0.1, 0.1, 0.1]],
                  "damping": [0.0, 0.1, [0.1] * 6], "rest_length": [0.5, 0.0], "force_function": ["c", "ex", "up"],
                  "axis": [[0.0, 0.0, 1.0]], "reference": [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
                  "rest_angle": [0.0, 0.5]},
    "gravity": {"g": [[0.0, 0.0, -9.81]]},
    "initial_velocities[]": {"node": ["rb", "b:end", "bar"], "velocity": [[1.0, 0.0, 0.0]],
                             "angular_velocity": [[0.0, 0.0, 1.0]]},
    "solver": {"algorithm": ["staggered_central_difference", "static", "generalized_alpha", "modes", "buckling",
                             "arc_length"], "dt": [1e-3, 1e-4, 2e-4],
               "t_end": [0.02, 0.01], "damping": [0.0, 1.0], "output_every": [1, 5, 7],
               "consistent_initial_velocities": [True, False], "max_steps": [10, 10**10],
               "allow_unsafe_dt": [True, False], "load_steps": [1, 3], "rho_inf": [0.0, 0.8, 1.0],
               "tolerance": [1e-8, 1e-14], "max_iterations": [1, 10],
               # keys of the algorithms to come (issues 19, 20, 22): refused in one line until they land
               "modes": [1, 6, 10**4], "about": ["reference", "static", "rotation"], "arc_length": [0.1, 1e-3],
               "spin_rate": [0.0, 6.0, -20.0], "spin_axis": [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]],
               "spin_point": [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]],
               "max_points": [10, 1000], "max_load_factor": [1.0, 10.0],
               "stop_when": ["position.z:b:end < -0.5", "load_factor > 2"], "branch_switch": [True, False],
               "control": ["position.x:b:end", "position:b:end", "position.z:b:end", "position.z:b:2",
                           "position.x:hub", "position.y:rb"],
               "error_tolerance": [1e-3, 1e-6, 1e-7, 1e-4], "dt_min": [1e-6, 1e-4, 1.0], "dt_max": [1e-2, 1e-3],
               "reference": ["increment", "total"], "backend": ["compiled", "reference", "auto", "numba"]},
    "checks.*": {"observable": ["position:b:end"], "tolerance": [0.1], "reason": ["r"], "at": [[0.1]],
                 "description": ["d"], "node": ["b:end", "rb"], "reference": ["r"],
                 "relative_to": ["length", "peak", "absolute"]},
    "crosscheck.*": {"observable": ["position:b:end", "angle.z:rocker"], "tolerance": [0.1, -1.0],
                     "relative_to": ["length", "peak", "absolute", "L"], "refine": [1, 2], "reason": ["r"]},
    "sensitivities": {"parameters": [["sections.bar.EI2"], ["loads[0].force", "springs[0].stiffness"],
                                     ["rigid_bodies.rb.mass"], ["nodes.b.position"], ["sections.bar.EI9"], [],
                                     ["nodes.b:end.position.x"], ["nodes.hub.position.z", "rigid_bodies.rb.inertia"],
                                     ["nodes.b:1.position.y"]],
                      "outputs": [["position:b:end"], ["midspan_deflection:b"], ["energy:strain"], ["position:zz"]]},
}
"""Table → key → sample values.  ``[]``: an array of tables; ``.*``: a table of named entries."""

EXPRESSIONS = ["sin(3*t)**2", "t**1e9", "1/t", "log(t-1)", "exp(exp(t))", "9**9**9", "2**(2**30)", "exp(800)",
               "(10**300)**100", "+".join(["sin(t)"] * 100), "*".join(["(1+t)"] * 90)]
"""Formulas at the edge (issue 23): power towers, huge exponents, non-finite at t = 0, very long."""
VOCABULARY["time_functions.*"]["expr"] = VOCABULARY["time_functions.*"]["expr"] + EXPRESSIONS

NASTY = [
    0, -1, 1, 2**63 - 1, -(2**63), 1e308, -1e308, 5e-324, 2e-14, 1e-300, math.inf, -math.inf, math.nan,
    "", "x", "b:４", "b:²", "b:99", "b:-1", "b:", ":", "ground", "\u0000", "../x", "a/b", "x" * 5000,
    True, False, [], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0], [1e308, 1e308, 1e308],
    [1.0] * 1000, [[1.0, 0.0, 0.0], [0.0, 1.0]], [[1.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    ["x", 1], {}, {"a": 1}, {"a": {"b": {}}}, 1e9, 10**9, 10**12,
]
"""Values that have broken a reader before, or could."""

SCALES = [0.0, -1.0, 1e-9, 1e-3, 0.5, 1.01, 2.0, 1e3, 1e9, 1e300]


VARIANTS = {
    "alpha_error_epsilon": ({"algorithm": "generalized_alpha", "dt": 1e-3, "t_end": 0.02, "error_tolerance": 1e-4,
                             "dt_min": 1e-6, "output_every": 5, "consistent_initial_velocities": True},
                            {"epsilon": 1e-6}, {}),
    "static": ({"algorithm": "static", "t_end": 0.02, "load_steps": 4}, {}, {}),
    "arc_length_control": ({"algorithm": "arc_length", "arc_length": 1e-3, "max_points": 3, "max_load_factor": 10.0,
                            "t_end": 0.02, "control": "position.z:b:end"}, {}, {}),
    "modes": ({"algorithm": "modes", "modes": 3}, {}, {}),
    "modes_static": ({"algorithm": "modes", "modes": 3, "about": "static", "t_end": 0.02, "load_steps": 2}, {}, {}),
    "buckling": ({"algorithm": "buckling", "modes": 2, "t_end": 0.02}, {}, {}),
    "reference_path": ({"algorithm": "staggered_central_difference", "dt": 1e-3, "t_end": 0.02, "damping": 0.1,
                        "output_every": 5, "consistent_initial_velocities": True, "backend": "reference"}, {}, {}),
    "beam3": ({}, {}, {"element": "beam3"}),
    "beam2_se3": ({}, {}, {"element": "beam2_se3"}),
}
"""Base decks made from :data:`EVERY_TABLE`, so that every algorithm and element family is mutated from a
deck that runs: name → (``[solver]`` in place of its own, or ``{}`` to keep it; keys set on every joint;
keys set on the flexible beam ``b``).  Modes about a rotation start from ``models/rotating_cantilever.toml``
(this deck's pinned body has no steady rotation)."""


def base_decks() -> dict[str, str]:
    """Name → TOML text: every ``models/*.toml``, the example of ``docs/deck.md``, :data:`EVERY_TABLE` and
    its :data:`VARIANTS`."""
    decks = {p.name: p.read_text(encoding="utf-8") for p in sorted((ROOT / "models").glob("*.toml"))}
    doc = (ROOT / "docs" / "deck.md").read_text(encoding="utf-8")
    decks["docs/deck.md"] = doc.split("## A small example")[1].split("```toml\n")[1].split("```")[0]
    decks["every_table"] = EVERY_TABLE
    for name, (solver, joint, beam) in VARIANTS.items():
        deck = tomllib.loads(EVERY_TABLE)
        deck["solver"] = solver or deck["solver"]
        for entry in deck["joints"]:
            entry.update(joint)
        deck["beams"][0].update(beam)
        decks[f"every_table/{name}"] = dumps(deck)
    return decks


def _key(k: str) -> str:
    return json.dumps(k)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dumps(deck: dict) -> str:
    """TOML text of a deck: scalars first, tables, tables of named tables, arrays of tables."""
    out = [f"{_key(k)} = {_value(v)}" for k, v in deck.items()
           if not isinstance(v, dict) and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))]
    for k, v in deck.items():
        if isinstance(v, dict):
            plain = {a: b for a, b in v.items() if not isinstance(b, dict)}
            nested = {a: b for a, b in v.items() if isinstance(b, dict)}
            out.append(f"[{_key(k)}]")
            out += [f"{_key(a)} = {_value(b)}" for a, b in plain.items()]
            for a, b in nested.items():
                out.append(f"[{_key(k)}.{_key(a)}]")
                out += [f"{_key(c)} = {_value(d)}" for c, d in b.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for entry in v:
                out.append(f"[[{_key(k)}]]")
                out += [f"{_key(a)} = {_value(b)}" for a, b in entry.items()]
    return "\n".join(out) + "\n"


def _containers(deck: dict):
    """(table pattern, container) for every table and entry of a deck, the deck itself as ``""``."""
    yield "", deck
    for name, value in deck.items():
        if isinstance(value, dict):
            if any(isinstance(v, dict) for v in value.values()) or f"{name}.*" in VOCABULARY:
                for sub in value.values():
                    if isinstance(sub, dict):
                        yield f"{name}.*", sub
                yield f"{name}.", value
            else:
                yield name, value
        elif isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
            for entry in value:
                yield f"{name}[]", entry


def _nasty(rng: random.Random, old):
    if isinstance(old, (int, float)) and not isinstance(old, bool) and rng.random() < 0.4:
        return old * rng.choice(SCALES)
    if isinstance(old, list) and old and rng.random() < 0.4:
        i = rng.randrange(len(old))
        new = list(old)
        new[i] = _nasty(rng, old[i])
        return new
    return rng.choice(NASTY)


def mutate_structure(rng: random.Random, deck: dict) -> None:
    """One structural mutation of the parsed deck, in place."""
    places = list(_containers(deck))
    pattern, table = rng.choice(places)
    vocab = VOCABULARY.get(pattern, VOCABULARY.get(pattern.rstrip("."), {}))
    op = rng.random()
    if op < 0.2 and table:
        table.pop(rng.choice(list(table)))
    elif op < 0.45 and vocab:
        key = rng.choice(list(vocab))
        table[key] = copy.deepcopy(rng.choice(vocab[key]))  # a copy: later mutations must not reach the vocabulary
    elif op < 0.5:
        table[rng.choice(["bogus", "dt", "label", "elements", "name"])] = rng.choice(NASTY)
    elif op < 0.85 and table:
        key = rng.choice(list(table))
        table[key] = _nasty(rng, table[key])
    elif op < 0.92:
        arrays = [k for k, v in deck.items() if isinstance(v, list) and v and isinstance(v[0], dict)]
        if arrays:
            k = rng.choice(arrays)
            deck[k].append(dict(rng.choice(deck[k])))  # a duplicate entry (duplicate labels, double joints)
    elif op < 0.96:
        if deck:  # an earlier mutation may have emptied it
            deck.pop(rng.choice(list(deck)), None)
    else:
        name = rng.choice([p for p in VOCABULARY if p])
        base = name.rstrip("[]").rstrip(".*")
        entry = {k: copy.deepcopy(rng.choice(v)) for k, v in VOCABULARY[name].items() if rng.random() < 0.7}
        if name.endswith("[]"):
            deck.setdefault(base, [])
            if isinstance(deck[base], list):
                deck[base].append(entry)
        elif name.endswith(".*"):
            if isinstance(deck.get(base, {}), dict):
                deck.setdefault(base, {})[f"n{rng.randrange(9)}"] = entry
        else:
            deck[base] = entry


def mutate_text(rng: random.Random, text: str) -> str:
    """One textual mutation: cut, repeat, garble or truncate a line."""
    lines = text.splitlines()
    i = rng.randrange(len(lines))
    op = rng.random()
    if op < 0.3:
        del lines[i]
    elif op < 0.5:
        lines.insert(i, lines[i])
    elif op < 0.8:
        line = lines[i]
        j = rng.randrange(len(line) + 1)
        lines[i] = line[:j] + rng.choice(["[", "]", "{", "}", "=", '"', "'", ".", ",", "#", "\\", "\u0000", "９",
                                          "[" * 40, "a." * 40, "\n[", "1e999", "-"]) + line[j + 1:]
    else:
        return text[: rng.randrange(len(text))]
    return "\n".join(lines) + "\n"


def make_case(rng: random.Random, bases: dict[str, str]) -> tuple[str, str, dict]:
    """(base name, deck text, overrides) of one case."""
    name = rng.choice(sorted(bases))
    text = bases[name]
    deck = tomllib.loads(text)
    for _ in range(rng.choice([1, 1, 2, 3])):
        if rng.random() < 0.8:
            mutate_structure(rng, deck)
            text = dumps(deck)
        else:
            text = mutate_text(rng, text)
            try:
                deck = tomllib.loads(text)
            except tomllib.TOMLDecodeError:
                break
    overrides = {}
    if rng.random() < 0.1:
        key = rng.choice(["dt", "t_end", "refine"])
        overrides[key] = rng.choice([1e-300, 5e-324, 1e308, 0.5, 2, 10**9, -1.0, 1e-4, 3])
    return name, text, overrides


class CaseTimeout(Exception):
    """A case ran over :data:`TIME_LIMIT`."""


class _Compiling(CompileTimer):
    """Whether numba is compiling now: a case that compiles kernels (a first run of an element family the
    warm-up did not reach) is given more time; compilation is not a hang of the case."""

    @property
    def busy(self) -> bool:
        return self._depth > 0


_COMPILING = _Compiling()


def _alarm(signum, frame):
    if _COMPILING.busy:
        signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT)  # the limit counts again once it has compiled
        return
    raise CaseTimeout


TIME_STEPPING = ("staggered_central_difference", "generalized_alpha", "static")
"""Algorithms whose run :func:`solve` shortens to :data:`STEPS` steps (the others' ``t_end`` is a load level)."""


def finite(name: str, values) -> bool:
    """Whether a dataset of a completed run holds numbers only, but for the NaN that docs/results.md
    documents: ``/solver/error_estimate`` without error control or before the first step, and a column of
    ``/joints/*`` that is NaN throughout (``prescribed_reaction`` of the joints that are not prescribed
    displacements, the reactions of master/slave joints)."""
    import numpy as np

    if name == "solver/error_estimate":
        return not np.any(np.isinf(values))
    if name.startswith("joints/") and values.ndim >= 2:
        columns = values.reshape(values.shape[0], -1)
        return bool(np.all(np.isfinite(columns) | np.all(np.isnan(columns), axis=0)))
    return bool(np.all(np.isfinite(values)))


def solve(domain, results: Path) -> None:
    """Run a deck as ``flexmbs run`` does, shortened (:data:`STEPS` steps or arc-length points), into the
    results file ``results``; then the file must say how the run ended, and a run whose ``status`` is
    ``completed`` must have written finite numbers only. Modes about a rotation that completed also run a
    two-rate Campbell table (``flexmbs campbell``, which runs the table only after a completed run)."""
    import h5py
    import numpy as np

    from reference.errors import SolverDiverged

    settings = domain.solver
    t_end = None
    if settings.algorithm in TIME_STEPPING:
        # the algorithm's step: a static run's is t_end / load_steps whatever dt (or --dt) says
        t_end = min(settings.t_end, STEPS * domain.algorithm().dt)
    if settings.algorithm == "arc_length":
        settings.max_points = min(settings.max_points, STEPS)
    results.unlink(missing_ok=True)
    try:
        domain.solve(t_end=t_end, results_path=results)
    except SolverDiverged:
        pass
    with h5py.File(results, "r") as f:
        status = str(f.attrs.get("status", ""))
        assert status and status != "running", f"results file left with status {status!r}"
        if status == "completed":
            bad = []
            f.visititems(lambda name, obj: bad.append(name) if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f"
                         and not finite(name, obj[()]) else None)
            assert not bad, f"non-finite values with status 'completed': /{bad[0]}"
    if settings.algorithm == "modes" and settings.about == "rotation" and status == "completed":
        from flexmbs.campbell import campbell

        table = campbell(domain, [0.0, settings.spin_rate])
        assert np.all(np.isfinite(table.frequency)), "non-finite Campbell frequency"


def check(path: Path, overrides: dict, results: Path | None = None) -> str:
    """Run one case; return ``"error"`` or ``"accepted"``, or raise AssertionError with the reason.

    An accepted deck takes :data:`STEPS` steps (:meth:`Domain.solve_at`, then its state must be finite),
    or with ``results`` (a results file's path) runs as on the command line (:func:`solve`)."""
    import numpy as np

    from reference.errors import SolverDiverged
    from reference.io.deck import DeckError, load_deck
    from reference.validation import ModelWarning

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT)
    try:
        with warnings.catch_warnings(), _COMPILING:
            warnings.simplefilter("error")
            warnings.simplefilter("ignore", ModelWarning)  # deliberate, one line on the command line
            try:
                domain = load_deck(path, overrides=overrides).domain
            except DeckError as exc:
                message = str(exc)
                assert "\n" not in message, f"multi-line message: {message[:400]!r}"
                assert len(message) <= MAX_CHARS + len(str(path)), f"{len(message)}-character message: {message[:400]!r}"
                assert message.startswith(str(path)), f"message without the file: {message[:400]!r}"
                return "error"
            if results is not None:
                solve(domain, results)
                return "accepted"
            try:
                state = domain.solve_at(STEPS * domain.solver.dt)
            except SolverDiverged:
                return "accepted"
            assert all(np.all(np.isfinite(a)) for a in (state.x, state.q, state.v, state.w)), \
                f"non-finite state at t = {state.t} without SolverDiverged"
            return "accepted"
    except CaseTimeout:
        raise AssertionError(f"hang: no answer in {TIME_LIMIT} s") from None
    except AssertionError:
        raise
    except Exception as exc:  # the property: nothing but a DeckError
        raise AssertionError(f"{type(exc).__name__}: {str(exc)[:300]}") from exc
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernels of every algorithm before the timed cases:
    a first compilation can take longer than :data:`TIME_LIMIT` and is not a hang of the case."""
    from reference.algorithms import ALGORITHMS
    from reference.io.deck import load_deck
    from reference.errors import SolverDiverged

    deck = ROOT / "models" / "three_bar.toml"
    for name in ALGORITHMS:
        domain = load_deck(deck, overrides={"t_end": 0.02}).domain
        domain.solver.algorithm, domain.solver.dt, domain.solver.t_end, domain.solver.load_steps = name, 2e-4, 1e-3, 5
        domain.solver.arc_length, domain.solver.max_points, domain.solver.max_load_factor = 1e-3, 5, 1.0
        try:
            domain.solve()
        except SolverDiverged:  # arc length and buckling refuse the unloaded three-bar: nothing to compile there
            pass


HANG_LIMIT = 6 * TIME_LIMIT
"""Wall time [s] of one case (compilation left out) after which the watchdog ends the fuzzer: a loop inside
compiled code never returns to Python, so :data:`TIME_LIMIT`'s alarm cannot stop it."""


class Watchdog(threading.Thread):
    """Ends the process (exit 3), naming the case and keeping its deck, when a case runs past
    :data:`HANG_LIMIT` outside numba's compiler; ``--start`` resumes after it."""

    def __init__(self, workdir: Path, report):
        super().__init__(daemon=True)
        self.workdir, self.report, self.case, self.since = workdir, report or print, None, 0.0

    def watch(self, case, text: str) -> None:
        (self.workdir / "current.toml").write_text(text, encoding="utf-8", errors="surrogatepass")
        self.case, self.since = case, time.monotonic()

    def run(self) -> None:
        while True:
            time.sleep(1.0)
            if _COMPILING.busy:
                self.since = time.monotonic()
            elif self.case is not None and time.monotonic() - self.since > HANG_LIMIT:
                kept = self.workdir / f"hang_{self.case}.toml"
                (self.workdir / "current.toml").replace(kept)
                self.report(f"case {self.case}: hang, no return from compiled code in {HANG_LIMIT:.0f} s; deck {kept}; "
                            f"resume with --start {self.case + 1}")
                os._exit(3)


def run(cases: int, seed: int, workdir: Path, report=None, start: int = 0, results: bool = False) -> dict:
    """Run cases ``start`` … ``cases − 1`` of ``seed`` (``results``: as on the command line, :func:`solve`);
    return counts, failures (with their decks) and timings."""
    rng = random.Random(seed)
    warm_up()
    watchdog = Watchdog(workdir, report)
    watchdog.start()
    bases = {}
    for name, text in base_decks().items():  # a base deck must itself load: mutations are made from valid decks
        path = workdir / "base.toml"
        path.write_text(text, encoding="utf-8")
        try:
            answer = check(path, {}, workdir / "results.h5" if results else None)
        except AssertionError as exc:
            answer = f"fails ({exc})"
        if answer == "accepted":
            bases[name] = text
        elif report:
            report(f"base deck {name}: {answer}; left out")
    counts = {"error": 0, "accepted": 0}
    failures = []
    slowest = (0.0, "")
    path = workdir / "case.toml"
    t0 = time.perf_counter()
    for k in range(cases):
        name, text, overrides = make_case(rng, bases)
        if k < start:
            continue
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        watchdog.watch(k, text)
        t = time.perf_counter()
        try:
            counts[check(path, overrides, workdir / "results.h5" if results else None)] += 1
        except AssertionError as exc:
            failures.append({"case": k, "base": name, "overrides": overrides, "problem": str(exc), "deck": text})
            (workdir / f"failure_{k}.toml").write_text(text, encoding="utf-8", errors="surrogatepass")
        watchdog.case = None
        dt = time.perf_counter() - t
        if dt > slowest[0]:
            slowest = (dt, name)
        if report and (k + 1) % 1000 == 0:
            report(f"{k + 1} cases, {len(failures)} failures, {time.perf_counter() - t0:.1f} s")
    return {"cases": cases, "failures": failures, "wall": time.perf_counter() - t0, "slowest": slowest,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, **counts}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", type=int, default=10_000)
    p.add_argument("--seed", type=int, default=12)
    p.add_argument("--out", default="out/fuzz", help="folder for the failing decks")
    p.add_argument("--start", type=int, default=0, help="skip the cases before this one (resume after a hang)")
    p.add_argument("--results", action="store_true",
                   help="run each accepted deck as `flexmbs run` does and check its results file")
    args = p.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    res = run(args.cases, args.seed, out, report=lambda s: print(s, flush=True), start=args.start,
              results=args.results)
    for f in res["failures"][:20]:
        print(f"case {f['case']} ({f['base']}, overrides {f['overrides']}): {f['problem']}")
    print(f"{res['cases']} cases in {res['wall']:.1f} s: {res['error']} clean errors, {res['accepted']} accepted, "
          f"{len(res['failures'])} failures; slowest case {res['slowest'][0]:.2f} s ({res['slowest'][1]}); "
          f"peak memory {res['peak_rss_mb']:.0f} MB")
    return 1 if res["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
