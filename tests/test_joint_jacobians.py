"""Every joint's velocity Jacobian against finite differences of its constraint equations."""

from __future__ import annotations

import numpy as np
import pytest

from reference.domain import Domain
from reference.interactions import Sine
from reference.joints import Joint, joint_frame
from reference.joints.joint import PRESCRIBED, ROWS
from reference.rotation import EulerParameters, RotationVector

KINDS = list(ROWS)


def random_q(rng):
    return RotationVector(rng.normal(size=3) * 1.5).to_euler_parameters().q


def setup(kind, rng, ground):
    d = Domain()
    bi = d.add_rigid_body("i", 1.0, [1.0, 2.0, 3.0], rng.normal(size=3), rotation=random_q(rng))
    bj = None if ground else d.add_rigid_body("j", 2.0, [2.0, 1.0, 1.0], rng.normal(size=3), rotation=random_q(rng))
    frame = joint_frame(rng.normal(size=3), rng.normal(size=3))
    joint = Joint(kind, bi, bj, rng.normal(size=3), frame, time_function=Sine(0.7, 2.0, 0.3, 0.1),
                  mode="velocity" if kind.endswith("drive") and rng.random() < 0.5 else "position")
    x0 = np.array([n.position for n in d.nodes])
    q0 = np.array([n.rotation for n in d.nodes])
    return joint, x0, q0


def perturb(x, q, node, k, eps):
    x, q = x.copy(), q.copy()
    d = np.zeros(3)
    d[k % 3] = eps
    if k < 3:
        x[node] += d
    else:
        q[node] = EulerParameters(q[node]).product(RotationVector(d).to_euler_parameters()).q
    return x, q


@pytest.mark.parametrize("ground", [False, True])
@pytest.mark.parametrize("kind", KINDS)
def test_jacobian_matches_finite_differences(kind, ground):
    """20 random configurations each: B against central differences of Φ under x → x + ε e_k and
    q → q ⊗ exp(ε e_k) (body-frame rotation).  ε = 1e-6: truncation ~1e-12, round-off ~1e-10
    of |Φ| ~ 1, so 1e-7 absolute; Φ_t against central differences in time (same reasoning)."""
    rng = np.random.default_rng(hash((kind, ground)) % 2**32)
    if kind == PRESCRIBED and not ground:  # its direction is inertial: body_j is the ground
        with pytest.raises(ValueError, match="fixed on the ground"):
            setup(kind, rng, ground)
        return
    for _ in range(20):
        joint, x0, q0 = setup(kind, rng, ground)
        x = x0 + rng.normal(size=x0.shape) * 0.3
        q = np.array([EulerParameters(qq).product(RotationVector(rng.normal(size=3) * 0.5).to_euler_parameters()).q
                      for qq in q0])
        t = rng.uniform(0.0, 3.0)
        phi, B, phit = joint.evaluate(x, q, t)
        eps = 1e-6
        n_bodies = 1 if ground else 2
        fd = np.zeros_like(B)
        for body in range(n_bodies):
            for k in range(6):
                plus = joint.evaluate(*perturb(x, q, body, k, eps), t)[0]
                minus = joint.evaluate(*perturb(x, q, body, k, -eps), t)[0]
                fd[:, 6 * body + k] = (plus - minus) / (2 * eps)
        assert np.max(np.abs(fd - B)) < 1e-7, kind
        if ground:
            assert np.all(B[:, 6:] == 0.0)
        fd_t = (joint.evaluate(x, q, t + eps)[0] - joint.evaluate(x, q, t - eps)[0]) / (2 * eps)
        assert np.allclose(fd_t, phit, atol=1e-7)


@pytest.mark.parametrize("kind", KINDS)
def test_joint_equations_vanish_as_assembled_and_have_full_rank(kind):
    """Φ = 0 in the configuration the joint was defined in (drives: at t = 0, θ(0) = 0 for the
    velocity mode), and B has full row rank at generic configurations."""
    rng = np.random.default_rng(3)
    for _ in range(10):
        joint, x0, q0 = setup(kind, rng, ground=kind == PRESCRIBED)  # a prescribed displacement: to the ground
        t = 0.0
        if (kind.endswith("drive") or kind == PRESCRIBED) and joint.mode == "position":
            joint.time_function = Sine(0.7, 2.0, 0.0, 0.0)  # zero at t = 0
        phi, B, _ = joint.evaluate(x0, q0, t)
        assert np.max(np.abs(phi)) < 1e-13
        assert np.linalg.matrix_rank(B) == joint.n_equations


def test_revolute_drive_measures_the_relative_rotation():
    """A body turned by α about the joint axis relative to the ground: the drive's Φ equals
    sin(α − θ(t)), zero when the prescribed angle is α."""
    d = Domain()
    b = d.add_rigid_body("crank", 1.0, [1.0, 1.0, 1.0], [0.5, 0.0, 0.0])
    joint = Joint("rotation_drive", b, None, [0.0, 0.0, 0.0], joint_frame([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
                  time_function=Sine(0.0, 1.0, 0.0, 0.3))  # θ(t) = 0.3
    alpha = 0.3
    R = RotationVector([0.0, 0.0, alpha])
    x = np.array([R.matrix() @ [0.5, 0.0, 0.0]])
    q = np.array([R.to_euler_parameters().q])
    assert joint.evaluate(x, q, 0.0)[0][0] == pytest.approx(0.0, abs=1e-15)
    x2 = np.array([RotationVector([0.0, 0.0, 0.5]).matrix() @ [0.5, 0.0, 0.0]])
    q2 = np.array([RotationVector([0.0, 0.0, 0.5]).to_euler_parameters().q])
    assert joint.evaluate(x2, q2, 0.0)[0][0] == pytest.approx(np.sin(0.5 - 0.3), abs=1e-14)
