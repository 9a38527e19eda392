"""Rotations (reference/rotation.py and the generated kernels it wraps).

Round trips among the parametrisations and matrices, group properties, behaviour
near 0 (across the series thresholds of the coefficient functions) and near π,
the Cayley update, the SO(3) Jacobians, the coefficient functions against mpmath,
and the Rodrigues half-turn refusal.  Hypothesis drives the "for every rotation"
claims.  Every tolerance states its reason; EPS = 2.2e-16 is the double epsilon.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from derivations.codegen import short_threshold
from derivations.rotation_maps import COEFFICIENTS

from reference.generated import rotation_maps as rm
from reference.rotation import (
    EulerParameters, RodriguesParameters, Rotation, RotationVector, left_jacobian, left_jacobian_inverse,
    quaternion_product, right_jacobian, right_jacobian_inverse, skew, unskew,
)

EPS = np.finfo(float).eps
SETTINGS = settings(max_examples=100, deadline=None)
CLASSES = [EulerParameters, RotationVector, RodriguesParameters]

# Quaternions from a box; a norm floor keeps normalisation well conditioned.
quats = st.lists(st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 0.1)
vec3 = st.lists(st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False), min_size=3, max_size=3)
# Rotation vectors strictly inside the shortest branch (|ψ| < π), so ψ → rotation → ψ is single valued.
psis = vec3.filter(lambda v: np.linalg.norm(v) < 3.1)
AXIS = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])


def same_up_to_sign(a, b) -> float:
    """Distance between two quaternions modulo the sign (q and −q are the same rotation)."""
    return min(np.max(np.abs(a - b)), np.max(np.abs(a + b)))


def mp_exp_matrix(psi):
    """exp(ψ̃) of the float vector ψ, by Rodrigues' formula in 40-digit mpmath, rounded once."""
    with mpmath.workdps(40):
        p = [mpmath.mpf(float(c)) for c in psi]
        a = mpmath.sqrt(sum(c * c for c in p))
        S = mpmath.matrix([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        A = mpmath.eye(3) + (mpmath.sin(a) / a) * S + ((1 - mpmath.cos(a)) / a**2) * S * S
        return np.array([[float(A[i, j]) for j in range(3)] for i in range(3)])


def mp_euler_parameters(psi):
    """(cos(a/2), sin(a/2) ψ/a) of the float vector ψ in 40-digit mpmath."""
    with mpmath.workdps(40):
        p = [mpmath.mpf(float(c)) for c in psi]
        a = mpmath.sqrt(sum(c * c for c in p))
        return np.array([float(mpmath.cos(a / 2))] + [float(mpmath.sin(a / 2) / a * c) for c in p])


def test_skew_unskew_and_the_stated_matrix_convention():
    """ã b = a × b; unskew inverts skew; A(q) is (2e0²−1)I + 2(eeᵀ + e0ẽ) and maps body to inertial:
    a +90° turn about z carries the body x axis to inertial y.  Tolerance 1e-15: a few ulps."""
    a, b = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 0.3, 2.0])
    assert np.allclose(skew(a) @ b, np.cross(a, b), rtol=0, atol=1e-15)
    assert np.array_equal(unskew(skew(a)), a)
    q = EulerParameters([0.8, 0.1, -0.5, 0.3])
    e0, e = q.q[0], q.q[1:]
    A = (2 * e0**2 - 1) * np.eye(3) + 2 * (np.outer(e, e) + e0 * skew(e))
    assert np.max(np.abs(q.matrix() - A)) <= 1e-15
    quarter = EulerParameters([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    assert np.max(np.abs(quarter.apply([1.0, 0.0, 0.0]) - [0.0, 1.0, 0.0])) <= 1e-15
    # the rotation vector and Rodrigues parameters describe the same turn
    assert np.max(np.abs(RotationVector([0, 0, np.pi / 2]).matrix() - quarter.matrix())) <= 1e-15
    assert np.max(np.abs(RodriguesParameters([0, 0, 1.0]).matrix() - quarter.matrix())) <= 1e-15


def test_kinematic_rate_is_body_frame_angular_velocity():
    """q̇ = ½ q ⊗ (0, ω) ⇔ Ȧ = A ω̃ (ω in the body frame, not Ȧ = ω̃ A), and q·q̇ = 0.
    Central differences with step 1e-6: truncation ~1e-12, round-off ~EPS/1e-6 ≈ 2e-10 → 1e-9."""
    q = EulerParameters([0.9, 0.1, -0.3, 0.2])
    w = np.array([0.3, -0.2, 0.5])
    qd = q.kinematic_rate(w)
    assert abs(q.q @ qd) <= 1e-16
    d = 1e-6
    Adot = (EulerParameters(q.q + d * qd).matrix() - EulerParameters(q.q - d * qd).matrix()) / (2 * d)
    assert np.max(np.abs(Adot - q.matrix() @ skew(w))) <= 1e-9
    assert np.max(np.abs(Adot - skew(w) @ q.matrix())) > 1e-2  # the other convention is really different


@SETTINGS
@given(quats)
def test_round_trips_from_euler_parameters(q):
    """EP → matrix → EP, EP → RV → EP, EP → Rodrigues → EP (not within 1e-6 rad of π): the same
    unit quaternion up to sign.  Tolerances: Shepperd's method divides by the largest component
    (≥ ½), so 4e-16 matrix errors stay ~1e-15; log/exp and e/e0 → (1,g)/|·| likewise; 3e-15."""
    ep = EulerParameters(q)
    assert same_up_to_sign(EulerParameters.from_matrix(ep.matrix()).q, ep.q) <= 3e-15
    assert same_up_to_sign(ep.to(RotationVector).to(EulerParameters).q, ep.q) <= 3e-15
    assert same_up_to_sign(RotationVector.from_matrix(ep.matrix()).to_euler_parameters().q, ep.q) <= 3e-15
    if np.pi - ep.angle() > 1e-6:
        assert same_up_to_sign(ep.to(RodriguesParameters).to(EulerParameters).q, ep.q) <= 3e-15
        assert same_up_to_sign(RodriguesParameters.from_matrix(ep.matrix()).to_euler_parameters().q, ep.q) <= 3e-15


@SETTINGS
@given(psis)
def test_round_trips_from_rotation_vectors(psi):
    """|ψ| < 3.1 < π: ψ → EP → ψ and ψ → matrix → ψ return ψ itself (shortest branch is unique).
    Tolerance 5e-15 absolute: log(q) = 2 (b/sin b) e with b/sin b ≤ π/2 amplifies ulp errors of
    the O(1) quaternion by ≤ ~π; the matrix path adds Shepperd's ~1e-15 (measured ≤ 1.1e-15 over
    2·10⁴ random ψ)."""
    rv = RotationVector(psi)
    assert np.max(np.abs(rv.to(EulerParameters).to(RotationVector).psi - rv.psi)) <= 5e-15
    assert np.max(np.abs(RotationVector.from_matrix(rv.matrix()).psi - rv.psi)) <= 5e-15
    for cls in CLASSES:  # every parametrisation gives the same matrix (few-ulp agreement)
        if cls is RodriguesParameters and np.pi - rv.angle() < 1e-6:
            continue
        assert np.max(np.abs(rv.to(cls).matrix() - rv.matrix())) <= 4e-15


@SETTINGS
@given(vec3.filter(lambda v: np.linalg.norm(v) < 1e3))
def test_round_trips_from_rodrigues_parameters(g):
    """g → EP → g and g → matrix → g.  Relative tolerance 1e-14 on g (plus 1e-15 absolute):
    g = e/e0, and |g| up to ~5 here means e0 ≥ 0.2, so a few-ulp quaternion error grows ≤ ~25×."""
    rp = RodriguesParameters(g)
    tol = 1e-14 * np.linalg.norm(rp.g) + 1e-15
    assert np.max(np.abs(rp.to(EulerParameters).to(RodriguesParameters).g - rp.g)) <= tol
    assert np.max(np.abs(RodriguesParameters.from_matrix(rp.matrix()).g - rp.g)) <= tol


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-9, 1e-5, 0.09, 0.1 - 1e-12, 0.1 + 1e-12, 0.11, 1.0])
@pytest.mark.parametrize("cls", CLASSES)
def test_small_angles_are_relatively_accurate(cls, angle):
    """Near 0 (and across the 0.1 series threshold) the rotation vector survives every round trip
    with *relative* accuracy 1e-14 — an arccos of the trace would lose everything at 1e-9 — and
    the matrix equals the 40-digit exp(ψ̃) to 4e-16 absolute (≈ 2 ulps of O(1) entries)."""
    psi = angle * AXIS
    R = RotationVector(psi)
    if angle > 0:
        assert np.max(np.abs(R.matrix() - mp_exp_matrix(psi))) <= 4e-16
    else:
        assert np.array_equal(R.matrix(), np.eye(3))
    for via in ("parameters", "matrix"):
        X = R.to(cls) if via == "parameters" else cls.from_matrix(R.matrix())
        back = X.to(RotationVector).psi
        assert np.linalg.norm(back - psi) <= 1e-14 * angle, (via, back, psi)
        assert np.max(np.abs(X.matrix() - R.matrix())) <= 4e-16
    # Euler parameters against 40-digit cos(a/2), sin(a/2) n: few ulps relative per component
    if angle > 0:
        assert np.max(np.abs(R.to_euler_parameters().q - mp_euler_parameters(psi))
                      / np.maximum(np.abs(mp_euler_parameters(psi)), 1e-300)) <= 1e-15
    assert R.to(cls).angle() == pytest.approx(angle, rel=1e-14, abs=0)


