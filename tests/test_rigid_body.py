"""Rigid bodies in the nodal formalism: torque-free motion (Euler's equations)."""

from __future__ import annotations

import numpy as np
import pytest

from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.rotation import EulerParameters

J = np.diag([1.0, 2.0, 3.0])


def spin(omega0, dt=1e-3, t_end=20.0):
    d = Domain("torque-free body")
    body = d.add_rigid_body("body", 1.0, np.diag(J), [0.0, 0.0, 0.0])
    body.angular_velocity = np.asarray(omega0, dtype=float)
    d.solver = SolverSettings(dt=dt, t_end=t_end, output_every=10)
    r = d.solve()
    return r.angular_velocity("body"), r.rotation("body")


def test_torque_free_body_conserves_energy_and_angular_momentum():
    """Asymmetric body spun near its intermediate axis, h = 1e-3, 20 s (20,000 steps):
    kinetic energy and inertial angular momentum A J ω conserved to ≤ 1e-6 relative.

    The midpoint gyroscopic term conserves both exactly at the half steps; what
    remains is the O(h²) error of the integer-step average used for output
    (measured 3.3e-7 and 4.5e-7, falling 25× at h = 2e-4)."""
    w, q = spin([0.01, 2.0, 0.01])
    T = 0.5 * np.einsum("ni,ij,nj->n", w, J, w)
    H = np.array([EulerParameters(qq).matrix() @ (J @ ww) for qq, ww in zip(q, w)])
    assert np.max(np.abs(T / T[0] - 1.0)) <= 1e-6
    assert np.max(np.linalg.norm(H - H[0], axis=1)) <= 1e-6 * np.linalg.norm(H[0])


def test_intermediate_axis_flips_and_major_axis_is_stable():
    """Spin about the intermediate axis is unstable: ω2 reverses (twice in 20 s for this
    perturbation); spin about the major axis with the same perturbation stays put."""
    w, _ = spin([0.01, 2.0, 0.01])
    assert np.sum(np.diff(np.sign(w[:, 1])) != 0) >= 2
    assert np.min(w[:, 1]) < -1.9  # a full flip, not a wobble
    w, _ = spin([0.01, 0.01, 2.0])
    assert np.all(w[:, 2] > 1.99)


def test_rigid_bar_has_the_mass_distribution_of_the_bar():
    """A rigid bar of length L: mass ρA L; inertia ρJ1 L about its axis and
    ρJ L + ρA L³/12 about the transverse axes through its centre."""
    sec = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=2.0, rhoJ1=0.04, rhoJ2=0.02, rhoJ3=0.03)
    d = Domain()
    bar = d.add_rigid_bar("bar", (0.0, 0.0, 0.0), (0.0, 3.0, 0.0), sec, axis2=(0.0, 0.0, 1.0))
    assert bar.mass == pytest.approx(6.0)
    assert np.allclose(bar.inertia, np.diag([0.12, 0.06 + 6.0 * 9 / 12, 0.09 + 6.0 * 9 / 12]))
    assert np.allclose(bar.position, [0.0, 1.5, 0.0])
    assert np.allclose(EulerParameters(bar.rotation).matrix()[:, 0], [0.0, 1.0, 0.0])  # axis 1 along the bar
