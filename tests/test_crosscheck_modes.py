"""Exudyn's eigen-solve on flexmbs models (crosscheck/exudyn_modes.py) against closed forms.

The sections are slender (EI/(GA L²) = r²/L² = 1e-6: shear and rotary inertia move the
frequencies by ~1e-6 of (βL)², below every tolerance here) so that the Euler–Bernoulli
closed forms hold; EI3 = 4 EI2 puts the two bending planes an octave apart.

Mesh error of Exudyn's element (linear shape functions, consistent mass, one strain per
element): a bending wave of wavenumber k on elements of length h runs at
``ω_h/ω = 1 + (kh)²/24`` from the stiffness and ``+ (kh)²/12`` from the consistent mass,
so in the interior the frequency is high by ``(kh)²/8`` (von Neumann analysis of the
assembled equations); the cantilever's ends lower that coefficient (measured 0.034, 0.11
for the first two modes at 8 to 32 elements).  Hence the bounds ``0 < e ≤ (βh)²/8`` and an
observed order of 2 ± 0.1 between two meshes.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from crosscheck.exudyn_model import Unsupported
from crosscheck.exudyn_modes import exudyn_modes_timing, lumped, modes
from flexmbs.verification.analytic import double_pendulum_frequencies
from reference.algorithms.base import SolverSettings
from reference.domain import Domain
from reference.elements import Section
from reference.forces import Bushing
from reference.interactions import Gravity, NodalLoad

from conftest import cantilever

SLENDER = Section(EA=1e6, GA2=1e6, GA3=1e6, GJ=1.0, EI2=1.0, EI3=4.0, rhoA=1.0, rhoJ1=2e-6, rhoJ2=1e-6, rhoJ3=1e-6)
BAR = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01, rhoJ3=0.01)


def beta_L(k: int, axial_load: float = 0.0) -> float:
    """βL of the k-th bending mode of a clamped-free Euler–Bernoulli beam (EI = ρA = L = 1) under a dead
    compressive end load P: the root of the 4×4 determinant of ``w'''' + P w'' = ω² w`` with
    w(0) = w'(0) = 0, w''(1) = 0, w'''(1) + P w'(1) = 0 (P = 0: ``cos βL cosh βL = −1``); ω = (βL)²."""

    def det(omega):
        r = np.hypot(axial_load, 2.0 * omega)
        a, b = np.sqrt(0.5 * (r - axial_load)), np.sqrt(0.5 * (r + axial_load))
        ca, sa, cb, sb = np.cosh(a), np.sinh(a), np.cos(b), np.sin(b)
        return np.linalg.det(np.array([
            [1.0, 0.0, 1.0, 0.0], [0.0, a, 0.0, b],
            [a * a * ca, a * a * sa, -b * b * cb, -b * b * sb],
            [a**3 * sa + axial_load * a * sa, a**3 * ca + axial_load * a * ca,
             b**3 * sb - axial_load * b * sb, -b**3 * cb + axial_load * b * cb]]))

    grid = np.linspace(0.05, 40.0, 4001)
    values = [det(w) for w in grid]
    roots = [brentq(det, grid[i], grid[i + 1], xtol=1e-14) for i in range(len(grid) - 1)
             if np.sign(values[i]) != np.sign(values[i + 1])]
    return float(np.sqrt(roots[k - 1]))


def z_plane(result, count: int) -> np.ndarray:
    """Indices of the first ``count`` modes bending in the x–z plane (displacement along z only: the other
    components ≤ 1e-6 of it; measured ≤ 1.3e-7 with the numerically differentiated Jacobian, ~1e7 for the
    modes of the other plane)."""
    u = result.shape[:, :, :3]
    planar = np.max(np.abs(u[:, :, [0, 1]]), axis=(1, 2)) <= 1e-6 * np.max(np.abs(u[:, :, 2]), axis=1)
    return np.flatnonzero(planar)[:count]


def test_euler_bernoulli_closed_form():
    # the determinant reproduces the textbook roots (Blevins 1979, table 8-1) to their digits
    assert beta_L(1) == pytest.approx(1.8751, abs=1e-4) and beta_L(2) == pytest.approx(4.6941, abs=1e-4)