@pytest.mark.parametrize("delta", [1e-5, 1e-9, 0.0])
@pytest.mark.parametrize("cls", [EulerParameters, RotationVector])
def test_near_a_half_turn(cls, delta):
    """a = π − δ for δ = 1e-5, 1e-9 and exactly (float) π: Euler parameters and rotation vectors
    are exact there.  ψ comes back to π·1e-15 absolute (Shepperd divides by the largest e_k ≥ ½,
    and the angle is 2 atan2(|e|, e0), accurate where e0 → 0); at π itself ±ψ are the same
    rotation and either may come back.  Matrices agree with 40-digit exp(ψ̃) to 1e-15: near π the
    ψ̃² term is (1−cos a)/a² ψψᵀ with entries up to 2, whose ulps (4.4e-16) survive the sum."""
    psi = (np.pi - delta) * AXIS
    R = RotationVector(psi)
    A = mp_exp_matrix(psi)
    assert np.max(np.abs(R.matrix() - A)) <= 1e-15
    for X in (R.to(cls), cls.from_matrix(A)):
        back = X.to(RotationVector).psi
        assert np.linalg.norm(back) <= np.pi * (1 + 2 * EPS)  # shortest branch, up to the ulps of the norm
        err = np.linalg.norm(back - psi) if delta > 0 else min(np.linalg.norm(back - psi), np.linalg.norm(back + psi))
        assert err <= 1e-15 * np.pi, (back, psi)
        assert np.max(np.abs(X.matrix() - A)) <= 1e-15
        assert X.angle() == pytest.approx(np.pi - delta, rel=0, abs=1e-15)


