"""The verification report's section "Sensitivities" (issue 40): the four checks of the parameter sensitivities
by direct differentiation (:mod:`reference.sensitivity`), each against central differences of whole runs and,
where one exists, a closed form.

- **Roll-up** (``models/embedded_beam_static.toml`` with beam2_se3): the tip's derivative with respect to the
  torque's scale at k = 1 against the exact circle's ``d(x, z)/dk = (−L, −2L/π)``;
- **Euler column** (:data:`COLUMN`): ``dP_cr/dEI2`` against central differences and ``π²/(4L²)``;
- **cantilever frequency** (``models/cantilever_modes.toml``): ``dω₁/dEI2``, ``dω₁/dρA`` against central
  differences and Euler–Bernoulli's ``±ω₁/2`` (EI = ρA = 1);
- **jointed modes** (:data:`PENDULUM`): the torsion double pendulum's frequencies with respect to its springs and
  masses against the closed form;
- **three-bar, generalized-α** (``models/three_bar.toml``): the coupler's mid-span deflection with respect to
  the coupler's EI2 and the crank speed against central differences of whole runs, over the whole history.

Every run takes the reference path (nothing to compile).  ``quick`` (``flexmbs report --quick``) runs a subset:
the frequency's EI2 only and the three-bar's first 0.2 s with EI2 only; the full report all four over the
issue's 2 s.  :func:`report_lines` gives the section's text and its rows, which the report turns into its
checks (:class:`flexmbs.report.Check`: name, reference, computed, tolerance, why).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

MODELS = Path(__file__).resolve().parents[2] / "models"
REFERENCE = {"solver.backend": "reference"}
"""Every run here: the reference path."""

COLUMN = """
[meta]
name = "euler_column"
description = "clamped-free column of length 1 under a dead axial tip load ramped to 2 at t = 1"

[sections.col]
EA = 1e5      # axial shortening P/EA = 2e-5: negligible in P_cr; shear P/GA likewise
GA2 = 1e5     # (stiffer sections leave round-off of 1e-8 in the eigenvalue: GA/EI = 1e7 cancels digits)
GA3 = 1e5
GJ = 1.0
EI2 = 1.0
EI3 = 4.0
rhoA = 1.0
rhoJ1 = 1e-4
rhoJ2 = 1e-4
rhoJ3 = 1e-4

[time_functions.load_factor]
kind = "ramp"
t0 = 0.0
t1 = 1.0

[[beams]]
label = "column"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
elements = 32
section = "col"
axis2 = [0.0, 1.0, 0.0]

[[clamps]]
node = "column:start"

[[loads]]
node = "column:end"
force = [-2.0, 0.0, 0.0]
time_function = "load_factor"

[solver]
algorithm = "buckling"
modes = 1
t_end = 1.0
load_steps = 1
tolerance = 1e-12  # the default 1e-8 of the forces leaves 1e-8 in the axial force, so in μ (2e-6 in the differences)
"""
"""A clamped-free Euler column of length 1, EI2 = 1, under a tip load of 2 at t_end: ``P_cr = μ · 2 = π²/4``."""

PENDULUM = """
[meta]
name = "torsion_double_pendulum_modes"
description = "models/torsion_double_pendulum.toml at rest, hanging: its two modes about the reference state"

[[rigid_bodies]]
label = "upper"
mass = 1.0
inertia = [0.0208333333333333, 0.0208333333333333, 1e-3]
position = [0.0, 0.0, -0.25]
points = { pivot = [0.0, 0.0, 0.0], hinge = [0.0, 0.0, HINGE] }

[[rigid_bodies]]
label = "lower"
mass = 1.0
inertia = [0.0208333333333333, 0.0208333333333333, 1e-3]
position = [0.0, 0.0, -0.75]

[[joints]]
kind = "revolute"
label = "pivot"
body_i = "upper"
point = [0.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]

[[joints]]
kind = "revolute"
label = "hinge"
body_i = "lower"
body_j = "upper"
point = [0.0, 0.0, HINGE]
axis = [0.0, 1.0, 0.0]

[[springs]]
kind = "rotational"
label = "k1"
body_i = "upper"
axis = [0.0, 1.0, 0.0]
stiffness = 5.0

[[springs]]
kind = "rotational"
label = "k2"
body_i = "lower"
body_j = "upper"
axis = [0.0, 1.0, 0.0]
stiffness = 2.0

[gravity]
g = [0.0, 0.0, -9.81]

[solver]
algorithm = "modes"
modes = 2
about = "reference"
"""
"""The torsion double pendulum (two rigid bars of 0.5 m, two revolute joints, torsion springs 5 and 2 N m/rad)
hanging at rest; ``HINGE`` the hinge's height (−0.5)."""
PENDULUM_PARAMETERS = {"springs[0].stiffness": ("springs.0.stiffness", 5.0),
                       "springs[1].stiffness": ("springs.1.stiffness", 2.0),
                       "rigid_bodies.upper.mass": ("rigid_bodies.0.mass", 1.0),
                       "rigid_bodies.lower.mass": ("rigid_bodies.1.mass", 1.0)}
