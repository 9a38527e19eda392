"""Cantilever checks against analytic beam theory: Timoshenko static tip deflection
under a small tip load, and the first bending frequency in free vibration."""

from __future__ import annotations

import numpy as np
import pytest

from flexmbs.verification.analytic import cantilever_first_frequency, cantilever_tip_deflection
from reference.domain import SolverSettings
from reference.elements import Section
from reference.interactions import NodalLoad, SmoothStep

from conftest import cantilever


def test_small_tip_load_gives_timoshenko_deflection():
    """Tip deflection under P (linear range) = P L³/(3 EI2) + P L/GA3 (Timoshenko).

    Static state by dynamic relaxation (mass-proportional damping at about
    critical for the first mode, load applied with a smooth step).  The shear
    term is 3 % of the total, so Euler–Bernoulli alone would fail the check.
    Tolerance 0.15 %: the one-point linear element's bending error is
    1/(4n²) = 0.0625 % at n = 20, geometric nonlinearity at δ/L = 3.4e-4 is
    ~1e-7, and the residual dynamics after relaxation are below 1e-5.
    """
    L, EI, GA, P = 1.0, 1.0, 10.0, 1e-3
    sec = Section(EA=1e3, GA2=GA, GA3=GA, GJ=1.0, EI2=EI, EI3=EI, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)
    d, nodes = cantilever(20, sec, L)
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, P]), time_function=SmoothStep(0.0, 1.0, 0.0, 1.0)))
    d.solver = SolverSettings(dt=1e-3, t_end=12.0, damping=7.0, output_every=1000)
    assert d.critical_time_step() > 1.5 * d.solver.dt
    r = d.solve()
    tip = r.position("beam:20")[-1]
    expected = cantilever_tip_deflection(P, L, EI, GA)
    assert tip[2] == pytest.approx(expected, rel=1.5e-3)
    # Sharper: the one-point linear element's bending part is exactly P L³/(3EI)(1 − 1/(4n²))
    # (measured −6.2526e-4 against −6.25e-4 at n = 20); 1e-5 covers nonlinearity and relaxation.
    discrete = P * L / GA + P * L**3 / (3 * EI) * (1.0 - 1.0 / (4 * 20**2))
    assert tip[2] == pytest.approx(discrete, rel=1e-5)
    assert abs(tip[1]) == 0.0  # no load, no coupling out of the x–z plane
    assert np.max(np.abs(r.velocity("beam:20")[-1])) < 1e-5 * expected


def test_first_bending_frequency_of_free_vibrating_cantilever():
    """ω1 = 1.87510² √(EI/(ρA L⁴)) (Euler–Bernoulli clamped–free).

    Initial transverse velocity in the shape (x/L)², close to mode 1; the period
    is measured from upward zero crossings of the tip deflection over three
    periods.  Timoshenko corrections for r/L = 0.01 and EI/(GA L²) = 1e-5 are
    below 0.05 %; lumped-mass discretisation with 20 elements is O(h²) ≈ 0.2 %:
    tolerance 0.5 %.
    """
    L, EI, rhoA = 1.0, 1.0, 1.0
    sec = Section(EA=1e5, GA2=1e5, GA3=1e5, GJ=1.0, EI2=EI, EI3=EI, rhoA=rhoA, rhoJ1=2e-4, rhoJ2=1e-4, rhoJ3=1e-4)
    d, nodes = cantilever(20, sec, L)
    for n in nodes[1:]:
        n.velocity = np.array([0.0, 0.0, 1e-3 * (n.position[0] / L) ** 2])
    omega = cantilever_first_frequency(L, EI, rhoA)
    period = 2 * np.pi / omega
    d.solver = SolverSettings(dt=5e-5, t_end=round(3.2 * period, 2), output_every=10)
    assert d.critical_time_step() > 1.1 * d.solver.dt
    r = d.solve()
    z = r.position("beam:20")[:, 2]
    t = r.time
    up = np.where((z[:-1] < 0) & (z[1:] >= 0))[0]
    crossings = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    assert len(crossings) >= 2
    measured = 2 * np.pi / np.mean(np.diff(crossings))
    assert measured == pytest.approx(omega, rel=5e-3)