@SETTINGS
@given(quats)
def test_matrices_are_proper_orthogonal(q):
    """AᵀA = I and det A = +1 for every parametrisation.  Tolerance 5e-15: each entry of A carries a
    few ulps and AᵀA / det sum three products of them (measured ≤ 2.3e-15 and 3.0e-15 over 3·10⁵
    random rotations)."""
    ep = EulerParameters(q)
    for cls in CLASSES:
        if cls is RodriguesParameters and np.pi - ep.angle() < 1e-6:
            continue
        A = ep.to(cls).matrix()
        assert np.max(np.abs(A.T @ A - np.eye(3))) <= 5e-15
        assert abs(np.linalg.det(A) - 1.0) <= 5e-15


@SETTINGS
@given(quats, quats, quats)
def test_quaternion_product_is_associative_and_a_homomorphism(p, q, r):
    """(p⊗q)⊗r = p⊗(q⊗r), A(p⊗q) = A(p)A(q), p⊗p* = 1.  4e-15: sums of 4 products of unit-size
    numbers, twice, a few ulps each (matrix homomorphism measured ≤ 1.7e-15)."""
    P, Q, R = EulerParameters(p), EulerParameters(q), EulerParameters(r)
    assert np.max(np.abs((P * Q * R).q - (P * (Q * R)).q)) <= 4e-15
    assert np.max(np.abs(P.product(Q).matrix() - P.matrix() @ Q.matrix())) <= 4e-15
    assert np.max(np.abs((P * P.conjugate()).q - [1.0, 0.0, 0.0, 0.0])) <= 4e-15
    raw = quaternion_product(np.asarray(p), np.asarray(q))  # the bare product scales with the norms
    assert np.linalg.norm(raw) == pytest.approx(np.linalg.norm(p) * np.linalg.norm(q), rel=4 * EPS)


