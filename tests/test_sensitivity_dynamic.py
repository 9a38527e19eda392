"""Generalized-α sensitivities by the tangent-linear step (reference/sensitivity/dynamic.py, issue 40): the
three-bar's coupler deflection against central differences of whole runs."""

import numpy as np
import pytest

from reference.io.deck import load_deck
from reference.io.deck_parameters import ParameterError
from reference.io.deck_sensitivities import dynamic_sensitivities, static_sensitivities
from reference.observables import parse

THREE_BAR = "models/three_bar.toml"
OUT = "midspan_deflection:coupler"
ALPHA = {"solver.algorithm": "generalized_alpha", "t_end": 2.0, "dt": 1e-2, "solver.output_every": 1,
         "solver.backend": "reference"}
"""The three-bar on generalized-α for 2 s (the crank's spin-up) in steps of 10 ms (200 steps: the test's cost)."""


def _history(extra):
    r = load_deck(THREE_BAR, overrides={**ALPHA, **extra}).domain.solve()
    return parse(OUT, r).evaluate(r)


@pytest.mark.parametrize("name, value", [("sections.coupler.EI2", 1e3),
                                         ("time_functions.crank_speed.v1", 1.5707963267948966)])
def test_three_bar_deflection_sensitivity_matches_central_differences(name, value):
    # The coupler bends in the plane about its section axis 2 (EI2 in this deck: axis2 is out of plane); the crank
    # speed's scale is the smooth step's end value.  Central differences of whole runs (relative step 1e-6):
    # truncation O(1e-12), the runs' Newton tolerance and round-off leave ~1e-7 of the peak (measured 1.4e-7
    # and 1.1e-7 over the 2 s); issue 40's bound 1e-5 of the peak, over the whole history.
    t, out = dynamic_sensitivities(THREE_BAR, [name], [OUT], ALPHA)
    d = np.asarray(out[OUT][name])
    h = 1e-6
    fd = (_history({name: value * (1 + h)}) - _history({name: value * (1 - h)})) / (2 * h * value)
    assert d.shape == fd.shape and len(t) == 201
    assert np.max(np.abs(d - fd)) <= 1e-5 * np.max(np.abs(fd))


def test_time_function_parameters_are_refused_where_not_built():
    with pytest.raises(ParameterError, match="generalized-α runs only"):
        static_sensitivities("models/embedded_beam_static.toml", ["time_functions.load_factor.v1"],
                             ["position:beam:end"])


SHORT = {**ALPHA, "t_end": 0.5}
"""The first 0.5 s (50 steps): the kinds' checks below need the tangent-linear step's wiring, not the long run."""


@pytest.mark.parametrize("name, value", [("sections.coupler.rhoA", 1.0), ("sections.coupler.rhoJ2", 0.01),
                                         ("sections.bar.rhoA", 1.0)])
def test_three_bar_mass_sensitivities_match_central_differences(name, value):
    # The masses' kind (∂m/∂p, ∂J/∂p taken once; the initial accelerations' sensitivity from A s' = [−∂r/∂p; 0])
    # against central differences of whole runs: 1e-5 of the peak.  Relative step 1e-4: the whole runs' Newton
    # tolerance leaves ~1e-8 (absolute, in these units) in their difference, which a step of 1e-6 of a small
    # inertia (ρJ2 = 0.01) turns into 1e-4 of the peak; at 1e-4 the truncation is O(1e-8) and that noise 1e-6
    # (measured 9.0e-7 for ρJ2, 4.5e-7 for the bars' ρA).
    t, out = dynamic_sensitivities(THREE_BAR, [name], [OUT], SHORT)
    d = np.asarray(out[OUT][name])
    h = 1e-4
    r = [load_deck(THREE_BAR, overrides={**SHORT, name: value * (1 + s * h)}).domain.solve() for s in (1, -1)]
    fd = (parse(OUT, r[0]).evaluate(r[0]) - parse(OUT, r[1]).evaluate(r[1])) / (2 * h * value)
    assert np.max(np.abs(fd)) > 0.0
    assert np.max(np.abs(d - fd)) <= 1e-5 * np.max(np.abs(fd))


def test_torsion_pendulum_spring_and_mass_sensitivities_match_central_differences():
    # Rigid bodies, revolute joints, gravity: a spring's stiffness (its element alone) and a body's mass and inertia
    # scale on generalized-α (0.5 s in 10 ms steps), the lower bar's x against central differences (relative 1e-6).
    deck, obs = "models/torsion_double_pendulum.toml", "position:lower"
    over = {"solver.algorithm": "generalized_alpha", "t_end": 0.5, "dt": 1e-2, "solver.output_every": 1,
            "solver.backend": "reference"}
    names = ["springs[0].stiffness", "rigid_bodies.upper.mass"]
    t, out = dynamic_sensitivities(deck, names, [obs], over)
    h = 1e-6
    for name, key, value in zip(names, ["springs.0.stiffness", "rigid_bodies.0.mass"], [5.0, 1.0]):
        r = [load_deck(deck, overrides={**over, key: value * (1 + s * h)}).domain.solve() for s in (1, -1)]
        fd = (parse(obs, r[0]).evaluate(r[0]) - parse(obs, r[1]).evaluate(r[1])) / (2 * h * value)
        d = np.asarray(out[obs][name])
        assert np.max(np.abs(fd)) > 0.0
        assert np.max(np.abs(d - fd)) <= 1e-5 * np.max(np.abs(fd)), name
