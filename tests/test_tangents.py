"""Every generated tangent against central differences of the force or constraint it differentiates.

The perturbation is the one the integrators use: ``x → x + ε δx``, ``q → q ⊗ exp(ε δθ)``
(body-frame increment).  Central differences with ε = 1e-5 have truncation error
~ε²|f'''| ≈ 1e-10 and round-off ~1e-16|f|/ε ≈ 1e-11 relative to the entries (O(1)–O(10) here);
the bound 1e-7 relative to the largest entry (tighter than the 1e-6 of the issue) leaves a
margin of ~100 and still catches a single wrong term (a missing geometric term is O(1)).
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from reference.elements import Beam2Formulation
from reference.generated import beam2, tangents
from reference.generated import rotation_maps as rm

from test_beam2 import SECTION, qexp, qmul

EPS = 1e-5
RTOL = 1e-7


def perturbed(x, q, k, eps):
    """Copies of ``x`` (n,3), ``q`` (n,4) with perturbation variable k (6 per node: δx then δθ) set to eps."""
    x, q = x.copy(), q.copy()
    node, comp = k // 6, k % 3
    d = np.zeros(3)
    d[comp] = eps
    if k % 6 < 3:
        x[node] += d
    else:
        q[node] = qmul(q[node], qexp(d))
    return x, q


def central_difference(func, x, q, n_vars):
    """Columns ``(func(+ε e_k) − func(−ε e_k)) / 2ε`` of the perturbation variables."""
    cols = [(func(*perturbed(x, q, k, EPS)) - func(*perturbed(x, q, k, -EPS))) / (2 * EPS) for k in range(n_vars)]
    return np.column_stack(cols)


def relative_error(K, fd):
    return np.max(np.abs(K - fd)) / np.max(np.abs(fd))


def skew_part_error(K, force):
    """``K − Kᵀ − blockdiag(0, f̃_θ1, 0, f̃_θ2)`` relative to |K|.

    A gradient ``f_a = dU[A ẽ_a]`` on the rotation group has the tangent
    ``K_ab = d²U[A ẽ_a, A ẽ_b] + dU[A ẽ_b ẽ_a]``: the first term is symmetric, and
    ``ẽ_b ẽ_a − ẽ_a ẽ_b = (e_b × e_a)~`` leaves ``(K − Kᵀ)_ab = f·(e_b × e_a) = (f̃)_ab`` on
    each body's rotation block, exactly.
    """
    from reference.rotation import skew

    expected = np.zeros((12, 12))
    expected[3:6, 3:6] = skew(force[3:6])
    expected[9:12, 9:12] = skew(force[9:12])
    return np.max(np.abs(K - K.T - expected)) / np.max(np.abs(K))


def beam_configuration(rng, bend, reference_twist):
    """A curved/twisted reference element and a large rotation + strain of it."""
    f = Beam2Formulation(SECTION)
    x_ref = np.array([[0.0, 0.0, 0.0], [1.2, 0.1, -0.1]])
    q0 = qexp(rng.normal(size=3))
    q_ref = np.array([q0, qmul(q0, qexp(reference_twist * rng.normal(size=3)))])
    ref = f.reference_state(x_ref, q_ref)
    q1 = qexp(rng.normal(size=3) * 2.0)
    q2 = qmul(q1, qexp(bend * rng.normal(size=3)))
    x1 = rng.normal(size=3)
    x2 = x1 + rng.normal(size=3) * 0.3 + np.array([1.0, 0.2, 0.0])
    return ref, np.array([x1, x2]), np.array([q1, q2])


def beam_forces(ref):
    def S(x, q):
        s = np.empty(12)
        beam2.internal_forces(x[0], x[1], q[0], q[1], ref["L0"], ref["psi0"], ref["gamma0"], SECTION.stiffness,
                              s, np.empty(6), np.empty(6))
        return s
    return S


def beam_tangent(ref, x, q):
    s, K = np.empty(12), np.empty(144)
    tangents.beam2_tangent(x[0], x[1], q[0], q[1], ref["L0"], ref["psi0"], ref["gamma0"], SECTION.stiffness, s, K)
    return s, K.reshape(12, 12)


@pytest.mark.parametrize("bend, twist", [(0.8, 0.0), (2.0, 0.5), (0.3, 1.2), (1e-3, 0.0)])
@pytest.mark.parametrize("seed", range(3))
def test_beam2_tangent_is_the_derivative_of_the_internal_forces(seed, bend, twist):
    """K = ∂S/∂[δx1, δθ1, δx2, δθ2] in large rotations, strained states, curved references;
    relative rotations from 1e-3 rad (series branches of the coefficients) to ~3 rad.  Its
    skew part is exactly that of a gradient on the rotation group (:func:`skew_part_error`)."""
    rng = np.random.default_rng(seed)
    ref, x, q = beam_configuration(rng, bend, twist)
    S = beam_forces(ref)
    s, K = beam_tangent(ref, x, q)
    # the same force as the force kernel, to round-off (the two generated kernels share their
    # subexpressions differently, so the last bits may differ)
    assert np.max(np.abs(s - S(x, q))) <= 1e-14 * np.max(np.abs(s))
    fd = central_difference(S, x, q, 12)
    assert relative_error(K, fd) <= RTOL
    assert skew_part_error(K, s) <= 1e-13  # round-off of |K| ~ 10


def test_beam2_tangent_at_zero_relative_rotation():
    """Identical nodal triads (ψ = 0 exactly: every coefficient at a = 0, |ψ| = √0) with a
    stretched and sheared axis: K finite and equal to the central differences."""
    f = Beam2Formulation(SECTION)
    q = np.array([qexp([0.3, -1.2, 0.8])] * 2)
    ref = f.reference_state(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), q)
    x = np.array([[0.0, 0.0, 0.0], [1.1, 0.2, -0.1]])
    s, K = beam_tangent(ref, x, q)
    assert np.all(np.isfinite(K))
    assert relative_error(K, central_difference(beam_forces(ref), x, q, 12)) <= RTOL


def test_beam2_tangent_is_symmetric_at_rest_and_singular_for_rigid_motion():
    """In the unstrained configuration S = 0, so K is the (symmetric) material stiffness and
    annihilates the six rigid-body modes (translations; rotations δx_a = δφ × (x_a − x1),
    δθ_a = A_aᵀ δφ).  Round-off bound 1e-12 of |K|."""
    rng = np.random.default_rng(7)
    f = Beam2Formulation(SECTION)
    x = np.array([[0.3, -0.1, 0.2], [1.1, 0.5, -0.4]])
    q = np.array([qexp(rng.normal(size=3) * 2), qexp(rng.normal(size=3) * 2)])
    ref = f.reference_state(x, q)
    s, K = beam_tangent(ref, x, q)
    assert np.max(np.abs(s)) < 1e-12
    scale = np.max(np.abs(K))
    assert np.max(np.abs(K - K.T)) < 1e-12 * scale
    modes = []
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        modes.append(np.concatenate([e, np.zeros(3), e, np.zeros(3)]))
        A = [np.empty(9), np.empty(9)]
        rm.rotation_matrix(q[0], A[0])
        rm.rotation_matrix(q[1], A[1])
        modes.append(np.concatenate([np.zeros(3), A[0].reshape(3, 3).T @ e,
                                     np.cross(e, x[1] - x[0]), A[1].reshape(3, 3).T @ e]))
    assert np.max(np.abs(K @ np.array(modes).T)) < 1e-12 * scale


def joint_setup(kind, rng, ground):
    """A joint of ``kind`` between two rigid bodies (or body and ground), randomly moved away
    from its assembly configuration (so Φ ≠ 0 and every term of the Hessian is exercised)."""
    from reference.domain import Domain
    from reference.interactions import Sine
    from reference.joints import Joint, joint_frame

    d = Domain()
    bi = d.add_rigid_body("i", 1.0, [1.0, 2.0, 3.0], rng.normal(size=3), rotation=qexp(rng.normal(size=3) * 1.5))
    bj = None if ground else d.add_rigid_body("j", 2.0, [2.0, 1.0, 1.0], rng.normal(size=3),
                                              rotation=qexp(rng.normal(size=3) * 1.5))
    joint = Joint(kind, bi, bj, rng.normal(size=3), joint_frame(rng.normal(size=3), rng.normal(size=3)),
                  time_function=Sine(0.7, 2.0, 0.3, 0.1),
                  mode="velocity" if kind.endswith("drive") and rng.random() < 0.5 else "position")
    x = np.array([n.position for n in d.nodes]) + rng.normal(size=(len(d.nodes), 3)) * 0.3
    q = np.array([qmul(n.rotation, qexp(rng.normal(size=3) * 0.8)) for n in d.nodes])
    return joint, x, q


def joint_hessian(joint, x, q, t, lam):
    from reference.joints.hessian import joint_rows_hessian

    m = joint.n_equations
    j = -1 if joint.body_j is None else joint.body_j.id
    tf = joint.time_function
    phi, B, phit, H = np.zeros(m), np.zeros((m, 12)), np.zeros(m), np.zeros((12, 12))
    joint_rows_hessian(x, q, joint.body_i.id, j, joint.body_fixed(), joint.rows, joint.drive_code, tf.kind,
                       tf.parameters(), float(t), lam, phi, B, phit, H, np.zeros(10), np.zeros(120), np.zeros(10))
    return phi, B, phit, H


@pytest.mark.parametrize("ground", [False, True])
@pytest.mark.parametrize("kind", ["spherical", "revolute", "universal", "cylindrical", "translational", "fixed",
                                  "rotation_drive", "displacement_drive", "prescribed_displacement"])
def test_joint_hessian_is_the_derivative_of_the_joint_forces(kind, ground):
    """``H = ∂(Bᵀλ)/∂[δx_i, δθ_i, δx_j, δθ_j]`` against central differences of Bᵀλ, B from the
    assembly's ``joint_rows`` (drives included, at a fixed t), 5 random configurations and
    multipliers each; Φ, B, Φ_t returned alongside equal ``joint_rows``' exactly; the skew part
    of H is that of the gradient Bᵀλ (:func:`skew_part_error`)."""
    rng = np.random.default_rng(zlib.crc32(f"{kind}{ground}".encode()))
    if kind == "prescribed_displacement" and not ground:  # its direction is inertial: body_j is the ground
        with pytest.raises(ValueError, match="fixed on the ground"):
            joint_setup(kind, rng, ground)
        return
    for _ in range(5):
        joint, x, q = joint_setup(kind, rng, ground)
        t = rng.uniform(0.0, 3.0)
        lam = rng.normal(size=joint.n_equations)
        phi, B, phit, H = joint_hessian(joint, x, q, t, lam)
        ref = joint.evaluate(x, q, t)
        assert np.array_equal(phi, ref[0]) and np.array_equal(B, ref[1]) and np.array_equal(phit, ref[2])
        n_vars = 6 if ground else 12
        fd = central_difference(lambda xx, qq: joint.evaluate(xx, qq, t)[1].T @ lam, x, q, n_vars)
        assert relative_error(H[:, :n_vars], fd) <= RTOL, kind
        assert skew_part_error(H, B.T @ lam) <= 1e-13, kind  # Bᵀλ is the gradient of λ·Φ
        if ground:
            assert np.all(H[6:, :] == 0.0) and np.all(H[:, 6:] == 0.0)


@pytest.mark.parametrize("seed", range(4))
def test_load_tangents_are_the_derivatives_of_the_external_forces(seed):
    """The engine's external forces (``reference.evaluation.forces.external_forces``) of a follower force and a dead
    moment on a rigid body, differentiated along q → q ⊗ exp(ε δθ) by central differences:
    ``∂F_u/∂δθ = f(t) follower_force_tangent``, ``∂F_θ/∂δθ = f(t) dead_moment_tangent``;
    dead forces, follower moments and gravity do not depend on the configuration."""
    from reference.evaluation.forces import external_forces
    from reference.domain import Domain
    from reference.interactions import Gravity, NodalLoad, Sine

    rng = np.random.default_rng(seed)
    d = Domain()
    body = d.add_rigid_body("b", 2.0, [1.0, 2.0, 3.0], rng.normal(size=3), rotation=qexp(rng.normal(size=3) * 2.0))
    tf = Sine(0.5, 1.3, 0.2, 0.4)
    b, m = rng.normal(size=3) * 3.0, rng.normal(size=3) * 2.0
    d.add_interaction(NodalLoad(body, b, follower=True, time_function=tf))
    d.add_interaction(NodalLoad(body, m, moment=True, time_function=tf))
    d.add_interaction(NodalLoad(body, rng.normal(size=3), time_function=tf))
    d.add_interaction(NodalLoad(body, rng.normal(size=3), moment=True, follower=True, time_function=tf))
    d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    model = d.model
    t = rng.uniform(0.0, 2.0)
    x, q = np.array([body.position]), np.array([body.rotation])

    def F(xx, qq):
        out = np.zeros((1, 6))
        external_forces(model, xx, qq, t, out, np.zeros(9))
        return out[0]

    fd = central_difference(F, x, q, 6)
    K = np.zeros((6, 6))
    Kf, Km = np.empty(9), np.empty(9)
    tangents.follower_force_tangent(q[0], b, Kf)
    tangents.dead_moment_tangent(q[0], m, Km)
    K[:3, 3:] = tf(t) * Kf.reshape(3, 3)
    K[3:, 3:] = tf(t) * Km.reshape(3, 3)
    assert relative_error(K, fd) <= RTOL


@pytest.mark.parametrize("seed", range(4))
def test_gyroscopic_tangent_is_the_derivative_of_the_gyroscopic_moment(seed):
    """∂(ω × Jω)/∂ω for a full (non-diagonal) inertia tensor, central differences in ω
    (quadratic in ω: the differences are exact up to round-off)."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(3, 3))
    J = G @ G.T + np.eye(3)
    w = rng.normal(size=3) * 5.0
    K = np.empty(9)
    tangents.gyroscopic_tangent(J.reshape(9), w, K)
    fd = np.column_stack([(np.cross(w + EPS * e, J @ (w + EPS * e)) - np.cross(w - EPS * e, J @ (w - EPS * e)))
                          / (2 * EPS) for e in np.eye(3)])
    assert relative_error(K.reshape(3, 3), fd) <= RTOL