@SETTINGS
@given(quats, quats)
def test_compose_and_inverse_agree_with_matrices(p, q):
    """compose/@ has the matrix A_self A_other in every combination of parametrisations and keeps
    the type of self; inverse has Aᵀ and R @ R⁻¹ = identity.  6e-15: matrices of composed
    conversions, a few ulps each (measured ≤ 2e-15)."""
    P, Q = EulerParameters(p), EulerParameters(q)
    AB = P.matrix() @ Q.matrix()
    for c1 in CLASSES:
        for c2 in CLASSES:
            rod = RodriguesParameters in (c1, c2)
            if rod and min(np.pi - P.angle(), np.pi - Q.angle(), np.pi - P.product(Q).angle()) < 1e-6:
                continue
            X = P.to(c1) @ Q.to(c2)
            assert type(X) is c1
            assert np.max(np.abs(X.matrix() - AB)) <= 6e-15
        if c1 is RodriguesParameters and np.pi - P.angle() < 1e-6:
            continue
        X = P.to(c1)
        assert type(X.inverse()) is c1
        assert np.max(np.abs(X.inverse().matrix() - P.matrix().T)) <= 6e-15
        assert (X @ X.inverse()).angle() <= 6e-15


def test_apply_to_and_repr():
    """apply = A v (also for stacks of vectors), to() converts, repr evaluates back to the same
    parameters (repr prints full precision, so exactly), from_matrix refuses reflections."""
    R = RotationVector([0.3, -1.2, 0.8])
    V = np.array([[1.0, 2.0, 3.0], [0.0, -1.0, 0.5]])
    assert np.allclose(R.apply(V), (R.matrix() @ V.T).T, rtol=0, atol=1e-15)
    assert np.allclose(R.apply(V[0]), R.matrix() @ V[0], rtol=0, atol=1e-15)
    for cls in CLASSES:
        X = R.to(cls)
        assert isinstance(X, Rotation) and type(X) is cls
        assert np.array_equal(eval(repr(X)).as_array(), X.as_array())
    with pytest.raises(TypeError):
        R.to(np.ndarray)
    with pytest.raises(ValueError, match="proper rotation"):
        EulerParameters.from_matrix(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(TypeError):
        Rotation()  # abstract


@SETTINGS
@given(quats)
def test_log_takes_the_shortest_branch(q):
    """|log q| ≤ π (to 1 ulp of π) and exp(log q) = ±q (3e-15: b/sin b ≤ π/2 times ulps)."""
    ep = EulerParameters(q)
    psi = ep.log()
    assert np.linalg.norm(psi) <= np.pi * (1 + EPS)
    assert same_up_to_sign(RotationVector(psi).to_euler_parameters().q, ep.q) <= 3e-15


@SETTINGS
@given(quats, vec3.filter(lambda v: np.linalg.norm(v) >= 0.5))
def test_cayley_update_is_third_order(q, w):
    """Trapezoidal (Cayley) step against the exact q ⊗ exp(hω): the error is (h|ω|)³/96 + …,
    so the ratio for h and h/2 gives an observed order 3 ± 0.2 (h|ω| ≤ 0.1: the next term is
    O((h|ω|)²) relative; |ω| ≥ 0.5 keeps the error ≥ 1e-9, far above round-off)."""
    q, w = EulerParameters(q), np.asarray(w)
    errs = []
    for h in (0.02, 0.01):
        cay = q.cayley_update(w, h).q
        exact = q.product(RotationVector(h * w).to_euler_parameters()).q
        errs.append(np.linalg.norm(cay - exact))
    assert np.log2(errs[0] / errs[1]) == pytest.approx(3.0, abs=0.2)


def test_cayley_update_over_many_steps():
    """10⁴ steps with a constant body ω: (i) unit norm to 1e-15 (the class renormalises each step
    against round-off); (ii) the net rotation is about the fixed axis ω by exactly n·4 atan(h|ω|/4),
    the Cayley angle per step (lagging h|ω| by (h|ω|)³/48 — 1.3e-5 rad in total here, so the exact
    h|ω| would fail) — to 1e-11: 10⁴ steps of ~1e-16 round-off, random-walk to ~1e-14, worst
    case linear ~1e-12."""
    q0 = EulerParameters([1.0, 0.2, -0.3, 0.1])
    w, h, n = np.array([3.0, -1.0, 2.0]), 1e-3, 10_000
    q = q0
    worst = 0.0
    for _ in range(n):
        q = q.cayley_update(w, h)
        worst = max(worst, abs(np.linalg.norm(q.q) - 1.0))
    assert worst <= 1e-15
    wn = np.linalg.norm(w)
    rel = (q0.conjugate() * q).to(RotationVector).psi
    cayley_angle = np.remainder(n * 4 * np.arctan(h * wn / 4) + np.pi, 2 * np.pi) - np.pi  # into [−π, π)
    assert np.max(np.abs(rel - cayley_angle * w / wn)) <= 1e-11
    exact_angle = np.remainder(n * h * wn + np.pi, 2 * np.pi) - np.pi
    assert np.max(np.abs(rel - exact_angle * w / wn)) > 1e-6  # the lag is real


def test_bare_cayley_kernel_stays_unit_without_renormalisation():
    """The generated kernel alone (no renormalisation) is unit in exact arithmetic; round-off makes
    |q| drift, and the drift is systematic, not a random walk (measured −3.7e-13 after 10⁴ steps,
    ~0.17 ulp per step).  Bound 5e-12: worst-case linear accumulation, 10⁴ × ~2 ulps.  This is why
    EulerParameters renormalises every step (against round-off only)."""
    q = np.array([1.0, 0.2, -0.3, 0.1]) / np.linalg.norm([1.0, 0.2, -0.3, 0.1])
    w = np.array([3.0, -1.0, 2.0])
    for _ in range(10_000):
        q = np.array(rm.cayley_update_scalars(*q, *w, 1e-3))
    assert abs(np.linalg.norm(q) - 1.0) <= 5e-12


def _fd_jacobian(psi, side: str, eps: float = 1e-6) -> np.ndarray:
    """Columns (log(q(ψ)* ⊗ q(ψ+εe_k)) − log(q(ψ)* ⊗ q(ψ−εe_k)))/2ε (right), or with the factors
    swapped (left): the derivative of the body (spatial) increment with respect to ψ."""
    q = RotationVector(psi).to_euler_parameters()
    J = np.zeros((3, 3))
    for k in range(3):
        cols = []
        for s in (1.0, -1.0):
            d = np.zeros(3)
            d[k] = s * eps
            qd = RotationVector(psi + d).to_euler_parameters()
            rel = q.conjugate() * qd if side == "right" else qd * q.conjugate()
            cols.append(rel.log())
        J[:, k] = (cols[0] - cols[1]) / (2 * eps)
    return J


def _check_jacobians(psi):
    """FD tolerance 5e-9: the relative quaternion has ~1e-16 absolute error, the log doubles it,
    divided by 2ε = 2e-6 → ~2e-10, times the O(1) conditioning; truncation O(ε²) ~ 1e-12.
    J_r J_r⁻¹ = I to 4e-15 (entries of J_r⁻¹ stay O(1) for |ψ| ≤ 3: c_jinv(3) ≈ 0.1, ψ̃² ≤ 9;
    a few ulps of O(1) products, measured ≤ 4.4e-16 over 2000 random ψ).
    J_l = J_r(ψ)ᵀ to 1e-15 (same coefficients, transposed signs)."""
    psi = np.asarray(psi, dtype=float)
    Jr, Jl = right_jacobian(psi), left_jacobian(psi)
    assert np.max(np.abs(_fd_jacobian(psi, "right") - Jr)) <= 5e-9
    assert np.max(np.abs(_fd_jacobian(psi, "left") - Jl)) <= 5e-9
    I = np.eye(3)
    assert np.max(np.abs(Jr @ right_jacobian_inverse(psi) - I)) <= 4e-15
    assert np.max(np.abs(right_jacobian_inverse(psi) @ Jr - I)) <= 4e-15
    assert np.max(np.abs(Jl @ left_jacobian_inverse(psi) - I)) <= 4e-15
    assert np.max(np.abs(Jl - Jr.T)) <= 1e-15
    R = RotationVector(psi)
    assert np.array_equal(R.tangent_operator(), Jr) and np.array_equal(R.tangent_operator_inverse(),
                                                                       right_jacobian_inverse(psi))
    assert np.array_equal(R.left_tangent_operator(), Jl)


@SETTINGS
@given(vec3.filter(lambda v: np.linalg.norm(v) <= 3.0))
def test_jacobians_by_finite_differences(psi):
    """exp((ψ+δψ)~) = exp(ψ̃) exp((J_r δψ)~) + O(δψ²) and = exp((J_l δψ)~) exp(ψ̃) + O(δψ²)."""
    _check_jacobians(psi)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-5, 0.09, 0.1 - 1e-12, 0.1 + 1e-12, 0.11, 1.0, 3.0])
