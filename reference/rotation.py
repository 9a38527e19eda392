"""Finite rotations and their parametrisations (paper §4.2.1, Fig. 3).

The paper's abstract ``Rotation`` class hides *how* a finite rotation is
stored; the derived classes here are :class:`EulerParameters` (the engine's
state: no singularity), :class:`RotationVector` (axis × angle, the exponential
map, used by the Beam2 strains) and :class:`RodriguesParameters` (the Gibbs
vector, infinite at a half turn).

Conventions of the whole project (stated here, once)
----------------------------------------------------
- **Skew matrix.** ``ã`` is the skew matrix of ``a``: ``ã b = a × b``
  (:func:`skew`, :func:`unskew`).
- **Euler parameters** ``q = (e0, e) = (e0, e1, e2, e3)``, **scalar first**,
  unit norm; ``q`` and ``−q`` are the same rotation.  For a rotation by the
  angle ``a`` about the unit axis ``n``: ``e0 = cos(a/2)``, ``e = sin(a/2) n``.
- **Rotation matrix** ``A(q) = (2 e0² − 1) I + 2 (e eᵀ + e0 ẽ)`` maps **body**
  components to **inertial** components: ``v_inertial = A v_body``.  Its
  columns are the body axes written in the inertial frame.
- **Quaternion product** ``q ⊗ p = (q0 p0 − q·p, q0 p + p0 q + q × p)``.
- **Composition order.** ``A(q ⊗ p) = A(q) A(p)``: the right factor ``p`` is a
  rotation expressed in the *body* frame of ``q`` (a body-frame, or material,
  increment); a left factor would be an inertial-frame (spatial) increment.
  ``R1 @ R2`` (:meth:`Rotation.compose`) has the matrix ``A1 A2``.  The time
  update of the engine is ``q_{n+1} = q_n ⊗ p(h ω)``.
- **Angular velocity** ``ω`` is in the **body** frame (Park et al. 1991):
  ``Ȧ = A ω̃`` and ``q̇ = ½ q ⊗ (0, ω)``.  The body-frame inertia is then
  constant, which is the point of Park's rotational equations.
- **Rotation vector** ``ψ = a n`` gives ``A = exp(ψ̃) = I + (sin a / a) ψ̃ +
  ((1 − cos a)/a²) ψ̃²``, ``a = |ψ|``; the logarithm returns the shortest branch,
  ``|ψ| ≤ π``.
- **Rodrigues (Gibbs) parameters** ``g = tan(a/2) n = e / e0``.
- **Units.** Angles in radians, angular velocities in rad/s, time in seconds.
  Euler parameters, Rodrigues parameters and matrices are dimensionless.

The scalar kernels (coefficient functions with their small-angle series,
exponential, logarithm, Jacobians, the Cayley update) are generated from sympy
in ``reference/generated/rotation_maps.py`` (source ``derivations/rotation_maps.py``);
this module is their readable, object-oriented face and the only place that
decides the conventions above.

Length: one class family of the paper (Fig. 3) with the project's conventions, kept in one
module (about 690 lines) so that the conventions are stated, and implemented, in one place.

References
----------
.. [GC] M. Géradin, A. Cardona, *Flexible Multibody Dynamics: A Finite Element
   Approach*, Wiley, 2001, ch. 4 (finite rotations, exponential map, tangent
   operator).
.. [Nik] P. E. Nikravesh, *Computer-Aided Analysis of Mechanical Systems*,
   Prentice-Hall, 1988, ch. 6 (Euler parameters).
.. [Park] K. C. Park, J. D. Downer, J. C. Chiou, C. Farhat, A modular multibody
   analysis capability for high precision, active control and real-time
   applications, *Int. J. Numer. Meth. Engng* 32 (1991) 1767–1798 (body-frame
   angular velocity, Euler-parameter update).
.. [Shep] S. W. Shepperd, Quaternion from rotation matrix, *J. Guidance and
   Control* 1 (1978) 223–224.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from reference.generated import rotation_maps as _rm

__all__ = [
    "skew", "unskew", "quaternion_product",
    "right_jacobian", "right_jacobian_inverse", "left_jacobian", "left_jacobian_inverse",
    "Rotation", "EulerParameters", "RotationVector", "RodriguesParameters",
]


def _vec(x, n: int, what: str) -> np.ndarray:
    """``x`` as a fresh contiguous float array of length ``n`` (checked finite)."""
    a = np.array(x, dtype=float).reshape(-1)
    if a.shape != (n,):
        raise ValueError(f"{what} must have {n} components, got shape {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be finite, got {a.tolist()}")
    return a


def _mat9(kernel, arg) -> np.ndarray:
    """Run a generated kernel that writes a row-major 3×3 matrix into ``out(9,)``."""
    out = np.empty(9)
    kernel(np.ascontiguousarray(arg, dtype=float), out)
    return out.reshape(3, 3)


def skew(v) -> np.ndarray:
    """Skew-symmetric matrix of a 3-vector.

    Parameters
    ----------
    v : array_like, shape (3,)
        Vector ``v`` (any units).

    Returns
    -------
    ndarray, shape (3, 3)
        ``ṽ`` such that ``ṽ b = v × b`` for every ``b``.

    References
    ----------
    Nikravesh (1988), §2 (the "tilde" operator).
    """
    v = _vec(v, 3, "skew: v")
    return np.array([[0.0, -v[2], v[1]],
                     [v[2], 0.0, -v[0]],
                     [-v[1], v[0], 0.0]])


def unskew(S) -> np.ndarray:
    """Axial vector of the skew-symmetric part of a 3×3 matrix.

    Parameters
    ----------
    S : array_like, shape (3, 3)
        Matrix; its symmetric part is ignored.

    Returns
    -------
    ndarray, shape (3,)
        ``v`` with ``ṽ = (S − Sᵀ)/2``; ``unskew(skew(v)) = v``.
    """
    S = np.asarray(S, dtype=float)
    if S.shape != (3, 3):
        raise ValueError(f"unskew: S must be 3×3, got shape {S.shape}")
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def quaternion_product(p, q) -> np.ndarray:
    """Quaternion product ``p ⊗ q`` (scalar first), by the generated kernel.

    Parameters
    ----------
    p, q : array_like, shape (4,)
        Left and right factors (need not be unit).

    Returns
    -------
    ndarray, shape (4,)
        ``(p0 q0 − p·q, p0 q + q0 p + p × q)``.  For unit factors
        ``A(p ⊗ q) = A(p) A(q)``.

    References
    ----------
    Nikravesh (1988), ch. 6; Géradin & Cardona (2001), ch. 4.
    """
    out = np.empty(4)
    _rm.quat_product(_vec(p, 4, "quaternion p"), _vec(q, 4, "quaternion q"), out)
    return out


def right_jacobian(psi) -> np.ndarray:
    """Right Jacobian (tangent operator) of the exponential map of SO(3).

    ``J_r(ψ) = I − ((1 − cos a)/a²) ψ̃ + ((a − sin a)/a³) ψ̃²``, ``a = |ψ|``, with
    series-switched coefficients near ``a = 0``.  It relates a change of the
    rotation vector to a body-frame (right) rotation increment,

        ``exp((ψ + δψ)~) = exp(ψ̃) exp((J_r(ψ) δψ)~) + O(|δψ|²)``,

    and so the body-frame angular velocity to the rate of ``ψ``:
    ``ω = J_r(ψ) ψ̇``.  It is the operator ``T(ψ)`` of Géradin & Cardona.

    Parameters
    ----------
    psi : array_like, shape (3,)
        Rotation vector [rad].

    Returns
    -------
    ndarray, shape (3, 3)
        ``J_r(ψ)`` (dimensionless); singular at ``|ψ| = 2π, 4π, …``.

    References
    ----------
    Géradin & Cardona (2001), ch. 4 (tangent operator).
    """
    return _mat9(_rm.right_jacobian, _vec(psi, 3, "rotation vector"))


def right_jacobian_inverse(psi) -> np.ndarray:
    """Inverse right Jacobian ``J_r(ψ)⁻¹ = I + ψ̃/2 + ((1 − (a/2) cot(a/2))/a²) ψ̃²``.

    Parameters
    ----------
    psi : array_like, shape (3,)
        Rotation vector [rad], ``|ψ| < 2π``.

    Returns
    -------
    ndarray, shape (3, 3)
        ``J_r(ψ)⁻¹``: ``ψ̇ = J_r⁻¹ ω`` (ω in the body frame).

    References
    ----------
    Géradin & Cardona (2001), ch. 4.
    """
    return _mat9(_rm.right_jacobian_inverse, _vec(psi, 3, "rotation vector"))


def left_jacobian(psi) -> np.ndarray:
    """Left Jacobian ``J_l(ψ) = J_r(−ψ) = J_r(ψ)ᵀ``.

    ``exp((ψ + δψ)~) = exp((J_l(ψ) δψ)~) exp(ψ̃) + O(|δψ|²)``: the inertial-frame
    (spatial) increment, and the inertial angular velocity ``A ω = J_l(ψ) ψ̇``.

    Parameters
    ----------
    psi : array_like, shape (3,)
        Rotation vector [rad].

    Returns
    -------
    ndarray, shape (3, 3)

    References
    ----------
    Géradin & Cardona (2001), ch. 4 (the transpose ``Tᵀ(ψ)``).
    """
    return right_jacobian(-_vec(psi, 3, "rotation vector"))


def left_jacobian_inverse(psi) -> np.ndarray:
    """Inverse left Jacobian ``J_l(ψ)⁻¹ = J_r(−ψ)⁻¹``, finite for ``|ψ| < 2π``.

    Parameters
    ----------
    psi : array_like, shape (3,)
        Rotation vector [rad].

    Returns
    -------
    ndarray, shape (3, 3)
    """
    return right_jacobian_inverse(-_vec(psi, 3, "rotation vector"))


class Rotation(ABC):
    """A finite rotation, in one parametrisation (paper §4.2.1, Fig. 3).

    A subclass must provide

    - ``matrix()`` → the rotation matrix ``A`` (3×3, body → inertial);
    - ``to_euler_parameters()`` → the same rotation as :class:`EulerParameters`;
    - classmethod ``from_matrix(R)`` → the rotation of a proper orthogonal ``R``;
    - classmethod ``from_euler_parameters(q)`` → the rotation of an
      :class:`EulerParameters` instance;

    and may override ``as_array()`` (its own parameters, used by ``__repr__``;
    the default returns the Euler parameters).

    The base class implements, in terms of these, composition
    (:meth:`compose`, ``@``), :meth:`inverse`, :meth:`apply`, conversion
    :meth:`to`, :meth:`angle` and ``__repr__``.  Composition and inversion go
    through Euler parameters (exact group operations, no singularity) and
    return the parametrisation of ``self``.

    Instances are treated as immutable: every operation returns a new object.
    """

    @abstractmethod
    def matrix(self) -> np.ndarray:
        """Rotation matrix ``A`` (body → inertial components), shape (3, 3)."""

    @abstractmethod
    def to_euler_parameters(self) -> "EulerParameters":
        """The same rotation as unit Euler parameters."""

    @classmethod
    @abstractmethod
    def from_matrix(cls, R) -> "Rotation":
        """The rotation whose matrix is ``R`` (proper orthogonal)."""

    @classmethod
    @abstractmethod
    def from_euler_parameters(cls, q: "EulerParameters") -> "Rotation":
        """The rotation described by the Euler parameters ``q``."""

    def as_array(self) -> np.ndarray:
        """The parameters of this parametrisation (a copy); default: Euler parameters."""
        return self.to_euler_parameters().q.copy()

    def compose(self, other: "Rotation") -> "Rotation":
        """Composition with ``A = A_self A_other``.

        ``other`` is a rotation expressed in the body frame of ``self`` (it is
        applied first to body vectors).  Computed as the quaternion product
        ``q_self ⊗ q_other``.

        Parameters
        ----------
        other : Rotation
            Any parametrisation.

        Returns
        -------
        Rotation
            In the parametrisation of ``self``.
        """
        if not isinstance(other, Rotation):
            raise TypeError(f"cannot compose a rotation with {type(other).__name__}")
        q = self.to_euler_parameters().product(other.to_euler_parameters())
        return type(self).from_euler_parameters(q)

    def __matmul__(self, other: "Rotation") -> "Rotation":
        """``self @ other`` is :meth:`compose`: matrix ``A_self A_other``."""
        if not isinstance(other, Rotation):
            return NotImplemented
        return self.compose(other)

    def inverse(self) -> "Rotation":
        """The inverse rotation, matrix ``Aᵀ`` (conjugate Euler parameters)."""
        return type(self).from_euler_parameters(self.to_euler_parameters().conjugate())

    def apply(self, v) -> np.ndarray:
        """Inertial components of body-frame vector(s): ``A v``.

        Parameters
        ----------
        v : array_like, shape (3,) or (..., 3)
            Body components (any units).

        Returns
        -------
        ndarray, same shape as ``v``
            Inertial components.
        """
        v = np.asarray(v, dtype=float)
        if v.shape[-1:] != (3,):
            raise ValueError(f"apply: vectors must have 3 components, got shape {v.shape}")
        return v @ self.matrix().T

    def to(self, cls: type) -> "Rotation":
        """The same rotation in another parametrisation ``cls`` (a Rotation subclass)."""
        if not (isinstance(cls, type) and issubclass(cls, Rotation)):
            raise TypeError(f"to(): {cls!r} is not a Rotation subclass")
        return cls.from_euler_parameters(self.to_euler_parameters())

    def angle(self) -> float:
        """Rotation angle ``a ∈ [0, π]`` [rad] (shortest branch).

        ``a = 2 atan2(|e|, |e0|)``: accurate near 0 and near π alike (no
        ``arccos`` of the trace).
        """
        q = self.to_euler_parameters().q
        return float(2.0 * np.arctan2(np.linalg.norm(q[1:]), abs(q[0])))

    def __repr__(self) -> str:
        vals = ", ".join(repr(float(x)) for x in self.as_array())
        return f"{type(self).__name__}([{vals}])"


ORTHOGONALITY_TOLERANCE = 1e-3
"""Largest ``|RᵀR − I|`` of a matrix taken as a rotation: it accepts matrices of other solvers whose
Euler parameters are normalised only to a Newton tolerance, and rejects garbage."""


def _check_rotation_matrix(R) -> np.ndarray:
    """``R`` as a float 3×3 array, rejecting non-finite, reflected or far-from-orthogonal input
    (``|RᵀR − I|`` above :data:`ORTHOGONALITY_TOLERANCE`, or det ≤ 0, which Shepperd's method
    would silently turn into some rotation; :func:`check_rotation_matrices`).
    """
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3):
        raise ValueError(f"a rotation matrix must be 3×3, got shape {R.shape}")
    return check_rotation_matrices(R[None])[0]


def check_rotation_matrices(R: np.ndarray) -> np.ndarray:
    """:func:`_check_rotation_matrix` of K matrices ``R`` (K, 3, 3) at once, naming the first bad one."""
    if not np.all(np.isfinite(R)):
        raise ValueError("a rotation matrix must be finite")
    err = np.max(np.abs(np.matmul(R.transpose(0, 2, 1), R) - np.eye(3)), axis=(1, 2))
    det = np.linalg.det(R)
    bad = np.flatnonzero((err > ORTHOGONALITY_TOLERANCE) | (det <= 0.0))
    if bad.size:
        raise ValueError(f"not a proper rotation matrix (|RᵀR − I| = {err[bad[0]]:.3g}, det = {det[bad[0]]:.6g})")
    return R


def shepperd(R: np.ndarray) -> np.ndarray:
    """Euler parameters (K, 4), ``e0 ≥ 0``, of K proper orthogonal matrices ``R`` (K, 3, 3) by Shepperd's
    method (:meth:`EulerParameters.from_matrix`, which normalises them), not yet normalised.

    Of ``4e0² = 1 + tr R`` and ``4ek² = 1 + 2 R_kk − tr R`` the largest (≥ 1) is taken by a square root;
    the other three follow from the symmetric and antisymmetric parts of ``R`` divided by it (Shepperd
    1978).  Each matrix takes its own branch, with the arithmetic of one matrix at a time.
    """
    tr = R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2]
    branch = np.argmax(np.stack([tr, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1), axis=1)
    q = np.empty((len(R), 4))
    for k in range(4):
        m = branch == k
        A, t = R[m], tr[m]
        s = 2.0 * np.sqrt(1.0 + t) if k == 0 else 2.0 * np.sqrt(1.0 + 2.0 * A[:, k - 1, k - 1] - t)  # = 4 e_k
        anti = [(A[:, 2, 1] - A[:, 1, 2]) / s, (A[:, 0, 2] - A[:, 2, 0]) / s, (A[:, 1, 0] - A[:, 0, 1]) / s]
        sym = {(1, 2): A[:, 0, 1] + A[:, 1, 0], (1, 3): A[:, 0, 2] + A[:, 2, 0], (2, 3): A[:, 1, 2] + A[:, 2, 1]}
        for j in range(4):
            if j == k:
                q[m, j] = 0.25 * s
            elif 0 in (j, k):
                q[m, j] = anti[j + k - 1]
            else:
                q[m, j] = sym[min(j, k), max(j, k)] / s
    return np.where(q[:, :1] >= 0.0, q, -q)


class EulerParameters(Rotation):
    """Unit quaternion ``q = (e0, e1, e2, e3)``, scalar first.

    ``e0 = cos(a/2)``, ``e = sin(a/2) n`` for the angle ``a`` about the unit
    axis ``n``.  No singularity anywhere; ``q`` and ``−q`` are the same
    rotation.  This is the orientation state of every node.

    Parameters
    ----------
    q : array_like, shape (4,), optional
        Euler parameters (dimensionless); normalised on construction.  Default:
        the identity ``(1, 0, 0, 0)``.

    Attributes
    ----------
    q : ndarray, shape (4,)
        The unit Euler parameters, scalar first, as given (the sign is not
        changed: continuity in time matters more than ``e0 ≥ 0``).

    References
    ----------
    Nikravesh (1988), ch. 6; Géradin & Cardona (2001), ch. 4.
    """

    def __init__(self, q=(1.0, 0.0, 0.0, 0.0)):
        q = _vec(q, 4, "Euler parameters")
        n = np.linalg.norm(q)
        if n == 0.0:
            raise ValueError("Euler parameters (0, 0, 0, 0) cannot be normalised")
        self.q = q / n

    def as_array(self) -> np.ndarray:
        return self.q.copy()

    def matrix(self) -> np.ndarray:
        """``A(q) = (2 e0² − 1) I + 2 (e eᵀ + e0 ẽ)`` (body → inertial), by the generated kernel."""
        return _mat9(_rm.rotation_matrix, self.q)

    rotation_matrix = matrix

    def to_euler_parameters(self) -> "EulerParameters":
        return self

    @classmethod
    def from_euler_parameters(cls, q: "EulerParameters") -> "EulerParameters":
        return cls(q.q)

    @classmethod
    def from_matrix(cls, R) -> "EulerParameters":
        """Euler parameters of a rotation matrix by Shepperd's method.

        Of ``4e0² = 1 + tr R`` and ``4ek² = 1 + 2 R_kk − tr R`` the largest
        (≥ 1) is taken by a square root; the other three follow from the
        symmetric and antisymmetric parts of ``R`` divided by it.  No division
        by a small number, so it is accurate at every angle, near 0 and π
        included.

        Parameters
        ----------
        R : array_like, shape (3, 3)
            Proper orthogonal matrix (body → inertial).

        Returns
        -------
        EulerParameters
            With ``e0 ≥ 0`` (shortest branch).

        References
        ----------
        Shepperd (1978); Géradin & Cardona (2001), ch. 4.
        """
        return cls(shepperd(_check_rotation_matrix(R)[None])[0])

    def product(self, other: "EulerParameters") -> "EulerParameters":
        """Quaternion product ``self ⊗ other``: matrix ``A_self A_other``.

        Parameters
        ----------
        other : EulerParameters
            Right factor: a rotation expressed in the body frame of ``self``.

        Returns
        -------
        EulerParameters
        """
        if not isinstance(other, EulerParameters):
            raise TypeError(f"product(): expected EulerParameters, got {type(other).__name__}")
        return EulerParameters(quaternion_product(self.q, other.q))

    def __mul__(self, other: "EulerParameters") -> "EulerParameters":
        """``p * q`` is the quaternion product ``p ⊗ q`` (only between EulerParameters)."""
        if not isinstance(other, EulerParameters):
            return NotImplemented
        return self.product(other)

    def conjugate(self) -> "EulerParameters":
        """``(e0, −e)``: the inverse rotation, matrix ``Aᵀ``."""
        return EulerParameters(self.q * np.array([1.0, -1.0, -1.0, -1.0]))

    def log(self) -> np.ndarray:
        """Rotation vector of the shortest branch [rad], ``|ψ| ≤ π``, by the generated kernel.

        ``ψ = 2 (b / sin b) σ e`` with ``σ = sign(e0)`` and the half angle
        ``b = atan2(|e|, σ e0) ∈ [0, π/2]``: accurate near 0 (series of
        ``b/sin b``) and near π (``atan2``, no ``arccos``).
        """
        out = np.empty(3)
        _rm.log_quaternion(self.q, out)
        return out

    def kinematic_rate(self, omega_body) -> np.ndarray:
        """Time derivative of the Euler parameters, ``q̇ = ½ q ⊗ (0, ω)``.

        Parameters
        ----------
        omega_body : array_like, shape (3,)
            Angular velocity in the body frame [rad/s].

        Returns
        -------
        ndarray, shape (4,)
            ``q̇`` [1/s]; ``q·q̇ = 0`` and ``Ȧ = A ω̃``.

        References
        ----------
        Nikravesh (1988), ch. 6; Park et al. (1991).
        """
        w = _vec(omega_body, 3, "angular velocity")
        return 0.5 * quaternion_product(self.q, np.concatenate([[0.0], w]))

    def cayley_update(self, omega_body, h: float) -> "EulerParameters":
        """One trapezoidal step of ``q̇ = ½ q ⊗ (0, ω)`` with ``ω`` held over the step.

        The trapezoidal rule has the closed form ``q_new = q ⊗ p`` with the
        Cayley factor ``p = (1 − h²|ω|²/16, (h/2) ω) / (1 + h²|ω|²/16)``:
        exactly unit (the constructor renormalises only against round-off),
        a rotation about ``ω`` by ``4 atan(h|ω|/4) = h|ω| − (h|ω|)³/48 + …``,
        hence equal to the exact ``q ⊗ exp(hω)`` up to ``O((h|ω|)³)``.

        Parameters
        ----------
        omega_body : array_like, shape (3,)
            Body-frame angular velocity over the step [rad/s].
        h : float
            Time step [s].

        Returns
        -------
        EulerParameters
            The orientation at the end of the step (a new object).

        References
        ----------
        Park et al. (1991); paper §3.3; docs/formulation.md §8 "Euler parameters by the
        trapezoidal rule".
        """
        w = _vec(omega_body, 3, "angular velocity")
        return EulerParameters(np.array(_rm.cayley_update_scalars(*self.q, *w, float(h))))


class RotationVector(Rotation):
    """Rotation vector ``ψ = a n`` (angle × unit axis), ``A = exp(ψ̃)``.

    ``exp(ψ̃) = I + (sin a / a) ψ̃ + ((1 − cos a)/a²) ψ̃²``, ``a = |ψ|``, with
    series-switched coefficients near ``a = 0``.  Any ``ψ`` may be stored;
    built from another parametrisation it is the shortest branch ``|ψ| ≤ π``
    (at exactly π, ``ψ`` and ``−ψ`` are the same rotation and either may come
    back).

    Parameters
    ----------
    psi : array_like, shape (3,), optional
        Rotation vector [rad]; default zero.

    Attributes
    ----------
    psi : ndarray, shape (3,)

    Notes
    -----
    The right Jacobian (:meth:`tangent_operator`) linearises the map in the
    body frame: ``exp((ψ + δψ)~) ≈ exp(ψ̃) exp((J_r(ψ) δψ)~)``; the left one in
    the inertial frame: ``exp((ψ + δψ)~) ≈ exp((J_l(ψ) δψ)~) exp(ψ̃)``,
    ``J_l(ψ) = J_r(−ψ)``.

    References
    ----------
    Géradin & Cardona (2001), ch. 4; Cardona & Géradin, IJNME 26 (1988).
    """

    def __init__(self, psi=(0.0, 0.0, 0.0)):
        self.psi = _vec(psi, 3, "rotation vector")

    def as_array(self) -> np.ndarray:
        return self.psi.copy()

    def matrix(self) -> np.ndarray:
        """``exp(ψ̃)`` by the generated kernel."""
        return _mat9(_rm.exp_matrix, self.psi)

    def to_euler_parameters(self) -> EulerParameters:
        """``(cos(a/2), (sin(a/2)/a) ψ)`` by the generated kernel."""
        out = np.empty(4)
        _rm.exp_quaternion(self.psi, out)
        return EulerParameters(out)

    @classmethod
    def from_euler_parameters(cls, q: EulerParameters) -> "RotationVector":
        """The logarithm, shortest branch (:meth:`EulerParameters.log`)."""
        return cls(q.log())

    @classmethod
    def from_matrix(cls, R) -> "RotationVector":
        """The logarithm of ``R`` via Shepperd's Euler parameters (accurate near 0 and π)."""
        return cls.from_euler_parameters(EulerParameters.from_matrix(R))

    def tangent_operator(self) -> np.ndarray:
        """Right Jacobian ``J_r(ψ)``: ``ω = J_r ψ̇`` (body frame); see :func:`right_jacobian`."""
        return right_jacobian(self.psi)

    def tangent_operator_inverse(self) -> np.ndarray:
        """``J_r(ψ)⁻¹``: ``ψ̇ = J_r⁻¹ ω``; finite for ``|ψ| < 2π``."""
        return right_jacobian_inverse(self.psi)

    def left_tangent_operator(self) -> np.ndarray:
        """Left Jacobian ``J_l(ψ) = J_r(−ψ)``: ``A ω = J_l ψ̇`` (inertial frame)."""
        return left_jacobian(self.psi)

    def left_tangent_operator_inverse(self) -> np.ndarray:
        """``J_l(ψ)⁻¹ = J_r(−ψ)⁻¹``."""
        return left_jacobian_inverse(self.psi)