def test_cantilever_bending_frequencies_converge_to_euler_bernoulli():
    f_exact = np.array([beta_L(1), beta_L(2)]) ** 2 / (2.0 * np.pi)
    errors = {}
    for n in (16, 32):
        d, _ = cantilever(n, SLENDER)
        r = modes(d, 6, sparse=True)
        z = z_plane(r, 2)
        assert list(z) == [0, 2]  # z-plane (EI2 = 1) modes first and third; the y-plane's twice as high
        e = r.frequency[z] / f_exact - 1.0
        # from above, within the interior dispersion bound of the consistent-mass element (module docstring)
        assert np.all(e > 0.0) and np.all(e <= (np.array([beta_L(1), beta_L(2)]) / n) ** 2 / 8.0), e
        # the y-plane frequencies are twice the z-plane's (EI3 = 4 EI2, the same mesh error) but for the shear
        # compliance, 4× larger in that plane: a Timoshenko shift of about ½(βL)²(EI/GA L² + r²/L²), 5e-5 more
        # for mode 2 (measured 4.9e-5)
        assert r.frequency[[1, 3]] == pytest.approx(2.0 * r.frequency[z], rel=1e-4)
        errors[n] = e
    order = np.log2(errors[16] / errors[32])
    assert np.all(np.abs(order - 2.0) <= 0.1), order  # second order in h
    richardson = (4.0 * (errors[32] + 1.0) - (errors[16] + 1.0)) / 3.0 - 1.0
    # extrapolated to h → 0: the O(h⁴) remainder (16× smaller than the 8/16 pair's 2.3e-4) and the 1e-6
    # shear/rotary-inertia shift
    assert np.all(np.abs(richardson) <= 1e-4), richardson


def test_dense_and_sparse_variants_give_the_same_modes_and_shapes():
    d, nodes = cantilever(16, SLENDER)
    dense, sparse = modes(d, 6), modes(d, 6, sparse=True)
    # the same element and mass in two node parametrisations (Euler parameters + SVD null space; rotation
    # vectors + removed coordinates): agreement to the sparse Lanczos solve's accuracy (measured 4e-7)
    assert sparse.frequency == pytest.approx(dense.frequency, rel=2e-6)
    for a, b in zip(dense.shape, sparse.shape):
        b = b * np.sign(np.sum(a * b))
        assert np.max(np.abs(a - b)) <= 2e-5 * np.max(np.abs(a))
    # the rotation mapping: bending in x–z about the section axis 2 (= y) only, and the element's shear
    # strain vanishes ((w₂ − w₁)/h = −(θ₁ + θ₂)/2 for a rotation about +y) to GA's compliance 1e-6
    phi = dense.shape[0]
    h = 1.0 / 16
    w, theta = phi[:, 2], phi[:, 4]
    assert np.max(np.abs(phi[:, [0, 1, 3, 5]])) <= 1e-7 * np.max(np.abs(phi))  # SVD null-space round-off: 1.6e-8
    assert np.max(np.abs(np.diff(w) / h + 0.5 * (theta[1:] + theta[:-1]))) <= 1e-5 * np.max(np.abs(theta))
    assert np.all(phi[0] == 0.0) or np.max(np.abs(phi[0])) <= 1e-12  # the clamped node stays


def test_lumped_mass_is_flexmbs_mass_and_lowers_the_frequencies():
    d, _ = cantilever(8, SLENDER)
    consistent, lumped_run = modes(d, 4, sparse=True), modes(d, 4, sparse=True, lumped_mass=True)
    model = d.model
    # the block-lumped consistent mass is flexmbs' lumped one: ρA L/2 and (L/2) ρJ per node
    M = np.zeros((12, 12))
    M[:6, :6] = M[6:, 6:] = np.diag([1.0, 1.0, 1.0, 2.0, 2.0, 2.0]) / 3.0
    M[:6, 6:] = M[6:, :6] = np.diag([1.0, 1.0, 1.0, 2.0, 2.0, 2.0]) / 6.0
    L = lumped(M)
    assert np.allclose(np.diag(L), [0.5, 0.5, 0.5, 1.0, 1.0, 1.0] * 2, rtol=0, atol=1e-15)
    assert model.nodes.mass[1] == pytest.approx(1.0 / 8, rel=1e-14)  # interior node of 1/8 m elements, ρA = 1
    # the same stiffness with a lumped mass: every frequency lower (M_lumped − M_consistent = ρAL/6 [[1, −1],
    # [−1, 1]] per element is positive semi-definite: Courant's minimax); measured 0.60 % and 4.3 % for modes 1, 2
    assert np.all(consistent.frequency > lumped_run.frequency)
    # mass-normalised with the lumped mass (flexmbs' m, J): φᵀ M φ = 1
    phi = lumped_run.shape[0]
    mass = np.sum(model.nodes.mass[:, None] * phi[:, :3] ** 2) + np.einsum("ni,nij,nj->", phi[:, 3:],
                                                                            model.nodes.inertia, phi[:, 3:])
    assert mass == pytest.approx(1.0, rel=1e-10)


def test_prestressed_column_about_its_static_equilibrium():
    # a dead compressive end load of half the buckling load π²EI/4L²: the first frequency drops 28 %; Exudyn's
    # static solution and its (numerically differentiated) Jacobian against the beam-column closed form
    P = 0.5 * np.pi**2 / 4.0
    exact = np.array([beta_L(1, P), beta_L(2, P)]) ** 2 / (2.0 * np.pi)
    assert exact[0] / (beta_L(1) ** 2 / (2.0 * np.pi)) == pytest.approx(0.7208, abs=1e-4)  # the load matters
    errors = {}
    for n in (8, 16):
        d, nodes = cantilever(n, SLENDER)
        d.add_interaction(NodalLoad(nodes[-1], np.array([-P, 0.0, 0.0])))
        d.solver = SolverSettings(algorithm="static", t_end=1.0, dt=0.5, load_steps=2)
        r = modes(d, 4, about="static")
        e = r.frequency[z_plane(r, 2)] / exact - 1.0
        assert np.all(e > 0.0) and np.all(e <= (np.array([beta_L(1), beta_L(2)]) / n) ** 2 / 8.0), e
        errors[n] = e
    order = np.log2(errors[8] / errors[16])
    assert np.all(np.abs(order - 2.0) <= 0.1), order  # measured 1.99, 2.03