def test_jacobians_near_zero_and_large(angle):
    """The same checks at fixed angles across the series threshold and up to |ψ| = 3.0."""
    _check_jacobians(angle * AXIS)


def test_jacobian_wrong_sign_would_be_caught():
    """Control: the FD check distinguishes J_r from J_l (they differ by 2(1−cos a)/a² ψ̃, O(1) at 1 rad)."""
    psi = 1.0 * AXIS
    assert np.max(np.abs(_fd_jacobian(psi, "right") - left_jacobian(psi))) > 0.1


EXACT = {
    "c_sinc": lambda a: mpmath.sin(a) / a,
    "c_cosc": lambda a: (1 - mpmath.cos(a)) / a**2,
    "c_sinc3": lambda a: (a - mpmath.sin(a)) / a**3,
    "c_jinv": lambda a: (1 - (a / 2) * mpmath.cot(a / 2)) / a**2,
    "c_asinc": lambda a: a / mpmath.sin(a),
}
LIMIT_AT_ZERO = {"c_sinc": 1.0, "c_cosc": 0.5, "c_sinc3": 1 / 6, "c_jinv": 1 / 12, "c_asinc": 1.0}
# Where each coefficient switches from its series to its closed form, as the derivation says.
# The closed forms of c_cosc, c_sinc3 and c_jinv subtract nearly equal numbers (relative round-off
# ≈ 6 eps/a² for c_sinc3), so their series runs to a = 1; c_sinc and c_asinc switch at 0.1.
THRESHOLD = {c.name: c.threshold for c in COEFFICIENTS}
SHORT = {c.name: short_threshold(c) for c in COEFFICIENTS}
"""Below these the short series (order 8) is used, exact to double precision by construction."""
TOL = 1e-15  # ~4 ulps: both branches are exact to round-off on their side of the switch


