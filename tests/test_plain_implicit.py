"""The implicit and linear algorithms on the reference path (reference/plain/static.py, generalized_alpha.py,
linear.py) against the compiled ones, deck by deck: the same equilibria, motions, modes and load factors
within the Newton tolerance (issue 37 item 4)."""

from __future__ import annotations

import ast
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import LEE_FRAME_BEAM2
from reference.io.deck import load_deck
from reference.plain.algorithms import REFERENCE_TWINS
from reference.validation import ModelWarning

MODELS = Path(__file__).resolve().parent.parent / "models"


def both(deck: str, overrides: dict | None = None):
    """The deck run on the compiled path and on the reference path: ``(compiled, reference, domain)``."""
    out = []
    for backend in ("compiled", "reference"):
        domain = load_deck(MODELS / f"{deck}.toml", overrides).domain
        domain.solver.backend = backend
        results = domain.solve()
        assert results.status == "completed", (backend, results.status)
        assert domain.last_run.get("backend", ("compiled",))[0] == backend
        out.append(results)
    return out[0], out[1], domain


def model_size(domain) -> float:
    """The model size L [m] of the Newton tests (the span of the initial positions)."""
    x = domain.initial_conditions().x
    return max(float(np.max(np.ptp(x, axis=0))), 1e-3)


def assert_within(a, b, bound: float, what: str) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, what
    gap = float(np.max(np.abs(a - b), initial=0.0))
    assert gap <= bound, f"{what}: {gap:.3g} > {bound:.3g}"


def test_every_twin_is_the_compiled_algorithm_of_its_name():
    """Each reference twin subclasses the compiled algorithm registered under its deck name, so the solution
    loop, the deck reader and the results file treat it as that algorithm."""
    from reference.algorithms import ALGORITHMS

    assert {"static", "generalized_alpha", "modes", "buckling", "arc_length"} <= set(REFERENCE_TWINS)
    for name, cls in REFERENCE_TWINS.items():
        assert issubclass(cls, ALGORITHMS[name]) and cls.name == name


def test_static_embedded_beam_equilibria_agree_within_the_newton_tolerance():
    """embedded_beam_static, 20 load steps to k = 2: every recorded equilibrium (positions, rotations,
    strain energy, work of the loads) on both paths.  Each path stops within its Newton tolerance (1e-10
    of the model size L for a correction, or a balanced residual) of the same equilibrium, so the two
    differ by at most twice that: 2e-10 L in position, 2e-10 rad in rotation; the energies by as
    many digits of their scale."""
    compiled, plain, domain = both("embedded_beam_static")
    L, tol = model_size(domain), 1e-10
    assert_within(plain.time, compiled.time, 0.0, "load factors")
    assert_within(plain.positions, compiled.positions, 2 * tol * L, "positions")
    assert_within(plain.rotations, compiled.rotations, 2 * tol, "Euler parameters")
    for key in ("strain", "external_work"):
        scale = float(np.max(np.abs(compiled.energy[key])))
        assert_within(plain.energy[key], compiled.energy[key], 2 * tol * scale, key)
    count = compiled.data("stability/negative_eigenvalues")
    assert np.all(count >= 0)
    assert_within(plain.data("stability/negative_eigenvalues"), count, 0.0, "the stability count")


def test_static_stability_event_past_a_bifurcation_as_compiled():
    """The lateral–torsional cantilever of tests/test_modes.py (16 elements, tip load ramped to 1.5 times its
    reference in 30 load steps) on both paths: the same single warning line (stability lost between load
    factor 1 and 1.05 at a bifurcation), the same stability count at every output, the same event kind, and
    the interpolated critical load factor within 1e-5 relative: it is interpolated from the eigenvalue nearest
    zero at the two equilibria, each within the Newton tolerance of the other path's, on a perfect beam loaded
    past its bifurcation, whose lowest eigenvalue there is small and sensitive (measured 4e-7)."""
    from test_modes import ltb

    runs = []
    for backend in ("compiled", "reference"):
        domain = ltb(16, "static", 4.0, 1.5, 30)
        domain.solver.backend = backend
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            results = domain.solve()
        lines = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
        runs.append((results, lines))
    (compiled, lines0), (plain, lines1) = runs
    assert len(lines0) == 1 and lines0[0].startswith("stability lost between load factor 1 and 1.05: bifurcation")
    assert [line.split(" (critical")[0] for line in lines1] == [lines0[0].split(" (critical")[0]]
    assert_within(plain.data("stability/negative_eigenvalues"), compiled.data("stability/negative_eigenvalues"), 0.0,
                  "the stability count")
    assert list(plain.data("stability/critical_kind")) == ["bifurcation"]
    mu0, mu1 = compiled.data("stability/critical_load_factor"), plain.data("stability/critical_load_factor")
    assert_within(mu1 / mu0, np.ones_like(mu0), 1e-5, "critical load factor (relative)")


