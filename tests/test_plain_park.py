"""Park's step on the reference path (reference/plain/park.py) against the compiled step, step by step.

Each step of :class:`reference.plain.park.ReferenceStaggered` and of the compiled
:class:`reference.algorithms.staggered.StaggeredCentralDifference` starts from the same model and state; the
states and the output records (energies, constraint norms, multipliers) must agree to round-off at every
step of a short horizon (the two paths sum in different orders and factor the constraint matrix in different
pivot orders), and a blow-up must stop both at the same step with the same message.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from reference.monitor import energy_floor
from reference.plain import backend, park
from reference.plain.model import Evaluation
from reference.errors import SolverDiverged
from reference.state import GUARD, Record
from reference.io.deck import load_deck

ROOT = Path(__file__).resolve().parents[1]
STEPS = 25
"""Steps compared one by one: the half kick of the first step, then full steps."""
RTOL = 1e-10
"""Agreement relative to each quantity's scale over the steps (issue 37: explicit paths to round-off)."""
DECKS = ("three_bar", "slider_crank", "double_pendulum", "heavy_top", "torque_free_body", "force_elements_crosscheck")
"""Beams with revolute joints and a drive (three-bar, slider-crank), rigid bodies in a chain, a spinning top on a
spherical joint, a free body (the gyroscopic sweeps) and every force element (dampers, their dissipation)."""


def _start(name: str):
    domain = load_deck(ROOT / "models" / f"{name}.toml").domain
    model = domain.initialization()
    state = domain.initial_conditions()
    return domain, model, state


def _close(ours: np.ndarray, theirs: np.ndarray, scale: float, what: str) -> None:
    error = float(np.max(np.abs(ours - theirs), initial=0.0))
    assert error <= RTOL * scale, f"{what}: {error:.3g} against the scale {scale:.3g}"


@pytest.mark.parametrize("name", DECKS)
def test_steps_equal_the_compiled_steps(name):
    domain, model, start = _start(name)
    compiled = domain.algorithm()
    plain = backend.twin(compiled)
    assert isinstance(plain, park.ReferenceStaggered) and plain.dt == compiled.dt
    critical, floor = domain.critical_time_step(), energy_floor(model, start.x)
    ours, theirs = start.copy(), start.copy()
    run_ours, run_theirs = plain.start(model, ours, critical, floor), compiled.start(model, theirs, critical, floor)
    size = max(float(np.abs(start.x).max()), 1.0)
    history = []
    for _ in range(STEPS):
        rec_ours, rec_theirs = (Record.empty(len(start.x), model.n_constraints) for _ in range(2))
        assert plain.advance(model, ours, run_ours, 1, rec_ours) == compiled.advance(model, theirs, run_theirs, 1,
                                                                                      rec_theirs) == 0
        history.append((ours.copy(), theirs.copy(), rec_ours, rec_theirs))
    # the scales: the largest value of each quantity over the run (a constraint norm: the model's size)
    speed = max(np.abs(h[1].v).max() + size * np.abs(h[1].w).max() for h in history)
    energy = max(np.abs(h[3].energy).max() for h in history) or 1.0
    force = max(np.abs(h[3].lam).max(initial=0.0) for h in history) or 1.0
    for k, (s_ours, s_theirs, r_ours, r_theirs) in enumerate(history):
        where = f"{name}, step {k + 1}"
        _close(s_ours.x, s_theirs.x, size, f"x, {where}")
        _close(s_ours.q, s_theirs.q, 1.0, f"q, {where}")
        _close(np.hstack([s_ours.v, size * s_ours.w]), np.hstack([s_theirs.v, size * s_theirs.w]), speed,
               f"v, ω, {where}")
        _close(s_ours.clock.view(float), s_theirs.clock.view(float), max(energy, s_theirs.t),
               f"clock (t, n, W, D), {where}")
        _close(s_ours.angle, s_theirs.angle, 1.0, f"the springs' angles, {where}")
        _close(r_ours.energy, r_theirs.energy, energy, f"recorded energies, {where}")
        _close(r_ours.constraint, r_theirs.constraint, max(size, speed), f"recorded ‖Φ‖, ‖BV + Φ_t‖, {where}")
        _close(r_ours.lam, r_theirs.lam, force, f"multipliers, {where}")
    assert run_ours.energy == pytest.approx(run_theirs.energy, rel=RTOL, abs=RTOL * energy)