def _rel_err(name, a) -> float:
    """Relative error of the generated coefficient at the float a, against 50-digit mpmath."""
    with mpmath.workdps(50):
        ref = EXACT[name](mpmath.mpf(float(a)))
        return float(abs((mpmath.mpf(getattr(rm, name)(float(a))) - ref) / ref))


@pytest.mark.parametrize("name", list(EXACT))
def test_coefficients_against_mpmath(name):
    """All three branches to 1e-15 relative from 1e-12 up to the top of the range (π/2 for c_asinc,
    whose argument is a half angle; 3 for the others): series truncation is below 2⁻⁵³ at each
    threshold, the closed forms lose at most ~1.5e-15 to cancellation above it (measured 8e-16).
    With a single switch at 0.1 the closed forms lost up to 2.5e-13 (c_jinv)."""
    top = 1.5 if name == "c_asinc" else 3.0
    t, s = THRESHOLD[name], SHORT[name]
    assert 0.02 < s < t  # the short series covers the relative rotations of a fine mesh
    for a in [1e-12, 1e-8, 1e-4, 0.01, s * (1 - 1e-9), s * (1 + 1e-9), 0.0999, 0.1001, 0.5, t * (1 - 1e-9),
              t * (1 + 1e-9), 1.5, top]:
        assert _rel_err(name, a) <= TOL, (name, a)


