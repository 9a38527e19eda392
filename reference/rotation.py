"""Finite rotations and their parametrisations (paper §4.2.1, Fig. 3).

**Conventions of the whole project (stated here once):**

- ``ã`` is the skew matrix of ``a``: ``ã b = a × b``.
- Euler parameters ``q = (e0, e1, e2, e3)``, **scalar first**, unit norm.
- ``A(q) = (2 e0² − 1) I + 2 (e eᵀ + e0 ẽ)`` maps **body** components to
  **inertial** components: ``v_inertial = A v_body``.
- Quaternion product ``q ⊗ p = (q0 p0 − q·p, q0 p + p0 q + q × p)``, so that
  ``A(q ⊗ p) = A(q) A(p)``: ``p`` is a rotation expressed in the body frame of ``q``.
- Angular velocities are **body-frame** components ``ω`` (Park et al. 1991):
  ``Ȧ = A ω̃`` and ``q̇ = ½ q ⊗ (0, ω)``.
- The rotation vector ``ψ`` (axis × angle) gives ``A = exp(ψ̃)``.
- Units: radians, seconds.

The scalar kernels (exponential, logarithm, Jacobians, the Cayley update) are
generated from sympy in ``reference/generated/rotation_maps.py``; the classes
below are the readable, object-oriented face of the same maps.

Sources: Géradin & Cardona, *Flexible Multibody Dynamics* (2001), ch. 4;
Nikravesh, *Computer-Aided Analysis of Mechanical Systems* (1988), ch. 6;
Shepperd, *J. Guidance Control* 1 (1978) for the matrix → quaternion map.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from reference.generated import rotation_maps as _rm


def skew(v) -> np.ndarray:
    """``ṽ`` with ``ṽ b = v × b``."""
    v = np.asarray(v, dtype=float)
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def unskew(S) -> np.ndarray:
    """The vector of the skew-symmetric part of ``S``."""
    S = np.asarray(S, dtype=float)
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def quaternion_product(p, q) -> np.ndarray:
    """``p ⊗ q`` (scalar first)."""
    out = np.empty(4)
    _rm.quat_product(np.asarray(p, dtype=float), np.asarray(q, dtype=float), out)
    return out


def _mat9(kernel, arg) -> np.ndarray:
    out = np.empty(9)
    kernel(np.asarray(arg, dtype=float), out)
    return out.reshape(3, 3)


def right_jacobian(psi) -> np.ndarray:
    """``J_r(ψ)``: ``exp((ψ + δψ)~) ≈ exp(ψ̃) exp((J_r(ψ) δψ)~)`` (Géradin & Cardona 2001, §4.8)."""
    return _mat9(_rm.right_jacobian, psi)


def right_jacobian_inverse(psi) -> np.ndarray:
    """``J_r(ψ)⁻¹``, finite for ``|ψ| < 2π``."""
    return _mat9(_rm.right_jacobian_inverse, psi)


def left_jacobian(psi) -> np.ndarray:
    """``J_l(ψ) = J_r(−ψ)``: ``exp((ψ + δψ)~) ≈ exp((J_l δψ)~) exp(ψ̃)``."""
    return right_jacobian(-np.asarray(psi, dtype=float))


class Rotation(ABC):
    """A finite rotation in one parametrisation.

    Subclasses provide:

    - ``matrix()`` → the rotation matrix ``A`` (body → inertial);
    - ``to_euler_parameters()`` → :class:`EulerParameters`;
    - ``from_matrix(A)`` (classmethod);
    - ``from_euler_parameters(q)`` (classmethod).

    Composition, inversion, application and conversion are common.
    """

    @abstractmethod
    def matrix(self) -> np.ndarray: ...

    @abstractmethod
    def to_euler_parameters(self) -> "EulerParameters": ...

    @classmethod
    @abstractmethod
    def from_matrix(cls, A) -> "Rotation": ...

    @classmethod
    @abstractmethod
    def from_euler_parameters(cls, q: "EulerParameters") -> "Rotation": ...

    def compose(self, other: "Rotation") -> "Rotation":
        """``self`` then ``other`` in the body frame of ``self``: ``A = A_self A_other``."""
        q = self.to_euler_parameters().product(other.to_euler_parameters())
        return type(self).from_euler_parameters(q)

    def __matmul__(self, other: "Rotation") -> "Rotation":
        return self.compose(other)

    def inverse(self) -> "Rotation":
        return type(self).from_euler_parameters(self.to_euler_parameters().conjugate())

    def apply(self, v) -> np.ndarray:
        """Inertial components of the body vector ``v``."""
        return self.matrix() @ np.asarray(v, dtype=float)

    def to(self, cls: type) -> "Rotation":
        """The same rotation in another parametrisation."""
        return cls.from_euler_parameters(self.to_euler_parameters())

    def angle(self) -> float:
        """Rotation angle in [0, π]."""
        return float(np.linalg.norm(self.to_euler_parameters().log()))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({np.array2string(self.as_array(), precision=6)})"

    @abstractmethod
    def as_array(self) -> np.ndarray: ...


class EulerParameters(Rotation):
    """Unit quaternion ``q = (e0, e)``, scalar first (Nikravesh 1988, §6.3).

    No singularity anywhere; ``q`` and ``−q`` are the same rotation.
    """

    def __init__(self, q=(1.0, 0.0, 0.0, 0.0)):
        q = np.asarray(q, dtype=float).reshape(4)
        n = np.linalg.norm(q)
        if not np.isfinite(n) or n == 0.0:
            raise ValueError(f"Euler parameters {q.tolist()} cannot be normalised")
        self.q = q / n

    def as_array(self) -> np.ndarray:
        return self.q.copy()

    def matrix(self) -> np.ndarray:
        return _mat9(_rm.rotation_matrix, self.q)

    def to_euler_parameters(self) -> "EulerParameters":
        return self

    @classmethod
    def from_euler_parameters(cls, q: "EulerParameters") -> "EulerParameters":
        return cls(q.q)

    @classmethod
    def from_matrix(cls, A) -> "EulerParameters":
        """Shepperd's method: divide by the largest of the four ``4 e_k²`` (robust at any angle)."""
        A = np.asarray(A, dtype=float)
        tr = np.trace(A)
        cands = np.array([tr, A[0, 0], A[1, 1], A[2, 2]])
        k = int(np.argmax(cands))
        if k == 0:
            e0 = 0.5 * np.sqrt(1.0 + tr)
            q = [e0, (A[2, 1] - A[1, 2]) / (4 * e0), (A[0, 2] - A[2, 0]) / (4 * e0), (A[1, 0] - A[0, 1]) / (4 * e0)]
        elif k == 1:
            e1 = 0.5 * np.sqrt(1.0 + 2 * A[0, 0] - tr)
            q = [(A[2, 1] - A[1, 2]) / (4 * e1), e1, (A[0, 1] + A[1, 0]) / (4 * e1), (A[0, 2] + A[2, 0]) / (4 * e1)]
        elif k == 2:
            e2 = 0.5 * np.sqrt(1.0 + 2 * A[1, 1] - tr)
            q = [(A[0, 2] - A[2, 0]) / (4 * e2), (A[0, 1] + A[1, 0]) / (4 * e2), e2, (A[1, 2] + A[2, 1]) / (4 * e2)]
        else:
            e3 = 0.5 * np.sqrt(1.0 + 2 * A[2, 2] - tr)
            q = [(A[1, 0] - A[0, 1]) / (4 * e3), (A[0, 2] + A[2, 0]) / (4 * e3), (A[1, 2] + A[2, 1]) / (4 * e3), e3]
        q = np.array(q)
        return cls(q if q[0] >= 0.0 else -q)

    def product(self, other: "EulerParameters") -> "EulerParameters":
        """``self ⊗ other``."""
        return EulerParameters(quaternion_product(self.q, other.q))

    def conjugate(self) -> "EulerParameters":
        return EulerParameters(self.q * np.array([1.0, -1.0, -1.0, -1.0]))

    def log(self) -> np.ndarray:
        """Rotation vector of the shortest branch, ``|ψ| ≤ π``."""
        out = np.empty(3)
        _rm.log_quaternion(self.q, out)
        return out

    def kinematic_rate(self, omega_body) -> np.ndarray:
        """``q̇ = ½ q ⊗ (0, ω)`` with ``ω`` in the body frame [1/s]."""
        return 0.5 * quaternion_product(self.q, np.concatenate([[0.0], np.asarray(omega_body, dtype=float)]))

    def cayley_update(self, omega_body, h: float) -> "EulerParameters":
        """One step of the trapezoidal rule for ``q̇ = ½ q ⊗ (0, ω)`` with ω held over the step.

        Closed form ``q ⊗ p``, ``p = (1 − h²|ω|²/16, (h/2) ω)/(1 + h²|ω|²/16)``
        (the Cayley map): exactly unit, equal to ``q ⊗ exp(hω)`` up to
        ``O((h|ω|)³)`` (paper §3.3; FORMULATION.md).
        """
        out = np.empty(4)
        _rm.cayley_update(self.q, np.asarray(omega_body, dtype=float), float(h), out)
        return EulerParameters(out)


