"""Every deck in models/ states its source and its checks, and runs; the gallery's closed forms are right.

The full checks of each deck are in the verification report (``flexmbs report``,
``tests/test_cli.py`` runs its quick version); here every deck — including the
ones other features add — runs a short horizon and must stay finite, keep its
constraints and balance its energy.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from flexmbs.verification import analytic
from reference.io.deck import load_deck

ROOT = Path(__file__).resolve().parent.parent
DECKS = sorted((ROOT / "models").glob("*.toml"))


def test_at_least_ten_decks():
    assert len(DECKS) >= 10


@pytest.mark.parametrize("deck", DECKS, ids=lambda p: p.stem)
def test_deck_states_its_source_and_the_reason_for_every_tolerance(deck):
    d = load_deck(deck)
    assert d.metadata.get("provenance") and d.domain.description
    for name, spec in {**d.checks, **d.crosscheck}.items():
        assert "tolerance" in spec and len(str(spec.get("reason", ""))) > 20, name
    assert d.checks or d.crosscheck, "a deck checks something"


@pytest.mark.parametrize("deck", DECKS, ids=lambda p: p.stem)
def test_deck_runs_a_short_horizon_and_balances_energy(deck):
    d = load_deck(deck).domain
    interval = d.solver.dt * d.solver.output_every
    t_end = min(d.solver.t_end, max(2, int(round(0.1 / interval))) * interval)
    d = load_deck(deck, overrides={"t_end": t_end}).domain
    r = d.solve()
    assert r.status == "completed" and np.all(np.isfinite(r.positions))
    if d.model.n_constraints:
        assert np.nanmax(r.constraint_violation) < 1e-4
    e = r.energy
    balance = e["external_work"] - e["kinetic"] - e["strain"] - np.nan_to_num(e["dissipated"])
    scale = max(np.max(np.abs(e["kinetic"])), np.max(np.abs(e["external_work"])), np.max(np.abs(e["strain"])), 1e-12)
    # the energy balance holds to the scheme's accuracy (first order for the work of drives and damping)
    assert np.max(np.abs(balance - balance[0])) <= 1e-2 * scale


def test_pendulum_period_closed_form():
    # small amplitude: 2π √(I/(m g d)); 90°: the classical factor 1.18034
    T0 = 2 * np.pi * np.sqrt(1.0 / 9.81)
    assert analytic.pendulum_period(1e-6, 1.0, 1.0, 9.81, 1.0) == pytest.approx(T0, rel=1e-10)
    assert analytic.pendulum_period(np.pi / 2, 1.0, 1.0, 9.81, 1.0) / T0 == pytest.approx(1.18034, abs=1e-5)


def test_steady_precession_satisfies_the_euler_equations():
    m, g, l, A, C, w3, th = 1.0, 9.81, 0.5, 0.3, 0.08, 50.0, np.pi / 6
    W = analytic.steady_precession_rate(m, g, l, A, C, w3, th)
    assert m * g * l == pytest.approx(W * (C * w3 - A * W * np.cos(th)), rel=1e-12)
    assert W == pytest.approx(m * g * l / (C * w3), rel=0.2)  # the gyroscopic approximation


def test_torque_free_period_against_euler_equations():
    I, w0 = np.array([1.0, 2.0, 3.0]), np.array([0.01, 5.0, 0.01])
    T = analytic.torque_free_flip_period(I, w0)

    def rhs(t, w):
        return [(I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1], (I[0] - I[1]) * w[0] * w[1] / I[2]]

    sol = solve_ivp(rhs, [0, 2.2 * T], w0, rtol=1e-11, atol=1e-12, dense_output=True)
    t = np.linspace(0, 2.2 * T, 200001)
    w1 = sol.sol(t)[0]
    i = np.where((w1[:-1] < 0) & (w1[1:] >= 0))[0]
    ups = t[i] - w1[i] * (t[i + 1] - t[i]) / (w1[i + 1] - w1[i])
    assert np.diff(ups)[0] == pytest.approx(T, rel=1e-6)


def test_large_deflection_closed_form_against_the_elastica_ode_and_the_published_table():
    def tip(alpha):
        from scipy.optimize import brentq

        def rhs(s, y):
            return [y[1], -alpha * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])]

        def end_moment(k0):
            return solve_ivp(rhs, [0, 1], [0, k0, 0, 0], rtol=1e-12, atol=1e-13).y[1, -1]

        k0 = brentq(end_moment, 0.0, alpha)
        y = solve_ivp(rhs, [0, 1], [0, k0, 0, 0], rtol=1e-12, atol=1e-13).y[:, -1]
        return y[2], y[3], y[0]

    for alpha in (0.5, 1.0, 2.0):
        assert analytic.cantilever_large_deflection(alpha) == pytest.approx(tip(alpha), abs=1e-9)
    x, d, _ = analytic.cantilever_large_deflection(1.0)
    assert (x, d) == pytest.approx((0.94357, 0.30172), abs=1e-5)  # Bisshopp & Drucker (1945)


def test_double_pendulum_frequencies_of_a_point_mass_limit():
    # two equal point masses on massless rods of length 1: ω² = (2 ± √2) g
    w, _ = analytic.double_pendulum_frequencies(1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 9.81)
    assert w**2 == pytest.approx([(2 - np.sqrt(2)) * 9.81, (2 + np.sqrt(2)) * 9.81], rel=1e-12)


def test_andrews_equations_against_hairer_wanner_and_the_test_set():
    """``flexmbs.verification.andrews`` builds the squeezer's mass matrix from the bodies' kinematics: it is
    Hairer & Wanner's published M(q) (1996, §VII.7, transcribed below) to round-off at random angles; the
    test set's initial angles close the three loops, and the index-1 system gives its consistent initial
    accelerations and multipliers (the published 14222.44…, −10666.83… rad/s² and 98.5669, −6.1227 N)."""
    from flexmbs.verification import andrews

    p = andrews.PARAMETERS

    def published(q):
        m1, m2, m3, m4, m5, m6, m7 = (p[f"m{k}"] for k in range(1, 8))
        i1, i2, i3, i4, i5, i6, i7 = (p[f"i{k}"] for k in range(1, 8))
        rr, ra, da, sa, sb, e, ea, zt = p["rr"], p["ra"], p["da"], p["sa"], p["sb"], p["e"], p["ea"], p["zt"]
        ta, tb, zf, fa, u, ua, ub = p["ta"], p["tb"], p["zf"], p["fa"], p["u"], p["ua"], p["ub"]
        th, ph, om = q[1], q[3], q[5]
        M = np.zeros((7, 7))
        M[0, 0] = m1 * ra**2 + m2 * (rr**2 - 2 * da * rr * np.cos(th) + da**2) + i1 + i2
        M[1, 0] = m2 * (da**2 - da * rr * np.cos(th)) + i2
        M[1, 1] = m2 * da**2 + i2
        M[2, 2] = m3 * (sa**2 + sb**2) + i3
        M[3, 3] = m4 * (e - ea) ** 2 + i4
        M[4, 3] = m4 * ((e - ea) ** 2 + zt * (e - ea) * np.sin(ph)) + i4
        M[4, 4] = m4 * (zt**2 + 2 * zt * (e - ea) * np.sin(ph) + (e - ea) ** 2) + m5 * (ta**2 + tb**2) + i4 + i5
        M[5, 5] = m6 * (zf - fa) ** 2 + i6
        M[6, 5] = m6 * ((zf - fa) ** 2 - u * (zf - fa) * np.sin(om)) + i6
        M[6, 6] = m6 * ((zf - fa) ** 2 - 2 * u * (zf - fa) * np.sin(om) + u**2) + m7 * (ua**2 + ub**2) + i6 + i7
        return np.tril(M) + np.tril(M, -1).T

    rng = np.random.default_rng(22)
    for q in rng.uniform(-np.pi, np.pi, (5, 7)):
        M = published(q)
        assert np.max(np.abs(andrews.mass_matrix(q) - M)) <= 1e-14 * np.max(np.abs(M))
    assert np.max(np.abs(andrews.constraints(andrews.Q0))) < 1e-16
    qdd, lam = andrews.accelerations(andrews.Q0, np.zeros(7))
    assert qdd[:2] == pytest.approx([14222.4439199541138705911625887, -10666.8329399655854029433719415], rel=1e-11)
    assert lam[:2] == pytest.approx([98.5668703962410896057654982170, -6.12268834425566265503114393122], rel=1e-11)
    assert np.max(np.abs(qdd[2:])) < 1e-6 and np.max(np.abs(lam[2:])) < 1e-9
