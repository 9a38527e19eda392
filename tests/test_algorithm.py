"""The staggered algorithm one step at a time, and the time functions."""

from __future__ import annotations

import numpy as np
import pytest

from reference.algorithms import step
from reference.domain import Domain, SolverSettings
from reference.interactions import Constant, PiecewiseLinear, Ramp, Sine, SmoothStep, Step, NodalLoad


def free_mass(m=2.0, J=(1.0, 2.0, 3.0)):
    d = Domain("point")
    n = d.add_node([0.0, 0.0, 0.0], label="body")
    n.mass, n.inertia = m, np.diag(J)
    return d, n


def test_step_is_a_pure_function_of_state():
    """step() returns a new state and leaves its input untouched; two calls agree bit for bit."""
    d, n = free_mass()
    n.velocity = np.array([1.0, 0.0, 0.0])
    n.angular_velocity = np.array([0.3, 0.2, 0.1])
    model, s0 = d.initialization(), d.initial_conditions()
    before = s0.copy()
    s1 = step(model, s0, 0.01)
    s1b = step(model, s0, 0.01)
    for a, b in zip(before, s0):
        assert np.array_equal(a, b)
    for a, b in zip(s1, s1b):
        assert np.array_equal(a, b)
    assert s1.n == 1 and s1.t == pytest.approx(0.01)


def test_constant_force_is_integrated_exactly():
    """Central differences with the half-step start-up integrate a constant acceleration
    exactly: x(t) = x0 + v0 t + F t²/(2m) to round-off."""
    d, n = free_mass(m=2.0)
    n.velocity = np.array([0.5, -1.0, 0.0])
    d.add_interaction(NodalLoad(n, np.array([1.0, 2.0, -4.0])))
    d.solver = SolverSettings(dt=0.01, t_end=1.0, output_every=10)
    r = d.solve()
    t = r.time[:, None]
    exact = np.array([0.5, -1.0, 0.0]) * t + np.array([1.0, 2.0, -4.0]) / 2.0 * t**2 / 2.0
    assert np.allclose(r.position("body"), exact, atol=1e-12)
    assert np.allclose(r.velocity("body"), np.array([0.5, -1.0, 0.0]) + np.array([1.0, 2.0, -4.0]) / 2.0 * t, atol=1e-12)


def test_follower_moment_on_free_body_spins_about_body_axis():
    """A follower moment about body axis 3 of an axisymmetric body gives ω3 = M t / J3 and
    rotation angle M t²/(2 J3) about axis 3 (the axis stays fixed): checked to 1e-10."""
    d, n = free_mass(J=(2.0, 2.0, 3.0))
    d.add_interaction(NodalLoad(n, np.array([0.0, 0.0, 0.6]), moment=True, follower=True))
    d.solver = SolverSettings(dt=1e-3, t_end=2.0, output_every=100)
    r = d.solve()
    w = r.angular_velocity("body")[-1]
    assert w == pytest.approx([0.0, 0.0, 0.6 * 2.0 / 3.0], abs=1e-10)
    q = r.rotation("body")[-1]
    angle = 2 * np.arctan2(q[3], q[0])
    assert angle == pytest.approx(0.6 * 4.0 / 6.0, rel=1e-6)  # trapezoidal rule: O(h²) on the angle


@pytest.mark.parametrize(
    "tf, t, value, rate, integral",
    [
        (Constant(2.0), 3.0, 2.0, 0.0, 6.0),
        (Ramp(1.0, 3.0, 0.0, 4.0), 2.0, 2.0, 2.0, 1.0),
        (Ramp(1.0, 3.0, 0.0, 4.0), 5.0, 4.0, 0.0, 12.0),
        (Step(1.0, 1.0, 3.0), 2.0, 3.0, 0.0, 4.0),
        (PiecewiseLinear([0.0, 1.0, 3.0], [0.0, 2.0, 0.0]), 2.0, 1.0, -1.0, 2.5),
        (Sine(2.0, np.pi, 0.0, 1.0), 0.5, 3.0, 0.0, 0.5 + 2.0 / np.pi),
        (SmoothStep(0.0, 2.0, 0.0, 1.0), 1.0, 0.5, 0.75, 0.1875),
    ],
)
def test_time_functions(tf, t, value, rate, integral):
    """Values, rates and integrals by hand."""
    assert tf(t) == pytest.approx(value)
    assert tf.derivative(t) == pytest.approx(rate)
    assert tf.integral(t) == pytest.approx(integral)


@pytest.mark.parametrize("tf", [Ramp(0.5, 1.5, 1.0, -2.0), PiecewiseLinear([0.0, 0.4, 1.0, 1.7], [1.0, -1.0, 2.0, 0.5]),
                                Sine(1.5, 3.0, 0.2, -0.5), SmoothStep(0.3, 1.2, 2.0, -1.0), Step(0.7, 1.0, -2.0)])
def test_time_function_integral_and_derivative_are_consistent(tf):
    """integral' = value (central differences, h = 1e-6: error ≤ h·(slope jump) ≈ 1e-5 at a kink)
    and value' = derivative away from kinks."""
    for t in np.linspace(0.05, 1.95, 23):
        h = 1e-6
        assert (tf.integral(t + h) - tf.integral(t - h)) / (2 * h) == pytest.approx(tf(t), abs=1e-5)
        if all(abs(t - k) > 1e-3 for k in (0.3, 0.4, 0.5, 0.7, 1.0, 1.2, 1.5, 1.7)):
            assert (tf(t + h) - tf(t - h)) / (2 * h) == pytest.approx(tf.derivative(t), abs=1e-5)


def test_kernels_run_as_plain_python_and_agree_with_compiled(tmp_path):
    """NUMBA_DISABLE_JIT=1 runs the same kernels as Python: 100 steps of the roll-up and of the
    three-bar with one master/slave joint (beam, joint, multiplier and elimination kernels)
    agree with the compiled runs to 1e-12 (compiled code may reorder floating-point operations)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from reference.io.deck import load_deck

    models = Path(__file__).resolve().parent.parent / "models"
    three_bar = tmp_path / "three_bar_ms.toml"
    three_bar.write_text((models / "three_bar.toml").read_text().replace(
        'label = "A"', 'label = "A"\nformulation = "master_slave"'))
    for deck, t_end in ((models / "embedded_beam.toml", 0.02), (three_bar, 0.02)):
        code = ("import json; from reference.io.deck import load_deck; "
                f"r = load_deck({str(deck)!r}, overrides={{'t_end': {t_end}}}).solve(); "
                "print(json.dumps(r.positions[-1].tolist()))")
        env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        python_positions = np.array(json.loads(out.stdout))
        compiled = load_deck(deck, overrides={"t_end": t_end}).solve().positions[-1]
        assert np.allclose(python_positions, compiled, rtol=0, atol=1e-12), deck.name