class RotationVector(Rotation):
    """Rotation vector ``ψ = a n`` (angle × unit axis); ``A = exp(ψ̃)``.

    Kept on the shortest branch (``|ψ| ≤ π``) when built from another
    parametrisation.
    """

    def __init__(self, psi=(0.0, 0.0, 0.0)):
        self.psi = np.asarray(psi, dtype=float).reshape(3).copy()

    def as_array(self) -> np.ndarray:
        return self.psi.copy()

    def matrix(self) -> np.ndarray:
        return _mat9(_rm.exp_matrix, self.psi)

    def to_euler_parameters(self) -> EulerParameters:
        out = np.empty(4)
        _rm.exp_quaternion(self.psi, out)
        return EulerParameters(out)

    @classmethod
    def from_euler_parameters(cls, q: EulerParameters) -> "RotationVector":
        return cls(q.log())

    @classmethod
    def from_matrix(cls, A) -> "RotationVector":
        return cls.from_euler_parameters(EulerParameters.from_matrix(A))

    def tangent_operator(self) -> np.ndarray:
        """``J_r(ψ)``: body-frame angular velocity ``ω = J_r(ψ) ψ̇``."""
        return right_jacobian(self.psi)

    def tangent_operator_inverse(self) -> np.ndarray:
        """``J_r(ψ)⁻¹``: ``ψ̇ = J_r⁻¹ ω``."""
        return right_jacobian_inverse(self.psi)


