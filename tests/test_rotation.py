"""Rotations: round trips, group properties, behaviour near 0 and π, the Cayley update,
the tangent operators (hypothesis-driven where the claim is "for every rotation")."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from reference.generated import rotation_maps as rm
from reference.rotation import (
    EulerParameters, RodriguesParameters, RotationVector, left_jacobian, quaternion_product, right_jacobian,
    right_jacobian_inverse, skew, unskew,
)

unit = st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 0.1)
vec3 = st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=3, max_size=3)
SETTINGS = settings(max_examples=100, deadline=None)


def same_rotation(a, b, tol=1e-12):
    return np.max(np.abs(a.matrix() - b.matrix())) <= tol


@SETTINGS
@given(unit)
def test_round_trips_through_every_parametrisation(q):
    """EP → matrix → EP, EP → rotation vector → EP, EP → Rodrigues → EP (away from π): same
    rotation to 1e-12 (a few ulps of the O(1) matrix entries, times the conversions)."""
    ep = EulerParameters(q)
    assert same_rotation(EulerParameters.from_matrix(ep.matrix()), ep)
    assert same_rotation(ep.to(RotationVector).to(EulerParameters), ep)
    assert same_rotation(RotationVector.from_matrix(ep.matrix()), ep)
    if ep.angle() < np.pi - 1e-3:
        assert same_rotation(ep.to(RodriguesParameters), ep, tol=1e-10)


@SETTINGS
@given(unit)
def test_matrices_are_proper_orthogonal(q):
    A = EulerParameters(q).matrix()
    assert np.allclose(A.T @ A, np.eye(3), atol=1e-14) and np.linalg.det(A) == pytest.approx(1.0, abs=1e-14)


@SETTINGS
@given(unit, unit, unit)
def test_product_is_associative_and_a_homomorphism(p, q, r):
    """(p⊗q)⊗r = p⊗(q⊗r) and A(p⊗q) = A(p) A(q); compose() and inverse() agree with matrices."""
    P, Q, R = EulerParameters(p), EulerParameters(q), EulerParameters(r)
    assert np.allclose(P.product(Q).product(R).q, P.product(Q.product(R)).q, atol=1e-14)
    assert np.allclose(P.product(Q).matrix(), P.matrix() @ Q.matrix(), atol=1e-14)
    V = RotationVector(P.log())
    assert np.allclose((V @ Q.to(RotationVector)).matrix(), P.matrix() @ Q.matrix(), atol=1e-12)
    assert np.allclose(V.inverse().matrix(), P.matrix().T, atol=1e-12)


@SETTINGS
@given(unit)
def test_log_takes_the_shortest_branch(q):
    """|log q| ≤ π and exp(log q) = ±q."""
    ep = EulerParameters(q)
    psi = ep.log()
    assert np.linalg.norm(psi) <= np.pi + 1e-12
    back = RotationVector(psi).to_euler_parameters().q
    assert min(np.max(np.abs(back - ep.q)), np.max(np.abs(back + ep.q))) <= 1e-13


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-9, 1e-5, 0.09, 0.1 - 1e-12, 0.1, 0.11, 1.0, 3.0,
                                   np.pi - 1e-5, np.pi - 1e-9, np.pi])
def test_near_zero_and_near_half_turn(angle):
    """Rotation vector ↔ matrix ↔ Euler parameters across the series threshold (0.1) and up
    to π, against the Rodrigues formula evaluated in closed form (1e-13: a few ulps)."""
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    psi = angle * axis
    K = skew(axis)
    exact = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    rv = RotationVector(psi)
    assert np.allclose(rv.matrix(), exact, atol=1e-13)
    back = RotationVector.from_matrix(exact).psi
    if angle < np.pi - 1e-6:
        assert np.allclose(back, psi, atol=1e-9 if angle > 3 else 1e-13)
    else:  # at a half turn ±ψ are the same rotation
        assert min(np.linalg.norm(back - psi), np.linalg.norm(back + psi)) < 1e-6
    assert same_rotation(EulerParameters.from_matrix(exact), rv, tol=1e-13)


def test_rodrigues_refuses_a_half_turn_clearly():
    with pytest.raises(ValueError, match="infinite at a half turn"):
        RodriguesParameters.from_matrix(RotationVector([0.0, 0.0, np.pi]).matrix())
    g = RodriguesParameters.from_matrix(RotationVector([0.0, 0.0, np.pi - 1e-3]).matrix())
    assert np.isfinite(g.g).all()


@pytest.mark.parametrize("name, exact", [
    ("c_sinc", lambda a: mpmath.sin(a) / a),
    ("c_cosc", lambda a: (1 - mpmath.cos(a)) / a**2),
    ("c_sinc3", lambda a: (a - mpmath.sin(a)) / a**3),
    ("c_jinv", lambda a: (1 - (a / 2) * mpmath.cot(a / 2)) / a**2),
    ("c_asinc", lambda a: a / mpmath.sin(a)),
])
def test_coefficient_functions_against_high_precision(name, exact):
    """Both branches (series below 0.1, closed form above) against 50-digit mpmath: 1e-15
    relative below the threshold; above it, the closed forms' cancellation near 0.1 costs
    up to eps/a³ ≈ 2e-13 (c_sinc3), so 5e-13."""
    f = getattr(rm, name)
    mpmath.mp.dps = 50
    for a in [1e-8, 1e-4, 0.05, 0.1 - 1e-12, 0.1, 0.1 + 1e-12, 0.5, 1.5]:
        ref = float(exact(mpmath.mpf(a)))
        tol = 1e-15 if a < 0.1 else 5e-13
        assert f(a) == pytest.approx(ref, rel=tol), (name, a)


@SETTINGS
@given(unit, vec3)
def test_cayley_update_against_the_exponential(q, w):
    """The trapezoidal (Cayley) update equals q ⊗ exp(hω) to third order: the error ratio
    for h and h/2 is 8 (observed order 3 ± 0.2), and the result is unit to 1e-15."""
    q, w = EulerParameters(q), np.asarray(w)
    # below |ω| = 0.5 the O((h|ω|)³) error sinks towards round-off and the order is unmeasurable
    assume(np.linalg.norm(w) >= 0.5)
    errs = []
    for h in (0.02, 0.01):
        cay = q.cayley_update(w, h).q
        ex = q.product(RotationVector(h * w).to_euler_parameters()).q
        errs.append(np.linalg.norm(cay - ex))
        assert abs(np.linalg.norm(cay) - 1.0) < 1e-15
    assert np.log2(errs[0] / errs[1]) == pytest.approx(3.0, abs=0.2)


def test_cayley_keeps_unit_norm_over_many_updates():
    """10⁴ updates with a constant body ω: unit norm to 1e-14, and a rotation about the fixed
    axis ω by exactly n·4 atan(h|ω|/4) — the Cayley map's angle per step, which lags the
    exact h|ω| by h³|ω|³/48 (1e-5 rad after 10 s here, so the exact angle is asserted)."""
    q0 = EulerParameters([1.0, 0.2, -0.3, 0.1])
    w, h, n = np.array([3.0, -1.0, 2.0]), 1e-3, 10_000
    q = q0
    for _ in range(n):
        q = q.cayley_update(w, h)
    assert abs(np.linalg.norm(q.q) - 1.0) < 1e-14
    angle = (n * 4 * np.arctan(h * np.linalg.norm(w) / 4)) % (2 * np.pi)
    expected = RotationVector(min(angle, 2 * np.pi - angle) * np.sign(np.pi - angle) * w / np.linalg.norm(w))
    assert same_rotation(q0.conjugate().product(q), expected, tol=1e-10)


@SETTINGS
@given(st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) < 3.0))
def test_right_jacobian_by_finite_differences(psi):
    """exp((ψ+δψ)~) = exp(ψ̃) exp((J_r δψ)~) + O(δψ²): central differences of
    log(exp(ψ̃)ᵀ exp((ψ+εe_k)~))/ε give the columns of J_r (ε = 1e-6: error 1e-9);
    J_r J_r⁻¹ = I; J_l(ψ) = J_r(−ψ) = J_r(ψ)ᵀ."""
    psi = np.asarray(psi)
    A = RotationVector(psi).matrix()
    J = np.zeros((3, 3))
    eps = 1e-6
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        plus = RotationVector.from_matrix(A.T @ RotationVector(psi + d).matrix()).psi
        minus = RotationVector.from_matrix(A.T @ RotationVector(psi - d).matrix()).psi
        J[:, k] = (plus - minus) / (2 * eps)
    assert np.allclose(J, right_jacobian(psi), atol=1e-8)
    assert np.allclose(right_jacobian(psi) @ right_jacobian_inverse(psi), np.eye(3), atol=1e-12)
    assert np.allclose(left_jacobian(psi), right_jacobian(psi).T, atol=1e-14)


def test_skew_and_kinematic_rate():
    a, b = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 0.3, 2.0])
    assert np.allclose(skew(a) @ b, np.cross(a, b)) and np.allclose(unskew(skew(a)), a)
    q = EulerParameters([0.9, 0.1, -0.3, 0.2])
    w = np.array([0.3, -0.2, 0.5])
    # q̇ = ½ q ⊗ (0, ω) ⇔ Ȧ = A ω̃ (body-frame angular velocity)
    h = 1e-6
    Adot = (EulerParameters(q.q + h * q.kinematic_rate(w)).matrix() - EulerParameters(q.q - h * q.kinematic_rate(w)).matrix()) / (2 * h)
    assert np.allclose(Adot, q.matrix() @ skew(w), atol=1e-8)
    assert np.allclose(quaternion_product(q.q, [1.0, 0, 0, 0]), q.q)