class RodriguesParameters(Rotation):
    """Rodrigues (Gibbs) parameters ``g = tan(a/2) n = e / e0``.

    ``A = I + 2/(1 + g·g) (g̃ + g̃²)``.  They are infinite at a half turn
    (``a = π``): a rotation within :attr:`HALF_TURN_MARGIN` (1e-8 rad) of π is
    refused with a ``ValueError``, on construction from parameters, from Euler
    parameters or from a matrix.

    Parameters
    ----------
    g : array_like, shape (3,), optional
        Gibbs vector (dimensionless); default zero.

    Attributes
    ----------
    g : ndarray, shape (3,)

    References
    ----------
    Géradin & Cardona (2001), ch. 4; Ibrahimbegovic, CMAME 149 (1997).
    """

    HALF_TURN_MARGIN = 1e-8  # [rad]

    @classmethod
    def _refuse_half_turn(cls, distance_to_pi: float) -> None:
        if distance_to_pi < cls.HALF_TURN_MARGIN:
            raise ValueError(
                f"Rodrigues parameters are infinite at a half turn: this rotation is "
                f"{distance_to_pi:.3g} rad from π (margin {cls.HALF_TURN_MARGIN:g} rad); "
                "use EulerParameters or RotationVector for rotations near π"
            )

    def __init__(self, g=(0.0, 0.0, 0.0)):
        g = _vec(g, 3, "Rodrigues parameters")
        # π − a = π − 2 atan|g| = 2 atan2(1, |g|), without cancellation
        self._refuse_half_turn(2.0 * np.arctan2(1.0, np.linalg.norm(g)))
        self.g = g

    def as_array(self) -> np.ndarray:
        return self.g.copy()

    def matrix(self) -> np.ndarray:
        """``I + 2/(1 + g·g) (g̃ + g̃²)``."""
        G = skew(self.g)
        return np.eye(3) + (2.0 / (1.0 + self.g @ self.g)) * (G + G @ G)

    def to_euler_parameters(self) -> EulerParameters:
        """``(1, g)/√(1 + g·g)``."""
        return EulerParameters(np.concatenate([[1.0], self.g]))

    @classmethod
    def from_euler_parameters(cls, q: EulerParameters) -> "RodriguesParameters":
        """``g = e / e0`` (sign of ``q`` irrelevant); ``ValueError`` near a half turn."""
        e = q.q if q.q[0] >= 0.0 else -q.q
        # π − a = π − 2 atan2(|e|, e0) = 2 atan2(e0, |e|), accurate where e0 → 0
        cls._refuse_half_turn(2.0 * np.arctan2(e[0], np.linalg.norm(e[1:])))
        return cls(e[1:] / e[0])

    @classmethod
    def from_matrix(cls, R) -> "RodriguesParameters":
        """Via Shepperd's Euler parameters; ``ValueError`` near a half turn."""
        return cls.from_euler_parameters(EulerParameters.from_matrix(R))