def _jump(name, t, d=1e-12) -> float:
    """Jump of the generated coefficient across a switch at t, with the true slope removed: the
    difference of its relative errors at t + d and t − d."""
    with mpmath.workdps(50):
        f = getattr(rm, name)
        err = [mpmath.mpf(f(a)) - EXACT[name](mpmath.mpf(a)) for a in (t + d, t - d)]
        return float(abs(err[0] - err[1]) / EXACT[name](mpmath.mpf(t)))


@pytest.mark.parametrize("name", list(EXACT))
def test_coefficients_continuous_across_the_series_thresholds(name):
    """Short and long series, long series and closed form agree across each switch, once the true
    change f'·2e-12 is removed, to 1e-15 (~4 ulps)."""
    assert _jump(name, SHORT[name]) <= TOL
    assert _jump(name, THRESHOLD[name]) <= TOL


@pytest.mark.parametrize("delta", [0.0, 1e-12, 5e-9])
def test_rodrigues_refuses_a_half_turn_clearly(delta):
    """Within 1e-8 rad of π, from a matrix, from Euler parameters, by conversion, or directly from a
    huge g: ValueError saying why and what to use instead."""
    psi = (np.pi - delta) * AXIS
    msg = r"infinite at a half turn.*use EulerParameters or RotationVector"
    with pytest.raises(ValueError, match=msg):
        RodriguesParameters.from_matrix(mp_exp_matrix(psi))
    with pytest.raises(ValueError, match=msg):
        RodriguesParameters.from_euler_parameters(RotationVector(psi).to_euler_parameters())
    with pytest.raises(ValueError, match=msg):
        RotationVector(psi).to(RodriguesParameters)
    if delta > 0:
        with pytest.raises(ValueError, match=msg):
            RodriguesParameters(np.tan((np.pi - delta) / 2) * AXIS)


def test_rodrigues_just_outside_the_margin_is_fine():
    """At π − 1e-6 (100× the margin) g ≈ 2e6 n is finite: |g| to 1e-9 relative (e0 ≈ 5e-7 carries
    ~1e-16 absolute error, 2e-10 relative), and the matrix to 1e-15 (2/(1+|g|²) · |g|² is benign)."""
    psi = (np.pi - 1e-6) * AXIS
    rp = RodriguesParameters.from_matrix(mp_exp_matrix(psi))
    assert np.isfinite(rp.g).all() and np.linalg.norm(rp.g) == pytest.approx(np.tan((np.pi - 1e-6) / 2), rel=1e-9)
    assert np.max(np.abs(rp.matrix() - mp_exp_matrix(psi))) <= 1e-15