def test_the_stages_in_order_are_the_step():
    """The lesson's hand step (one call per stage of Fig. 10) is :func:`park.solve_step`, bit for bit."""
    domain, model, start = _start("three_bar")
    ev, h = Evaluation(model), domain.solver.dt
    by_hand, whole = start.copy(), start.copy()
    guard = np.zeros(1, GUARD)  # off (tolerance 0)
    for _ in range(3):
        f = park.forces(ev, by_hand)
        hk = park.kick_length(by_hand, h)
        kick = park.predict(ev, by_hand, f, hk, extra=park.CONSTRAINED_SWEEPS)
        new = park.constrain(ev, by_hand, f, kick, h, hk)
        by_hand.clock[0]["work"] += park.work_of_loads(by_hand, f.F, h)
        loss = park.damping_loss(ev, by_hand, new, hk)
        by_hand.clock[0]["work"] += hk * park.power_of_constraints(by_hand, new)
        by_hand.clock[0]["dissipated"] += loss
        park.drift(ev, by_hand, new, f.F, h)
        assert park.solve_step(ev, whole, h, guard) == 0
        for a, b in zip(by_hand, whole):
            np.testing.assert_array_equal(a, b)
    assert new.lam.shape == (model.n_constraints,) and np.all(np.isfinite(new.accelerations(by_hand, hk)))


def test_a_blow_up_stops_both_paths_at_the_same_step():
    """A step 1.6 × the critical one (allowed on purpose): the energy guard of either path stops the run after
    the same step, with the same message."""
    messages = {}
    for name in ("compiled", "reference"):
        domain = load_deck(ROOT / "models" / "cantilever_vibration.toml",
                                  overrides={"dt": 3e-4, "solver.allow_unsafe_dt": True, "t_end": 0.6}).domain
        domain.solver.backend = name
        with pytest.raises(SolverDiverged) as stop:
            domain.solve()
        messages[name] = (str(stop.value), domain.last_run["status"])
    assert messages["reference"] == messages["compiled"]
    assert "energy balance failed" in messages["reference"][0]


SOLVE_ON_THE_REFERENCE_PATH = """
import sys, numba
from reference.io.deck import load_deck

def dispatchers():
    return {(name, key): len(value.signatures) for name, module in list(sys.modules.items())
            if name.startswith("reference") for key, value in vars(module).items()
            if isinstance(value, numba.core.dispatcher.Dispatcher)}

called = set()
for deck in ("three_bar", "force_elements_crosscheck", "torque_free_body"):
    domain = load_deck(f"models/{deck}.toml", overrides={"t_end": 0.01}).domain
    domain.solver.backend = "reference"
    before = dispatchers()
    assert domain.solve().status == "completed", deck
    called |= {key for key, n in dispatchers().items() if n != before.get(key, 0)}
print(sorted(called))
"""
"""Explicit runs of the reference path in a fresh process (in this one, what other tests compiled would hide a
call): the numba dispatchers that gained a signature during the runs (the model's set-up before excluded)."""


def test_the_reference_step_and_its_outputs_call_no_compiled_kernel():
    """No numba dispatcher gains a signature: the step, its outputs and the solution loop's monitor are NumPy."""
    import ast
    import os
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", SOLVE_ON_THE_REFERENCE_PATH], cwd=ROOT, capture_output=True, text=True,
                         timeout=900, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stderr[-2000:]
    assert ast.literal_eval(out.stdout.strip().splitlines()[-1]) == []