EXPLICIT_AS_ALPHA = {"solver.algorithm": "generalized_alpha", "dt": 1e-3}
"""An explicit gallery deck run by generalized-α instead (its ``dt`` replaced by one generalized-α takes)."""


def test_static_load_step_past_a_limit_point_is_traced_as_compiled():
    """Lesson 11's von Mises truss loaded to 1.5 × its limit load in steps of 0.15 (tests/test_path_reliability.py):
    the static algorithm converges beyond the limit point on the mirrored branch; the step whose move per unit
    load jumps is traced again by arc length, on each path by its own arc length.  Both say the same line up to
    the traced limit load, record one "limit point" event, and their limit loads agree within 1e-6 relative
    (a parabola through three traced points, each converged to the Newton tolerance; measured 3e-14); the
    equilibria agree within 2e-10 L as every static level's."""
    from test_path_reliability import lesson_truss, solve

    domains = [lesson_truss(algorithm="static", t_end=1.5, load_steps=10, dt=0.15, backend=backend)
               for backend in ("compiled", "reference")]
    (compiled, lines0), (plain, lines1) = (solve(domain) for domain in domains)
    assert len(lines0) == 1 and "passed a limit point at load factor" in lines0[0]
    assert [line.split(" at load factor 1")[0] for line in lines1] == [lines0[0].split(" at load factor 1")[0]]
    assert list(plain.data("stability/critical_kind")) == ["limit point"]
    critical = compiled.data("stability/critical_load_factor")
    assert_within(plain.data("stability/critical_load_factor") / critical, np.ones(1), 1e-6, "limit load (relative)")
    assert_within(plain.positions, compiled.positions, 2e-10 * model_size(domains[0]), "positions")


@pytest.mark.parametrize("deck, overrides", [
    ("steel_three_bar", {"t_end": 0.02}), ("andrews_squeezer", {"t_end": 2e-4}),
    ("force_elements_crosscheck", {"t_end": 0.02, **EXPLICIT_AS_ALPHA}),
    ("torsion_double_pendulum", {"t_end": 0.02, **EXPLICIT_AS_ALPHA}),
    ("heavy_top", {"t_end": 0.02, **EXPLICIT_AS_ALPHA})])
def test_generalized_alpha_short_horizon_agrees_within_the_newton_tolerance(deck, overrides):
    """20 fixed steps of generalized-α on both paths: the three-bar's rocker with a steel coupler; Andrews'
    squeezer (seven bodies, a spring); the force elements' deck (springs, dampers, bushings, an actuator: the
    dampers' C in the iteration matrix); two rigid pendulums with rotational springs (their continuous angles);
    the heavy top (the gyroscopic tangent).  Each step converges to an imbalance below the Newton tolerance
    (1e-9 of the step's forces): the configurations differ by at most that fraction of the model size a
    step, accumulated over the 20 steps (no instability over so short a horizon): 20 × 1e-9 L; the
    velocities by as much of their largest, the multipliers of theirs, the energies (kinetic, strain, work,
    dissipated) of the largest of them."""
    compiled, plain, domain = both(deck, {**overrides, "solver.output_every": 1})
    L, tol, steps = model_size(domain), 1e-9, len(compiled.time) - 1
    assert steps >= 20
    assert_within(plain.time, compiled.time, 1e-15, "times")
    assert_within(plain.positions, compiled.positions, steps * tol * L, "positions")
    assert_within(plain.rotations, compiled.rotations, steps * tol, "Euler parameters")
    speed = float(np.max(np.abs(compiled.velocities)))
    assert_within(plain.velocities, compiled.velocities, steps * tol * speed, "velocities")
    lam = float(np.max(np.abs(compiled.multipliers), initial=0.0))
    assert_within(plain.multipliers, compiled.multipliers, steps * tol * lam, "multipliers")
    energy = max(float(np.max(np.abs(compiled.energy[key]))) for key in ("kinetic", "strain", "external_work"))
    for key in ("kinetic", "strain", "external_work", "dissipated"):
        assert_within(plain.energy[key], compiled.energy[key], steps * tol * energy, key)