def test_derived_coefficients_match_40_digit_references():
    """``c_d(a) = c'(a)/a`` of c_cosc, c_sinc3, c_jinv against mpmath (40 digits) on 0 ≤ a ≤ π
    (the range the beam uses: |ψ| ≤ π) including both sides of the series switch at a = 2.
    Bound 1e-14 relative: above a = 2 the closed form of c_jinv_d still cancels by a factor
    of ~10–60 (measured 5.5e-15); the others stay below 1.1e-15."""
    import mpmath as mp

    mp.mp.dps = 40
    exact = {
        "c_cosc_d": lambda a: (a * mp.sin(a) + 2 * mp.cos(a) - 2) / a**4,
        "c_sinc3_d": lambda a: (3 * mp.sin(a) - a * mp.cos(a) - 2 * a) / a**5,
        "c_jinv_d": lambda a: (a**2 + a * mp.sin(a) + 4 * mp.cos(a) - 4) / (2 * a**4 * (1 - mp.cos(a))),
    }
    limits = {"c_cosc_d": -1 / 12, "c_sinc3_d": -1 / 60, "c_jinv_d": 1 / 360}
    grid = np.concatenate([np.linspace(1e-3, np.pi, 400), [2.0 - 1e-12, 2.0, 2.0 + 1e-12]])
    for name, f in exact.items():
        func = getattr(tangents, name)
        assert func(0.0) == pytest.approx(limits[name], rel=1e-15)
        err = max(abs(float((func(a) - f(mp.mpf(a))) / f(mp.mpf(a)))) for a in grid)
        assert err < 1e-14, name