def hanging_double_pendulum(gravity: bool = True) -> Domain:
    """Two uniform bars of 1 m hanging along −z, revolute joints about y at the origin and at the elbow."""
    d = Domain("double pendulum")
    upper = d.add_rigid_bar("upper", (0.0, 0.0, 0.0), (0.0, 0.0, -1.0), BAR)
    lower = d.add_rigid_bar("lower", (0.0, 0.0, -1.0), (0.0, 0.0, -2.0), BAR)
    d.add_joint("revolute", upper, None, (0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), label="O")
    d.add_joint("revolute", lower, upper, (0.0, 0.0, -1.0), axis=(0.0, 1.0, 0.0), label="elbow")
    if gravity:
        d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    return d


def test_double_pendulum_modes_about_the_hanging_equilibrium():
    d = hanging_double_pendulum()
    J = d.node("upper").inertia[1, 1]
    omega, shape = double_pendulum_frequencies(1.0, 0.5, J, 1.0, 1.0, 0.5, J, 9.81)
    plain = modes(d, 4)
    # 2 bodies × 6 − 2 revolute joints × 5 = 2 independent coordinates: two modes, the mobility
    assert len(plain.frequency) == 2
    # Exudyn's Jacobian has no λ·∂(C_qᵀ)/∂q: the pendulum's stiffness (its joints' reactions) is missing
    assert np.all(plain.frequency <= 1e-6)
    fixed = modes(d, 4, joint_reactions=True)
    # with it: the linearised Lagrange equations; the second differences of Exudyn's joint equations carry ~1e-8
    assert fixed.frequency == pytest.approx(omega / (2.0 * np.pi), rel=1e-7)
    for k in range(2):  # the bars turn about y (body axis 2 of both) in the closed form's ratio, mass-normalised
        theta = fixed.shape[k][:, 4] * np.sign(fixed.shape[k][0, 4] * shape[0, k])
        assert theta == pytest.approx(shape[:, k], rel=1e-6)
    # without gravity the two modes are mechanism (zero) modes
    free = modes(hanging_double_pendulum(gravity=False), 4, joint_reactions=True)
    assert len(free.frequency) == 2 and np.all(free.frequency <= 1e-6)


def test_damped_modes_of_a_body_on_a_bushing():
    d = Domain("body on a bushing")
    body = d.add_rigid_body("body", 2.0, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    k = np.array([100.0, 200.0, 300.0, 40.0, 50.0, 60.0])
    c = np.array([2.0, 1.0, 3.0, 0.4, 0.2, 0.6])
    d.add_force_element(Bushing(body, None, point=np.zeros(3), axis=(0.0, 0.0, 1.0), reference=(1.0, 0.0, 0.0),
                                stiffness=k, damping=c))
    inertia = np.array([2.0, 2.0, 2.0, 1.0, 2.0, 3.0])
    omega = np.sqrt(k / inertia)
    zeta = c / (2.0 * np.sqrt(k * inertia))
    order = np.argsort(omega)
    r = modes(d, 6, damped=True)
    # six uncoupled damped oscillators: |λ| = ω and −Re λ/|λ| = ζ exactly (linear bushing, dense solve)
    assert r.frequency == pytest.approx(omega[order] / (2.0 * np.pi), rel=1e-9)
    assert r.damping_ratio == pytest.approx(zeta[order], rel=1e-8)
    assert r.shape is None


def test_refusals_are_one_line():
    d = hanging_double_pendulum()
    with pytest.raises(Unsupported, match="joint 'O'.*sparse=False"):
        modes(d, 2, sparse=True)
    with pytest.raises(Unsupported, match="use sparse=True"):
        modes(d, 2, lumped_mass=True)
    with pytest.raises(Unsupported, match="use damped=False"):
        modes(d, 2, damped=True, joint_reactions=True)
    with pytest.raises(ValueError, match="about = 'deformed'"):
        modes(d, 2, about="deformed")


def test_timing_function_on_a_small_cantilever():
    f, seconds = exudyn_modes_timing(40, 4)
    # the timing cantilever's section (EI = ρA = 1, EI/(GA L²) = 1e-4): the first frequency within the mesh and
    # shear/rotary-inertia shifts (about 4e-4 together at 40 elements) of Euler–Bernoulli
    assert f[0] == pytest.approx(1.8751**2 / (2.0 * np.pi), rel=1e-3) and f[1] == pytest.approx(f[0], rel=1e-9)
    assert 0.0 < seconds < 5.0