def test_cantilever_modes_agree():
    """cantilever_modes, the 10 lowest modes about the reference state: no Newton here, the same linearisation
    from the same generated physics (equal to round-off, tests/test_plain_model.py), so the frequencies agree
    to 1e-9 relative (an eigenvalue moves by the relative perturbation of K times its condition, about 1e3 for
    the slender beam's ω² spread), the zero-mode count and the mobility exactly."""
    compiled, plain, _ = both("cantilever_modes")
    f0, f1 = compiled.data("modes/frequency"), plain.data("modes/frequency")
    assert f0.size == 10
    assert_within(f1 / f0, np.ones_like(f0), 1e-9, "frequencies (relative)")
    for key in ("modes/zero_modes", "modes/mobility", "modes/constraint_rank", "modes/coordinates"):
        assert int(plain.data(key)) == int(compiled.data(key)), key


def test_lateral_buckling_load_factor_agrees():
    """lateral_buckling (a static path of 4 load steps, then the buckling eigenproblem): the load factor on
    both paths within 1e-8 relative.  The tangents at the two equilibria each come from an equilibrium
    within the Newton tolerance (1e-10 L) of the other path's, and ``K_g = K_1 − K_0`` is their difference,
    which loses about two digits of them (measured: the load factor ~1.02 while K's entries reach 1e8)."""
    compiled, plain, _ = both("lateral_buckling")
    mu0, mu1 = compiled.data("buckling/load_factor"), plain.data("buckling/load_factor")
    assert mu0.size == 1 and math.isfinite(mu0[0])
    assert_within(mu1 / mu0, np.ones_like(mu0), 1e-8, "load factor (relative)")


def test_lee_frame_arc_length_path_to_its_first_limit_point_agrees():
    """lee_frame's arc-length path on its former mesh (80 Beam2), its first 30 points, past the first limit load: the load factors,
    configurations and stability counts on both paths, and the critical point.  Every point is a corrector
    converged to the Newton tolerance (1e-10 of L for a correction) on the same normal plane, so the load
    factors agree to about that, accumulated over the points' predictors (each taken from the previous point):
    30 × 2e-10, the positions to 30 × 2e-10 L.  The limit point's load factor is located by the same secant steps
    on the lowest eigenvalue from those points: within 1e-8 relative (the eigenvalue's round-off near zero over
    its slope; measured 4e-16); the kind exactly."""
    with pytest.warns(ModelWarning, match="stability lost between load factor 1.8511 and 1.85592"):
        compiled, plain, domain = both("lee_frame", {**LEE_FRAME_BEAM2, "solver.max_points": 30})
    L, tol, points = model_size(domain), 1e-10, 30
    lam0 = compiled.data("path/load_factor")
    assert lam0.size == points + 1 and np.max(lam0) > 1.8  # the path passed the first limit load, 1.856
    assert_within(plain.data("path/load_factor"), lam0, points * 2 * tol, "load factors")
    assert_within(plain.data("path/arc_length"), compiled.data("path/arc_length"), points * 2 * tol, "arc lengths")
    assert_within(plain.positions, compiled.positions, points * 2 * tol * L, "positions")
    assert_within(plain.data("path/negative_eigenvalues"), compiled.data("path/negative_eigenvalues"), 0.0,
                  "stability counts")
    critical = compiled.data("path/critical_load_factor")
    assert critical.size == 1 and list(plain.data("path/critical_kind")) == ["limit point"]
    assert_within(plain.data("path/critical_load_factor") / critical, np.ones(1), 1e-8, "limit load (relative)")