def test_compiled_kernels_agree_with_plain_python():
    """The numba-compiled tangents equal their plain-Python source (``py_func``, what
    NUMBA_DISABLE_JIT=1 runs) to 1e-13 of |K| (compiled code may reorder operations)."""
    rng = np.random.default_rng(11)
    ref, x, q = beam_configuration(rng, 1.5, 0.5)
    args = (x[0], x[1], q[0], q[1], ref["L0"], ref["psi0"], ref["gamma0"], SECTION.stiffness)
    K, K_py = np.empty(144), np.empty(144)
    tangents.beam2_tangent(*args, np.empty(12), K)
    tangents.beam2_tangent.py_func(*args, np.empty(12), K_py)
    assert np.max(np.abs(K - K_py)) <= 1e-13 * np.max(np.abs(K))
    args = (rng.normal(size=3), qexp(rng.normal(size=3)), rng.normal(size=3), qexp(rng.normal(size=3)),
            rng.normal(size=3), rng.normal(size=3), rng.normal(size=9), rng.normal(size=9), rng.normal(size=10))
    tangents.joint_primitive_hessian(*args, K)
    tangents.joint_primitive_hessian.py_func(*args, K_py)
    assert np.max(np.abs(K - K_py)) <= 1e-13 * np.max(np.abs(K))
