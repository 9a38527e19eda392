"""Reduced flexible bodies, part 2 (issue 39): the floating-frame formulation (reference/reduced/body.py).

The equations of motion come from the invariants (mass matrix, quadratic-velocity vector); the checks here use
only the nodal definition of the motion (``x_i = r + A (x̄_i + Φt_i q)``, node spin ``ω + Φr_i q̇``) and
physics that any wrong term breaks: in free flight the energy and the linear and angular momenta, summed node
by node, stay constant.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps
from scipy.integrate import solve_ivp

from reference.io.deck import load_deck
from reference.reduced.body import ReducedBody, nearest_velocities, steady_spin
from reference.reduced.craig_bampton import (beam_matrices, clamped_modes, craig_bampton, floating_modes, free_free,
                                             interface_positions, rotation_matrices)
from reference.reduced.invariants import invariants

MODELS = Path(__file__).resolve().parents[1] / "models"


def _qmul(a, b):
    return np.concatenate([[a[0] * b[0] - a[1:] @ b[1:]], a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])])


@pytest.fixture(scope="module")
def coupler():
    """The three-bar's coupler (5 m, 4 Beam2) with Craig–Bampton modes at both ends (4 fixed-interface modes:
    10 floating modes), the frame at its centre of mass."""
    domain = load_deck(MODELS / "three_bar.toml").domain
    beam = beam_matrices(domain, "coupler")
    ends = interface_positions(domain, beam, ["coupler:start", "coupler:end"])
    modes = floating_modes(beam, craig_bampton(beam, ends, 4))
    return beam, ReducedBody("coupler", beam, modes, invariants(beam, modes), interfaces=ends)


def _split(body, y):
    r = body.n_modes
    return y[:3], y[3:7], y[7:7 + r], y[7 + r:10 + r], y[10 + r:13 + r], y[13 + r:]


def _rates(body):
    def f(t, y):
        _, p, _, v, w, qd = _split(body, y)
        a = body.accelerations(p, _split(body, y)[2], w, qd)
        return np.concatenate([v, 0.5 * _qmul(p, np.concatenate([[0.0], w])), qd, a])
    return f


def _nodal(body, y):
    """Energy, linear and angular momentum (about the inertial origin) summed over the nodes."""
    x0, p, q, v, w, qd = _split(body, y)
    A = rotation_matrices(p[None])[0]
    m, J = body.masses
    u = body.rest + body.Pt @ q
    x = x0 + u @ A.T
    xd = v + (np.cross(w, u) + body.Pt @ qd) @ A.T
    spin = w + body.Pr @ qd
    T = 0.5 * np.sum(m * np.sum(xd * xd, axis=1)) + 0.5 * np.einsum("na,nab,nb->", spin, J, spin)
    L = np.sum(m[:, None] * np.cross(x, xd), axis=0) + A @ np.einsum("nab,nb->a", J, spin)
    return T + 0.5 * q @ body.K @ q, m @ xd, L


@pytest.mark.parametrize("frame", ["mean_axes", "clamped"])
def test_free_flight_conserves_energy_and_momenta(coupler, frame):
    """The coupler tumbling freely (spin 2 rad/s about an oblique axis, drifting at 1 m/s, every mode excited:
    centrifugal, Coriolis and gyroscopic coupling all at work), 0.5 s with DOP853 at rtol 1e-11, in two frames:
    mean axes (Craig–Bampton floating modes, ``S₁ = 0``, origin at the coupler's start) and clamped at the start
    node (6 fixed-interface modes, ``S₁ ≠ 0``).  The energy and both momenta, summed node by node, stay within
    1e-8 of their scale (measured ≤ 6e-11, the integrator's error); dropping any one quadratic-velocity term
    (the Coriolis factor 2, ``½ ωᵀ∂I ω``, ``İ_θθ ω``) moves the energy by 5e-3 to 0.9 (measured)."""
    beam, body = coupler
    if frame == "clamped":
        modes = clamped_modes(beam, 0, 6)
        body = ReducedBody("coupler", beam, modes, invariants(beam, modes, origin=beam.x[0]))
        assert np.abs(body.inv.modal_first_moment).max() > 0.1
    else:
        body = ReducedBody("coupler", beam, body.modes, invariants(beam, body.modes, origin=beam.x[0]))
    r = body.n_modes
    rng = np.random.default_rng(39)
    y0 = np.concatenate([[0.3, -0.2, 0.1], [1.0, 0, 0, 0], 1e-2 * rng.normal(size=r), [1.0, 0.0, 0.0],
                         2.0 * np.array([0.3, 0.5, 0.81]) / np.linalg.norm([0.3, 0.5, 0.81]), 0.1 * rng.normal(size=r)])
    sol = solve_ivp(_rates(body), (0.0, 0.5), y0, method="DOP853", rtol=1e-11, atol=1e-12, dense_output=False,
                    t_eval=np.linspace(0.0, 0.5, 11))
    assert sol.success
    E0, P0, L0 = _nodal(body, y0)
    T, U = body.energy(*_split(body, y0)[1:3], *_split(body, y0)[3:])
    assert T + U == pytest.approx(E0, rel=1e-12)  # the invariants' energy is the nodal one
    for y in sol.y.T:
        E, P, L = _nodal(body, y)
        assert abs(E - E0) <= 1e-8 * E0
        assert np.abs(P - P0).max() <= 1e-8 * np.linalg.norm(P0)
        assert np.abs(L - L0).max() <= 1e-8 * np.linalg.norm(L0)


def test_a_point_force_does_the_work_of_the_node_it_pushes(coupler):
    """The generalised force of a force and a moment at the coupler's end node: its power ``Qᵀ V`` equals
    ``f · ẋ_end + m · ω_end`` from the nodal definition, at a random state (1e-12 relative)."""
    _, body = coupler
    rng = np.random.default_rng(7)
    r = body.n_modes
    p = rng.normal(size=4)
    p /= np.linalg.norm(p)
    q, v, w, qd = 1e-2 * rng.normal(size=r), rng.normal(size=3), rng.normal(size=3), rng.normal(size=r)
    f, mom = rng.normal(size=3), rng.normal(size=3)
    end = body.interfaces[1]
    Q = body.point_force(end, p, q, f, mom)
    A = rotation_matrices(p[None])[0]
    u = body.rest[end] + body.Pt[end] @ q
    power = f @ (v + A @ (np.cross(w, u) + body.Pt[end] @ qd)) + mom @ (A @ (w + body.Pr[end] @ qd))
    assert Q @ np.concatenate([v, w, qd]) == pytest.approx(power, rel=1e-12)


def test_the_critical_step_is_that_of_the_stiffest_mode_and_the_mesh_deforms_by_the_modes(coupler):
    """critical_time_step is 2/ω of the highest floating mode (1e-12); the deformed mesh at rest is the beam."""
    beam, body = coupler
    omega = np.sqrt(sla.eigvalsh(body.K, body.inv.modal_mass).max())
    assert body.critical_time_step() == pytest.approx(2.0 / omega, rel=1e-12)
    x, theta = body.mesh(body.inv.origin, np.array([1.0, 0, 0, 0]), np.zeros(body.n_modes))
    np.testing.assert_allclose(x, beam.x, atol=1e-14)
    assert np.all(theta == 0.0)


def _free_coupler(spin: float):
    """The three-bar's coupler section on its own, 4 Beam2, free in space: turning at ``spin`` [rad/s] about z
    through its centre, its end node kicked across the beam in its plane at 0.5 m/s; the nodal velocities
    (n, 6) ``[ẋ, ω]`` (inertial) and the domain with them set (node-frame angular velocities)."""
    from reference.domain import Domain
    from reference.elements.section import Section

    section = Section(EA=1e5, GA2=1e5, GA3=1e5, GJ=1e3, EI2=1e3, EI3=1e3, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01,
                      rhoJ3=0.01)
    domain = Domain()
    nodes = domain.add_beam("coupler", [0.0, 1.0, 0.0], [4.0, 4.0, 0.0], 4, section, axis2=(0.0, 0.0, 1.0))
    x = np.array([n.position for n in nodes])
    V = np.zeros((len(nodes), 6))
    V[:, :3] = np.cross([0.0, 0.0, spin], x - x.mean(axis=0))
    V[:, 5] = spin
    V[-1, :3] += 0.5 * np.array([-0.6, 0.8, 0.0])
    for node, Vi, A in zip(nodes, V, rotation_matrices(np.array([n.rotation for n in nodes]))):
        node.velocity, node.angular_velocity = Vi[:3].copy(), A.T @ Vi[3:]
    solver = domain.solver
    solver.algorithm, solver.dt, solver.t_end, solver.output_every = "staggered_central_difference", 2e-4, 0.5, 50
    solver.backend = "reference"
    return domain, V


def _reduced_mesh(body, V, times):
    """The reduced body started from the velocities nearest ``V`` (:func:`nearest_velocities`), integrated with
    DOP853 (rtol 1e-9): its deformed mesh (t, n, 3) at ``times`` and its largest elastic displacement [m]."""
    r = body.n_modes
    y0 = np.concatenate([body.inv.origin, [1.0, 0.0, 0.0, 0.0], np.zeros(r), nearest_velocities(body, V)])
    sol = solve_ivp(_rates(body), (0.0, times[-1]), y0, method="DOP853", rtol=1e-9, atol=1e-11, t_eval=times)
    assert sol.success
    meshes = [body.mesh(y[:3], y[3:7] / np.linalg.norm(y[3:7]), y[7:7 + r])[0] for y in sol.y.T]
    return np.array(meshes), max(np.abs(body.Pt @ y[7:7 + r]).max() for y in sol.y.T)


def test_a_free_reduced_coupler_follows_the_full_beam_and_its_error_falls_with_the_mode_count():
    """The free coupler kicked at its end (:func:`_free_coupler`, no spin), 0.5 s: the full geometrically exact
    beam (Park's explicit step on the reference path) against the reduced body with 2, 4, 8 free-free modes,
    node positions compared, relative to the peak elastic displacement of the 8-mode body (~6 mm).
    Measured 17 %, 3.3 %, 0.54 %; with all 24 modes 0.55 %: what remains is the full run's own central-
    difference period error on the mesh's highest modes (ω dt up to 0.64 at dt = 2e-4) and the geometric
    nonlinearity the linear modes leave out.  Asserted: the error falls with each doubling, 8 modes within 1 %."""
    domain, V = _free_coupler(0.0)
    full = domain.solve()
    beam = beam_matrices(domain, "coupler")
    runs = []
    for n in (2, 4, 8):
        modes = free_free(beam, n)
        runs.append(_reduced_mesh(ReducedBody("coupler", beam, modes, invariants(beam, modes)), V, full.time))
    peak = runs[-1][1]
    errors = [np.abs(mesh - full.positions).max() / peak for mesh, _ in runs]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01


@pytest.mark.parametrize("spin", [2.0, 6.0])
def test_a_spinning_reduced_blade_softens_in_plane_and_does_not_stiffen_out_of_plane(spin):
    """rotating_cantilever's blade (32 Beam2, EI = ρA = L = 1, clamped on the spin axis), its frame attached at
    the hub with its 4 lowest clamped modes (two bending pairs, ω₀ = 3.5151 and 22.029 rad/s), spun about z
    (steady_spin): a linear-mode model knows only the centrifugal softening, so its lead-lag (in-plane)
    frequencies are ``√(ω₀² − Ω²)`` and its flapwise ones stay ``ω₀``.  At Ω = 6 > ω₀ the first lead-lag mode
    is unstable (a real root ``√(Ω² − ω₀²)``): the classic failure without geometric stiffening, where the
    geometrically exact beam's modes about the same rotation (the modes algorithm, about = "rotation") are
    4.26 and 7.36 rad/s (lag, flap).  The lumped modes move along z or y alone and the spin couples neither
    pair, so the formulas hold to round-off of the stiff beam's eigenvalues: 1e-7 relative."""
    from reference.modal import modes as pencil_modes

    domain = load_deck(MODELS / "rotating_cantilever.toml").domain
    beam = beam_matrices(domain, "blade")
    basis = clamped_modes(beam, 0, 4)
    body = ReducedBody("blade", beam, basis, invariants(beam, basis, origin=beam.x[0]))
    M, G, K = steady_spin(body, [0.0, 0.0, spin])
    assert np.abs(G).max() < 1e-12 * np.abs(K).max()  # ω along z couples no in-plane/out-of-plane pair
    found = pencil_modes(sps.csr_matrix(M), sps.csr_matrix(G), sps.csr_matrix(K), 4)
    still = 2 * np.pi * basis.frequencies[[0, 2]]
    # the Euler–Bernoulli roots 1.8751², 4.6941²: 32 lumped Beam2 are 2.6e-4 low (second order), 1e-3 bounds it
    np.testing.assert_allclose(still, [1.87510407 ** 2, 4.69409113 ** 2], rtol=1e-3)
    lag = np.sqrt(np.abs(still ** 2 - spin ** 2))  # |s| of the lead-lag roots: ±i√(ω₀² − Ω²) or ±√(Ω² − ω₀²)
    roots = np.concatenate([still, lag, lag[still < spin]])  # an unstable lag mode: two real roots ±√(Ω² − ω₀²)
    np.testing.assert_allclose(np.sort(np.abs(found.s)), np.sort(roots)[:4], rtol=1e-7)
    assert (np.sum(found.kind == "unstable") == 1) == (spin > still[0])