def test_displacement_control_of_the_von_mises_truss_agrees():
    """The von Mises truss of tests/test_arc_length.py under displacement control of its apex (30 points of
    0.005 × its size, through both limit points): the load factors, configurations and the two limit loads on
    both paths.  Each point's corrector converges to the Newton tolerance (1e-10) on the same plane (the apex
    held where the previous point put it plus the step), so the load factors agree within 30 × 2e-10 and the
    limit loads, located by the same secant steps, within 1e-8 relative (measured 1e-15); each path says the
    same two lines."""
    from test_arc_length import truss

    runs, said = [], []
    for backend in ("compiled", "reference"):
        domain = truss(algorithm="arc_length", arc_length=0.005, max_points=30, max_load_factor=10.0)
        domain.solver.control = (domain.node("left:1").id, 2, "position.z:left:1")
        domain.solver.backend = backend
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            runs.append(domain.solve())
        said.append([str(w.message).split(" (critical")[0] for w in caught if issubclass(w.category, ModelWarning)])
    assert len(said[0]) == 2 and said[0][0].startswith("stability lost") and said[1] == said[0], said
    compiled, plain = runs
    L = model_size(domain)
    assert_within(plain.data("path/load_factor"), compiled.data("path/load_factor"), 30 * 2e-10, "load factors")
    assert_within(plain.positions, compiled.positions, 30 * 2e-10 * L, "positions")
    critical = compiled.data("path/critical_load_factor")
    assert critical.size == 2 and list(plain.data("path/critical_kind")) == ["limit point", "limit point"]
    assert_within(plain.data("path/critical_load_factor") / critical, np.ones(2), 1e-8, "limit loads (relative)")


def test_rotating_cantilever_modes_about_the_steady_rotation_agree():
    """rotating_cantilever, the 4 lowest modes in the frame spinning with the beam: the relative equilibrium is
    a Newton solution (tolerance 1e-10 of L) on both paths, and the co-rotating M, D, K come from it, so the
    frequencies agree to 1e-8 relative (the Newton tolerance amplified by the stiff beam's condition, as for
    buckling), the kinds exactly."""
    compiled, plain, _ = both("rotating_cantilever")
    f0, f1 = compiled.data("modes/frequency"), plain.data("modes/frequency")
    assert f0.size == 4 and np.all(f0 > 0.0)
    assert_within(f1 / f0, np.ones_like(f0), 1e-8, "frequencies (relative)")
    assert list(plain.data("modes/kind")) == list(compiled.data("modes/kind"))
    assert float(plain.data("modes/spin_rate")) == float(compiled.data("modes/spin_rate"))


def test_generalized_alpha_step_cuts_as_compiled():
    """steel_three_bar at dt = 0.05 s with at most 4 Newton corrections a step: steps fail and are halved, then
    grow back (reference/plain/alpha_control.py, the compiled rules).  Both paths cut the same steps at the same
    outputs (the same rules on iterates equal to within the Newton tolerance) and reach the same motion: the
    positions within 1e-9 L a step over the steps taken (as for the fixed steps)."""
    compiled, plain, domain = both("steel_three_bar", {"t_end": 0.15, "dt": 0.05, "solver.max_iterations": 4})
    cuts = compiled.data("solver/step_cuts")
    assert np.sum(cuts) >= 5
    assert_within(plain.data("solver/step_cuts"), cuts, 0.0, "step cuts per output")
    assert_within(plain.data("solver/step_size"), compiled.data("solver/step_size"), 0.0, "step at each output")
    steps = float(np.sum(compiled.data("solver/steps")))
    assert_within(plain.positions, compiled.positions, steps * 1e-9 * model_size(domain), "positions")


def test_generalized_alpha_error_control_agrees_within_the_error_tolerance():
    """steel_three_bar with error_tolerance = 1e-4: the steps are chosen from the local error estimate on both
    paths by the same controller (reference/plain/alpha_control.py).  The two step sequences part where an
    estimate near 1 falls either side of the rejection, so the motions agree not to the Newton tolerance but to
    the error tolerance: each path keeps its local error below 1e-4 of the coordinates' increments, so the
    positions agree within 1e-4 L and the velocities within 1e-4 of their largest; the first interval's steps,
    before any such parting, are the same."""
    compiled, plain, domain = both("steel_three_bar", {"t_end": 0.05, "solver.error_tolerance": 1e-4,
                                                       "solver.output_every": 10})
    assert float(np.sum(compiled.data("solver/steps"))) > 50  # the control chose steps well below dt = 1e-3
    assert_within(plain.data("solver/steps")[:2], compiled.data("solver/steps")[:2], 0.0, "first interval's steps")
    assert_within(plain.positions, compiled.positions, 1e-4 * model_size(domain), "positions")
    speed = float(np.max(np.abs(compiled.velocities)))
    assert_within(plain.velocities, compiled.velocities, 1e-4 * speed, "velocities")