"""Its parameters: name → (the deck reader's override, nominal value)."""


def pendulum_omegas(k1: float, k2: float, m1: float, m2: float) -> np.ndarray:
    """:data:`PENDULUM`'s two angular frequencies [rad/s] in closed form
    (:func:`flexmbs.verification.analytic.double_pendulum_frequencies`: bars of 0.5 m, centres at mid-length)."""
    from flexmbs.verification.analytic import double_pendulum_frequencies

    J = 0.0208333333333333
    return double_pendulum_frequencies(m1, 0.25, J, 0.5, m2, 0.25, J, 9.81, k1, k2)[0]


def pendulum(folder: Path) -> list[tuple]:
    """The jointed torsion double pendulum's two frequencies w.r.t. both springs and both masses against the
    closed form's derivatives (central differences of the formula, relative step 1e-5)."""
    from reference.io.deck_sensitivities import eigen_sensitivities

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "torsion_double_pendulum_modes.toml"
    path.write_text(PENDULUM.replace("HINGE", "-0.5"), encoding="utf-8")
    names = list(PENDULUM_PARAMETERS)
    _, d = eigen_sensitivities(path, names, REFERENCE)
    nominal = [value for _, value in PENDULUM_PARAMETERS.values()]
    error = 0.0
    for i, value in enumerate(nominal):
        h = 1e-5 * value
        up, down = (pendulum_omegas(*[v + s * h * (j == i) for j, v in enumerate(nominal)]) for s in (1, -1))
        error = max(error, float(np.max(np.abs(d[i] - (up - down) / (2.0 * h)) / np.abs((up - down) / (2.0 * h)))))
    return [("torsion double pendulum (2 revolute joints): dω₁, dω₂ w.r.t. both springs and both masses",
             "closed form of the 2 × 2 pencil", error, 1e-8, "the constrained pencil is the 2 × 2 one to round-off; "
             "the formula's central differences leave 1e-10; the largest of the eight relative errors")]


EIGEN_STEP = 1e-3
"""Relative step of the eigenvalues' central differences: their round-off, up to 4e-10 of the eigenvalue
(equilibrium and eigen-solver), over 2e-3 is 2e-7; their truncation ``h² f'''/(6 f')`` is 1.25e-7 for
``ω ∝ EI^(1/2)`` and 6.25e-7 for ``ω ∝ ρA^(−1/2)``: both below issue 40's 1e-6."""
RUN_STEP = 1e-6
"""Relative step of the three-bar's central differences of whole runs: truncation O(1e-12), the runs' Newton
tolerance and round-off leave about 1e-7 of the peak over the 2 s (docs/benchmarks.md §13)."""
THREE_BAR = {"solver.algorithm": "generalized_alpha", "dt": 1e-2, "solver.output_every": 1, **REFERENCE}
"""The three-bar on generalized-α in steps of 10 ms (tests/test_sensitivity_dynamic.py's setting)."""
DEFLECTION = "midspan_deflection:coupler"


def _eigenvalue(path, overrides: dict, index: int = 0) -> float:
    from reference.io.deck_sensitivities import eigen_sensitivities

    return float(eigen_sensitivities(path, [], {**REFERENCE, **overrides})[0][index])


def _central_eigenvalue(path, name: str, value: float, overrides: dict | None = None) -> float:
    """The lowest eigenvalue's central difference in the parameter ``name`` (an override) at ``value``."""
    overrides = overrides or {}
    plus = _eigenvalue(path, {**overrides, name: value * (1.0 + EIGEN_STEP)})
    minus = _eigenvalue(path, {**overrides, name: value * (1.0 - EIGEN_STEP)})
    return (plus - minus) / (2.0 * EIGEN_STEP * value)


def rollup() -> list[tuple]:
    """The static roll-up's tip at k = 1 (10 load steps of 0.1) with respect to the torque's scale."""
    from reference.io.deck_sensitivities import static_sensitivities

    path, tip, length = MODELS / "embedded_beam_static.toml", "position:beam:end", 10.0
    overrides = {"beams.0.element": "beam2_se3", "t_end": 1.0, "solver.load_steps": 10, **REFERENCE}
    r = static_sensitivities(path, ["loads[0].moment"], [tip], overrides)
    d = np.asarray(r.outputs[tip]["loads[0].moment"][-1])
    error = max(abs(d[0] + length), abs(d[2] + 2.0 * length / math.pi)) / length
    return [("roll-up: tip d(x, z)/dk at k = 1, beam2_se3, 12 elements", "exact circle (−L, −2L/π)", error, 1e-6,
             "beam2_se3 reproduces the circle at any mesh; the derivative is exact up to Newton's tolerance "
             "(error relative to L)")]