class RodriguesParameters(Rotation):
    """Rodrigues (Gibbs) parameters ``g = tan(a/2) n``.

    ``A = I + 2/(1 + g·g) (g̃ + g̃²)``.  They are infinite at a half turn:
    building them from a rotation within ``1e-8`` rad of π raises ``ValueError``.
    """

    HALF_TURN_MARGIN = 1e-8

    def __init__(self, g=(0.0, 0.0, 0.0)):
        self.g = np.asarray(g, dtype=float).reshape(3).copy()
        if not np.all(np.isfinite(self.g)):
            raise ValueError("Rodrigues parameters must be finite")

    def as_array(self) -> np.ndarray:
        return self.g.copy()

    def matrix(self) -> np.ndarray:
        G = skew(self.g)
        return np.eye(3) + 2.0 / (1.0 + self.g @ self.g) * (G + G @ G)

    def to_euler_parameters(self) -> EulerParameters:
        return EulerParameters(np.concatenate([[1.0], self.g]))

    @classmethod
    def from_euler_parameters(cls, q: EulerParameters) -> "RodriguesParameters":
        e = q.q if q.q[0] >= 0.0 else -q.q
        half_angle = np.arctan2(np.linalg.norm(e[1:]), e[0])
        if np.pi / 2 - half_angle < cls.HALF_TURN_MARGIN / 2:
            raise ValueError(
                "Rodrigues parameters are infinite at a half turn (rotation angle π); "
                "use EulerParameters or RotationVector for this rotation"
            )
        return cls(e[1:] / e[0])

    @classmethod
    def from_matrix(cls, A) -> "RodriguesParameters":
        return cls.from_euler_parameters(EulerParameters.from_matrix(A))