def test_branch_switch_onto_the_post_buckled_branch_agrees():
    """The perfect lateral–torsional cantilever of tests/test_arc_length.py with ``branch_switch``: the path
    flags the bifurcation, then leaves along the critical mode (Δλ = 0) onto the post-buckled branch.  The same
    bifurcation (kind; its load factor within 1e-6 relative: located by secant steps on the eigenvalue nearest
    zero at probe points solved to the Newton tolerance, on a perfect beam whose critical eigenvalue there is
    sensitive to it, as for the static path's bifurcation; measured 1.9e-7), the same stability counts, the
    same points:
    load factors within 16 × 2e-10 and positions within 16 × 2e-10 L (Newton's tolerance at each point, as
    for lee_frame); the lateral tip displacement on the branch is a result of the switch, so it is compared
    too (through the positions)."""
    from test_arc_length import ltb

    runs = []
    for backend in ("compiled", "reference"):
        domain = ltb(arc_length=0.05, max_points=16, max_load_factor=1.5, branch_switch=True)
        domain.solver.backend = backend
        with pytest.warns(ModelWarning, match="stability lost .*: bifurcation"):
            runs.append(domain.solve())
    compiled, plain = runs
    lateral = compiled.position("beam:end")[:, 1]
    assert abs(lateral[-1]) > 0.05  # the switch happened: the tip moved sideways
    assert_within(plain.data("path/load_factor"), compiled.data("path/load_factor"), 16 * 2e-10, "load factors")
    assert_within(plain.positions, compiled.positions, 16 * 2e-10 * model_size(domain), "positions")
    assert_within(plain.data("path/negative_eigenvalues"), compiled.data("path/negative_eigenvalues"), 0.0,
                  "stability counts")
    critical = compiled.data("path/critical_load_factor")
    assert list(plain.data("path/critical_kind")) == ["bifurcation"]
    assert_within(plain.data("path/critical_load_factor") / critical, np.ones(1), 1e-6, "bifurcation (relative)")


NO_DISPATCHER = """
import sys, warnings
import numba
from reference.io.deck import load_deck

warnings.simplefilter("ignore")


def signatures():
    return {(name, attribute): len(value.signatures) for name, module in list(sys.modules.items())
            if name.startswith("reference") for attribute, value in vars(module).items()
            if isinstance(value, numba.core.dispatcher.Dispatcher)}


called = set()
for deck, overrides in [("embedded_beam_static", None), ("cantilever_modes", None), ("lateral_buckling", None),
                        ("steel_three_bar", {"t_end": 0.01}), ("lee_frame", {"solver.max_points": 2, **LEE_FRAME_BEAM2})]:
    domain = load_deck(f"models/{deck}.toml", overrides).domain
    domain.solver.backend = "reference"
    before = signatures()
    assert domain.solve().status == "completed", deck
    called |= {key for key, count in signatures().items() if count != before.get(key, 0)}
print(sorted(called))
"""
def test_the_implicit_twins_call_no_numba_dispatcher_of_their_own():
    """Static, modes, buckling, generalized-α and arc length on the reference path, in a fresh process (what other
    tests compiled would hide a call): no numba dispatcher gets a new signature."""
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    script = f"LEE_FRAME_BEAM2 = {LEE_FRAME_BEAM2!r}\n{NO_DISPATCHER}"  # lee_frame's former Beam2 mesh
    out = subprocess.run([sys.executable, "-c", script], cwd=root, capture_output=True, text=True, timeout=900,
                         env={**os.environ, "PYTHONPATH": str(root)})
    assert out.returncode == 0, out.stderr[-2000:]
    assert ast.literal_eval(out.stdout.strip()) == []
