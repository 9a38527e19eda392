"""Constrained rigid bodies under gravity: spherical pendulum and double pendulum over 100
periods (energy and constraint drift), redundant constraints reported, drives."""

from __future__ import annotations

import numpy as np
import pytest

from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.interactions import Gravity
from reference.joints import Jacobian
from reference.rotation import RotationVector

G = 9.81
BAR = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=1e-3, rhoJ2=1e-3, rhoJ3=1e-3)


def physical_energy(r, domain):
    z = np.array([[n.mass for n in domain.nodes]]) * r.positions[:, :, 2]
    return r.energy["kinetic"] + G * z.sum(axis=1)


def test_spherical_pendulum_energy_and_drift_over_100_periods():
    """A rigid bar on a spherical joint, tilted 60° and spinning about the vertical (a conical,
    precessing motion), h = 1e-3, 200 s ≈ 100 periods: energy error ≤ 1e-3 of the initial
    energy and ‖Φ‖ bounded (≤ 5e-5, no growth between the first and last tenth).  Measured:
    4e-5 energy (second order: 3.9e-7 at h = 1e-4) and ‖Φ‖ ≈ 7.7e-6 = h²v²/(2l), the
    stabilised scheme's one-step linearisation error."""
    d = Domain("spherical pendulum")
    th = np.radians(60.0)
    com = 0.5 * np.array([np.sin(th), 0.0, -np.cos(th)])
    R = RotationVector([0.0, np.pi / 2 - th, 0.0])  # body axis 1 along the bar, pointing away from the pivot
    assert np.allclose(R.matrix()[:, 0], com / np.linalg.norm(com))
    bar = d.add_rigid_body("bar", 1.0, [1e-3, 1 / 12, 1 / 12], com, rotation=R.to_euler_parameters().q)
    d.add_joint("spherical", bar, None, [0.0, 0.0, 0.0])
    d.add_interaction(Gravity(np.array([0.0, 0.0, -G])))
    bar.velocity = np.cross([0.0, 0.0, 2.0], com)
    bar.angular_velocity = R.matrix().T @ np.array([0.0, 0.0, 2.0])
    d.solver = SolverSettings(dt=1e-3, t_end=200.0, output_every=100)
    r = d.solve()
    E = physical_energy(r, d)
    assert np.max(np.abs(E - E[0])) <= 1e-3 * abs(E[0])
    phi = r.constraint_violation
    assert phi.max() <= 5e-5
    tenth = len(phi) // 10
    assert phi[-tenth:].max() <= 1.5 * phi[:tenth].max()
    assert r.velocity_constraint_violation.max() <= 1e-4


def test_double_pendulum_energy_and_drift_over_100_periods():
    """Two rigid bars joined by revolute joints (axis y, gravity −z), released horizontal:
    a chaotic motion with tip speeds up to ~8 m/s; h = 5e-4, 150 s (~100 small-oscillation
    periods): energy error ≤ 1e-3 of the potential-energy range 2 m g L (the initial energy is
    0) and ‖Φ‖ ≤ 5e-5 throughout.  The energy error is second order (measured over 20 s:
    5.8e-3, 9.7e-4, 2.4e-4 at h = 1e-3, 5e-4, 2.5e-4)."""
    d = Domain("double pendulum")
    b1 = d.add_rigid_bar("bar1", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), BAR)
    b2 = d.add_rigid_bar("bar2", (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), BAR)
    d.add_joint("revolute", b1, None, [0.0, 0.0, 0.0], axis=[0.0, 1.0, 0.0])
    d.add_joint("revolute", b2, b1, [1.0, 0.0, 0.0], axis=[0.0, 1.0, 0.0])
    d.add_interaction(Gravity(np.array([0.0, 0.0, -G])))
    d.solver = SolverSettings(dt=5e-4, t_end=150.0, output_every=200)
    r = d.solve()
    E = physical_energy(r, d)
    assert np.max(np.abs(E - E[0])) <= 1e-3 * (2.0 * G * 1.0)
    assert r.constraint_violation.max() <= 5e-5
    assert np.all(r.positions[:, :, 1] == 0.0)  # planar: no out-of-plane motion at all
    assert r.position("bar2")[:, 2].min() < -1.0  # it really swung


def four_bar(epsilon=0.0):
    """A planar four-bar of rigid bars closed by four revolute joints: redundant in 3D."""
    d = Domain("rigid four-bar")
    crank = d.add_rigid_bar("crank", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), BAR, axis2=(1.0, 0.0, 0.0))
    coupler = d.add_rigid_bar("coupler", (0.0, 1.0, 0.0), (4.0, 4.0, 0.0), BAR)
    rocker = d.add_rigid_bar("rocker", (4.0, 4.0, 0.0), (4.0, 0.0, 0.0), BAR, axis2=(1.0, 0.0, 0.0))
    f = Jacobian(epsilon)
    d.add_joint("revolute", crank, None, [0.0, 0.0, 0.0], label="O1")
    d.add_joint("revolute", coupler, crank, [0.0, 1.0, 0.0], label="A")
    d.add_joint("revolute", rocker, coupler, [4.0, 4.0, 0.0], label="B", formulation=f)
    d.add_joint("revolute", rocker, None, [4.0, 0.0, 0.0], label="O3", formulation=f)
    d.add_interaction(Gravity(np.array([0.0, -G, 0.0])))
    d.solver = SolverSettings(dt=1e-3, t_end=1.0, output_every=100)
    return d


def test_redundant_constraints_are_reported_naming_the_joints():
    """Four revolute joints close a planar linkage of rigid bodies in 3D: 20 equations for 18
    coordinates, two of them dependent.  With ε = 0 the Domain refuses it, naming joints."""
    with pytest.raises(ValueError, match="redundant constraints") as info:
        four_bar(0.0).solve()
    assert "O3" in str(info.value) and "epsilon > 0" in str(info.value)


def test_redundant_constraints_can_be_regularised():
    """With ε > 0 on the closing joints the same linkage runs; its rocker follows gravity and
    ‖Φ‖ stays small (ε = 1e-9: the regularised rows give way by ~ε λ)."""
    r = four_bar(1e-9).solve()
    assert np.all(np.isfinite(r.positions))
    assert r.constraint_violation.max() < 1e-4


def test_the_redundancy_check_remembers_what_passed_and_nothing_else(monkeypatch):
    """``Domain.solve`` rebuilds and checks the model at every call: a model and configuration that passed are
    not checked again (reference.joints.setup.REDUNDANCY_CHECKED), a changed one is, and a refused one is refused
    at every call, also after its regularised twin passed (ε is part of what is remembered)."""
    from reference.joints import setup

    checked = []
    inner = setup._check_redundancy
    monkeypatch.setattr(setup, "_check_redundancy", lambda *args: checked.append(1) or inner(*args))
    monkeypatch.setattr(setup, "REDUNDANCY_CHECKED", {})
    d = four_bar(1e-9)
    d.initialization()
    d.initialization()
    assert len(checked) == 1
    d.nodes[0].position = np.asarray(d.nodes[0].position) + 1e-3
    d.initialization()
    assert len(checked) == 2
    for _ in range(2):
        with pytest.raises(ValueError, match="redundant constraints"):
            four_bar(0.0).initialization()
    assert len(checked) == 4
