"""The three-bar mechanism in Exudyn agrees with the reference engine (short horizon, for CI)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.exudyn_three_bar import crank_rotation, solve_three_bar_exudyn
from reference.analytic import fourbar_rocker_angle
from reference.domain import Domain
from reference.observables import midspan_deflection, rocker_angle, wrap

DECK = Path(__file__).resolve().parent.parent / "models" / "three_bar.toml"


def test_exudyn_and_reference_agree_on_the_three_bar_spin_up():
    """0 ≤ t ≤ 3 s (15,000 steps, through the spin-up): rocker angles within 2e-4 rad of each
    other (issue 4's tolerance; measured 1.8e-5 over the full 10 s) and mid-span deflection
    histories within 25 % of their peak (issue 4's tolerance at the 4-element mesh: lumped vs
    consistent mass, different rotation interpolation; measured 12 % over 10 s); Exudyn's
    crank follows the prescribed rotation."""
    d = Domain.from_deck(DECK, overrides={"t_end": 3.0})
    r = d.solve()
    e = solve_three_bar_exudyn(dt=d.solver.dt, t_end=3.0, output_every=d.solver.output_every)
    assert e["steps"] == 15000 and np.allclose(e["time"], r.time)
    theta = np.pi / 2 + np.array([crank_rotation(t) for t in e["time"]])
    crank = np.arctan2(e["crank"][:, 1], e["crank"][:, 0])
    assert np.max(np.abs(wrap(crank - theta))) < 1e-8
    rocker_e = np.arctan2(e["rocker"][:, 1], e["rocker"][:, 0] - 4.0)
    assert np.max(np.abs(wrap(rocker_angle(r) - rocker_e))) <= 2e-4
    assert np.max(np.abs(wrap(rocker_e - fourbar_rocker_angle(theta)))) < 1e-3
    P = e["coupler"]
    a, b, m = P[:, 0, :2], P[:, -1, :2], P[:, 2, :2]
    chord = b - a
    normal = np.stack([-chord[:, 1], chord[:, 0]], axis=1) / np.linalg.norm(chord, axis=1)[:, None]
    defl_e = np.sum((m - 0.5 * (a + b)) * normal, axis=1)
    defl_r = midspan_deflection(r)
    assert np.max(np.abs(defl_e - defl_r)) <= 0.25 * np.max(np.abs(defl_e))