def cantilever(quick: bool) -> list[tuple]:
    """The cantilever's first frequency with respect to EI2 (and ρA, full report)."""
    from reference.io.deck_sensitivities import eigen_sensitivities

    path, one = MODELS / "cantilever_modes.toml", {"solver.modes": 1}
    names = ["sections.rect.EI2"] + ([] if quick else ["sections.rect.rhoA"])
    omega, d = eigen_sensitivities(path, names, {**REFERENCE, **one})
    rows = []
    for i, (name, sign) in enumerate(zip(names, (1.0, -1.0))):
        key = name.split(".")[-1]
        central = _central_eigenvalue(path, name, 1.0, one)
        rows.append((f"cantilever: dω₁/d{key}", "central differences (relative step 1e-3)",
                     abs(d[i, 0] / central - 1.0), 1e-6, "the required bound; the differences' truncation "
                     "(1.25e-7 for EI, 6.25e-7 for ρA) and round-off (2e-7) stay below it"))
        rows.append((f"cantilever: dω₁/d{key}", f"Euler–Bernoulli {'+' if sign > 0 else '−'}ω₁/2 (EI = ρA = 1)",
                     abs(d[i, 0] / (sign * omega[0] / 2.0) - 1.0), 2e-3, "the Timoshenko beam's shear and rotary "
                     "inertia move the derivative by 1.2e-3 (EI) and 4.6e-4 (ρA) from Euler–Bernoulli, measured"))
    return rows


def column(folder: Path) -> list[tuple]:
    """The Euler column's critical load with respect to EI2 (:data:`COLUMN`, written into ``folder``)."""
    from reference.io.deck_sensitivities import eigen_sensitivities

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "euler_column_sensitivity.toml"
    path.write_text(COLUMN, encoding="utf-8")
    mu, d = eigen_sensitivities(path, ["sections.col.EI2"], REFERENCE)
    dP, exact = 2.0 * d[0, 0], math.pi**2 / 4.0  # P_cr = μ P with P = 2
    central = _central_eigenvalue(path, "sections.col.EI2", 1.0)
    return [("Euler column: dP_cr/dEI2, 32 Beam2 elements", "central differences (relative step 1e-3)",
             abs(d[0, 0] / central - 1.0), 1e-6, "the required bound; μ is linear in EI to the mesh's shear "
             "correction, so the differences' truncation is far below it, their round-off 2e-7"),
            ("Euler column: dP_cr/dEI2", "closed form π²/(4L²)", abs(dP / exact - 1.0), 1e-3,
             "Beam2's buckling load is second order from above: +4.0e-4 at 32 elements, measured on P_cr")]


def three_bar(quick: bool) -> list[tuple]:
    """The three-bar's coupler deflection history with respect to EI2 (and the crank speed, full report)."""
    from reference.io.deck import load_deck
    from reference.io.deck_parameters import resolve_all
    from reference.io.deck_sensitivities import dynamic_sensitivities
    from reference.observables import parse

    path, t_end = MODELS / "three_bar.toml", 0.2 if quick else 2.0
    overrides = {**THREE_BAR, "t_end": t_end}
    names = ["sections.coupler.EI2"] + ([] if quick else ["time_functions.crank_speed.v1"])
    _, out = dynamic_sensitivities(path, names, [DEFLECTION], overrides)
    rows = []
    for p in resolve_all(path, names, overrides):
        histories = []
        for sign in (1.0, -1.0):
            r = load_deck(path, overrides={**overrides, p.override: p.value * (1.0 + sign * RUN_STEP)}).domain.solve()
            histories.append(parse(DEFLECTION, r).evaluate(r))
        fd = (histories[0] - histories[1]) / (2.0 * RUN_STEP * p.value)
        error = np.max(np.abs(np.asarray(out[DEFLECTION][p.name]) - fd)) / np.max(np.abs(fd))
        rows.append((f"three-bar, generalized-α {t_end:g} s: d(coupler mid-span deflection)/d{p.name}",
                     "central differences of whole runs (relative step 1e-6)", error, 1e-5,
                     "the required bound, relative to the history's peak, over every output; the runs' Newton "
                     "tolerance and round-off leave about 1e-7 of it over 2 s, 1.7e-6 over the first 0.2 s (a "
                     "smaller peak), measured"))
    return rows


def report_lines(quick: bool, folder: Path) -> tuple[list[str], list[tuple]]:
    """The section's text and its rows ``(name, reference, computed, tolerance, why)`` (module docstring);
    ``folder`` takes the Euler column's deck."""
    started = time.perf_counter()
    rows = rollup() + cantilever(quick) + column(Path(folder)) + pendulum(Path(folder)) + three_bar(quick)
    lines = ["## Sensitivities", "",
             "Parameter sensitivities by direct differentiation (docs/formulation.md §14; "
             "`[sensitivities]` in a deck, docs/deck.md): the static tangent's back-substitution, the "
             "eigenvectors' dλ/dp = φᵀ(∂K/∂p − λ ∂M/∂p)φ, the tangent-linear generalized-α step, each against "
             "central differences of whole runs and, where one exists, a closed form; on the reference path. "
             + ("Quick report: the frequency's EI2 only and the three-bar's first 0.2 s with EI2 only."
                if quick else "All four checks, and the jointed modes.")
             + f" Computed in {time.perf_counter() - started:.1f} s.", ""]
    return lines, rows
