"""Force elements: springs, dampers and bushings between bodies (the paper's loads between bodies).

A force element connects body i to body j (a rigid body or a beam node) or to
the ground.  Like a joint (:mod:`reference.joints.joint`) it is defined in the
inertial frame at t = 0 by points and a frame stored body-fixed on both
bodies, and it is evaluated with the same derived primitives
with measures derived in sympy (``derivations/forces.py`` →
``reference/generated/forces.py``) from the relative displacement
``d = x_j + A_j s_j − x_i − A_i s_i`` and the projections of the two bodies'
frame vectors on each other, with their exact Jacobian ``B`` with respect to
``[v_i, ω_i, v_j, ω_j]`` (ω in the body frames) and its tangent.

Each element has one or six **measures** ``e(x, q)`` with Jacobian
``B_e = ∂ė/∂V`` (a combination of primitive rows), a stiffness ``k`` and a
damping ``c`` per measure, and a rest value ``e_0``; its generalised force on
the two nodes is::

    f = −B_eᵀ (k (e − e_0) + c B_e V)

its energy ``½ k (e − e_0)²`` (added to the strain energy) and its dissipation
rate ``c (B_e V)²`` (added to the dissipated energy).  The elastic force is the
exact gradient of the energy, so the explicit scheme's energy balance holds
with springs to its own accuracy.

=============  ===========================================================  ========
kind           measure                                                      measures
=============  ===========================================================  ========
point_to_point  ℓ = |d|, the distance between the two points (N = k(ℓ − ℓ0)   1
               + c ℓ̇ + f_a(t), positive in tension)
rotational     φ = atan2(u1_i·u2_j, u1_i·u1_j): the rotation of body i       1
               relative to body j about the axis u3, measured like the
               rotation drive's and continued through ±π (not wrapped)
bushing        d in body i's frame (u1_i·d, u2_i·d, u3_i·d) and the          6
               rotation of body j relative to body i, θ = ½ vee(R − Rᵀ),
               R_ab = u_a,i·u_b,j (the axial vector of the skew part of the
               relative rotation: sin|θ| along the rotation axis, equal to
               the rotation vector up to third order)
=============  ===========================================================  ========

The continuous angle of a rotational spring is carried in the state
(``State.angle``): each evaluation adds to the last angle the wrapped
difference to the new one, which is exact while the relative rotation changes
by less than π per evaluation.

All compiled work is in :func:`force_element_forces`, which every algorithm
calls, and :func:`force_element_tangent` (stiffness and damping matrices of
one element, for implicit algorithms); an actuator force along a
point-to-point line is an external load (its work counts as external work).
"""

from __future__ import annotations

import math
from abc import ABC
from dataclasses import dataclass, field

import numpy as np

from reference.generated import forces as generated
from reference.interactions import TimeFunction, tf_value
from reference.jit import inlined, kernel
from reference.joints.assembly import GROUND_Q, GROUND_X
from reference.joints.joint import joint_frame
from reference.rotation import EulerParameters

POINT_TO_POINT, ROTATIONAL, BUSHING = 0, 1, 2
KINDS = {"point_to_point": POINT_TO_POINT, "rotational": ROTATIONAL, "bushing": BUSHING}


@inlined
def _measures(model, x, q, k, e, B):
    """Measures ``e`` and Jacobian ``B`` (row-major, 12 columns) of element k; returns their number.

    A point-to-point element's generated d becomes ℓ = |d|, a rotational
    element's raw pair (r sin φ, r cos φ) the wrapped angle φ = atan2, with their
    Jacobians by the chain rule; the ground's columns are zeroed.
    """
    i, j = model.fe_i[k], model.fe_j[k]
    par = model.fe_par[k]
    kind = model.fe_kind[k]
    xj, qj = GROUND_X, GROUND_Q
    if j >= 0:
        xj, qj = x[j], q[j]
    m = 6
    if kind == POINT_TO_POINT:
        # generated: d and its Jacobian; here ℓ = |d| and B_ℓ = (d/ℓ)ᵀ B_d
        generated.point_to_point_measures(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], e, B)
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        for col in range(12):
            B[col] = (e[0] * B[col] + e[1] * B[12 + col] + e[2] * B[24 + col]) / length if length > 0.0 else 0.0
        e[0] = length
        m = 1
    elif kind == ROTATIONAL:
        generated.rotational_measures(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], e, B)
        sn, cs = e[0], e[1]
        r2 = sn * sn + cs * cs
        e[0] = math.atan2(sn, cs)
        for col in range(12):
            B[col] = (cs * B[col] - sn * B[12 + col]) / r2
        m = 1
    else:
        generated.bushing_measures(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], e, B)
    if j < 0:
        for r in range(m):
            for col in range(6, 12):
                B[12 * r + col] = 0.0
    return m


@inlined
def _rate(B, r, v, w, i, j):
    """``(B V)_r`` with V = [v_i, ω_i, v_j, ω_j]."""
    acc = 0.0
    for a in range(3):
        acc += B[12 * r + a] * v[i, a] + B[12 * r + 3 + a] * w[i, a]
        if j >= 0:
            acc += B[12 * r + 6 + a] * v[j, a] + B[12 * r + 9 + a] * w[j, a]
    return acc


@inlined
def _spread(B, r, f, i, j, F):
    """``F −= B_rᵀ f`` on nodes i and j (inertial force, body moment)."""
    for a in range(6):
        F[i, a] -= f * B[12 * r + a]
        if j >= 0:
            F[j, a] -= f * B[12 * r + 6 + a]


@inlined
def _continuous(angle, k, raw):
    """The last angle plus the wrapped difference to ``raw``."""
    d = raw - angle[k]
    d -= 2.0 * math.pi * math.floor(d / (2.0 * math.pi) + 0.5)
    return angle[k] + d


@inlined
def force_element_forces(model, x, q, v, w, t, angle, F, F_ext, e, B):
    """Forces of all force elements at one configuration; returns ``(energy, dissipation rate)``.

    Parameters
    ----------
    model : Model
        ``fe_*`` fields (see :class:`reference.state.Model`).
    x, q, v, w : arrays (N,3), (N,4), (N,3), (N,3)
        Positions, Euler parameters, inertial and body-frame velocities.
    t : float
        Time [s] (actuator force functions).
    angle : array (F,)
        Continuous angles of the rotational springs, updated in place.
    F : array (N,6)
        The spring and damper forces are **added** (inertial force, body moment).
    F_ext : array (N,6)
        The actuator forces are added here (external loads; may be ``F`` itself).
    e, B : arrays (≥ 6,), (≥ 72,)
        Work arrays.

    Returns
    -------
    energy : float
        ``Σ ½ k (e − e_0)²`` [J].
    dissipation : float
        ``Σ c (B_e V)²`` [W], ≥ 0 (an explicit step books
        :func:`force_element_dissipation` instead).
    """
    energy = 0.0
    dissipation = 0.0
    for k in range(model.fe_kind.shape[0]):
        i, j = model.fe_i[k], model.fe_j[k]
        kind = model.fe_kind[k]
        m = _measures(model, x, q, k, e, B)
        if kind == ROTATIONAL:
            e[0] = _continuous(angle, k, e[0])
            angle[k] = e[0]
        elif kind == POINT_TO_POINT and e[0] <= 0.0:
            continue  # coincident points: no direction (the deck refuses a zero rest length)
        for r in range(m):
            stretch = e[r] - (model.fe_rest[k] if m == 1 else 0.0)
            rate = _rate(B, r, v, w, i, j)
            energy += 0.5 * model.fe_k[k, r] * stretch * stretch
            dissipation += model.fe_c[k, r] * rate * rate
            _spread(B, r, model.fe_k[k, r] * stretch + model.fe_c[k, r] * rate, i, j, F)
        tf = model.fe_tf[k]
        if tf >= 0:
            _spread(B, 0, tf_value(model.tf_kind[tf], model.tf_par[tf], t), i, j, F_ext)
    return energy, dissipation


@inlined
def force_element_dissipation(model, x, q, v, w, v_new, w_new, e, B):
    """Work rate of the dampers over a kick: ``Σ c (B_e V⁻)·(B_e V̄)``, ``V̄ = ½(V⁻ + V⁺)`` [W].

    The damper force of an explicit step is evaluated at the old velocity V⁻;
    the kinetic energy changes by the kick length times the force times the
    mean velocity V̄, so this is the energy the dampers remove in that step
    (exact for the scheme).
    """
    total = 0.0
    for k in range(model.fe_kind.shape[0]):
        damped = False
        for r in range(6):
            damped = damped or model.fe_c[k, r] != 0.0
        if not damped:
            continue
        i, j = model.fe_i[k], model.fe_j[k]
        m = _measures(model, x, q, k, e, B)
        for r in range(m):
            old = _rate(B, r, v, w, i, j)
            new = _rate(B, r, v_new, w_new, i, j)
            total += model.fe_c[k, r] * old * 0.5 * (old + new)
    return total


@kernel
def force_element_tangent(model, x, q, v, w, angle, k, K, C, e, B, G):
    """Tangent stiffness and damping matrices of force element k (for implicit algorithms).

    ``K`` (12,12) ``= −∂f/∂δ`` and ``C`` (12,12) ``= −∂f/∂V`` of the element's
    generalised force ``f = −Bᵀ s``, ``s = k (e − e0) + c B V``, with respect to
    body-frame increments ``δ = [δx_i, δθ_i, δx_j, δθ_j]`` and velocities
    ``V = [v_i, ω_i, v_j, ω_j]``: ``K = Bᵀ diag(k) B + Bᵀ diag(c) (G·V) + Σ_r s_r G_r``,
    ``C = Bᵀ diag(c) B`` (``G`` the derived tangent of B, derivations/forces.py).
    The ground's rows and columns are zero.  ``e``, ``B``, ``G`` are work arrays
    (≥ 6, ≥ 72, ≥ 864); ``angle`` is read, not updated.
    """
    i, j = model.fe_i[k], model.fe_j[k]
    par = model.fe_par[k]
    kind = model.fe_kind[k]
    xj, qj = GROUND_X, GROUND_Q
    if j >= 0:
        xj, qj = x[j], q[j]
    if kind == POINT_TO_POINT:
        # chain rule through ℓ = |d|: G_ℓ = (Σ d_k G_k + Σ B_k ⊗ B_k)/ℓ − B_ℓ ⊗ B_ℓ/ℓ
        generated.point_to_point_tangent(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], G)
        generated.point_to_point_measures(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], e, B)
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        for a in range(12):
            bl_a = (e[0] * B[a] + e[1] * B[12 + a] + e[2] * B[24 + a]) / length
            for c in range(12):
                bl_c = (e[0] * B[c] + e[1] * B[12 + c] + e[2] * B[24 + c]) / length
                g = 0.0
                for kk in range(3):
                    g += e[kk] * G[144 * kk + 12 * a + c] + B[12 * kk + a] * B[12 * kk + c]
                G[12 * a + c] = (g - bl_a * bl_c) / length
    elif kind == ROTATIONAL:
        # chain rule through φ = atan2(s, c): G_φ from the tangents of s and c
        generated.rotational_tangent(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], G)
        generated.rotational_measures(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], e, B)
        sn, cs = e[0], e[1]
        r2 = sn * sn + cs * cs
        for a in range(12):
            bphi = (cs * B[a] - sn * B[12 + a]) / r2
            for c in range(12):
                g = (B[12 + c] * B[a] + cs * G[12 * a + c] - B[c] * B[12 + a] - sn * G[144 + 12 * a + c]) / r2
                G[12 * a + c] = g - bphi * 2.0 * (sn * B[c] + cs * B[12 + c]) / r2
    else:
        generated.bushing_tangent(x[i], q[i], xj, qj, par[0:3], par[3:6], par[6:15], par[15:24], G)
    m = _measures(model, x, q, k, e, B)
    if kind == ROTATIONAL:
        e[0] = _continuous(angle, k, e[0])
    K[:, :] = 0.0
    C[:, :] = 0.0
    for r in range(m):
        stretch = e[r] - (model.fe_rest[k] if m == 1 else 0.0)
        sr = model.fe_k[k, r] * stretch + model.fe_c[k, r] * _rate(B, r, v, w, i, j)
        for c in range(12):
            # ∂(B V)_r/∂δ_c = Σ_a G[r, a, c] V_a: the damper force changes with the configuration too
            gv = 0.0
            for a in range(3):
                gv += G[144 * r + 12 * a + c] * v[i, a] + G[144 * r + 12 * (3 + a) + c] * w[i, a]
                if j >= 0:
                    gv += G[144 * r + 12 * (6 + a) + c] * v[j, a] + G[144 * r + 12 * (9 + a) + c] * w[j, a]
            for a in range(12):
                K[a, c] += B[12 * r + a] * (model.fe_k[k, r] * B[12 * r + c] + model.fe_c[k, r] * gv) \
                    + sr * G[144 * r + 12 * a + c]
                C[a, c] += model.fe_c[k, r] * B[12 * r + a] * B[12 * r + c]
    if j < 0:
        for a in range(6, 12):
            for c in range(12):
                K[a, c] = 0.0
                K[c, a] = 0.0
    return m


def _matrix(q) -> np.ndarray:
    return EulerParameters(np.asarray(q, dtype=float)).matrix()


class ForceElement(ABC):
    """A spring-damper between ``body_i`` and ``body_j`` (``None``: the ground).

    Subclasses provide ``kind`` (a :data:`KINDS` value), :meth:`points`
    (the attachment points on i and j, inertial at t = 0), :meth:`frame` (the
    element frame, columns u1 u2 u3), :meth:`stiffness_damping` (k, c: 6 each,
    unused ones 0), :meth:`rest` (e_0) and :meth:`stiffness_rate` (a bound on
    the largest ω² the element adds, for the explicit step limit, given the
    lumped ``mass_of(node) → (m, J)``).
    """

    kind: int
    body_i: object
    body_j: object
    label: str

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def frame(self) -> np.ndarray:
        return np.eye(3)

    def stiffness_damping(self) -> tuple[np.ndarray, np.ndarray]:
        """k, c (6 each): a one-measure element's ``stiffness`` and ``damping`` in the first slot."""
        k, c = np.zeros(6), np.zeros(6)
        k[0], c[0] = self.stiffness, self.damping
        return k, c

    def rest(self) -> float:
        return 0.0

    def stiffness_rate(self, mass_of) -> float:
        raise NotImplementedError

    def body_fixed(self) -> np.ndarray:
        """``[s_i, s_j, f_i (9), f_j (9)]`` (24,), the joint layout of :meth:`Joint.body_fixed`."""
        parts = []
        for body, p in zip((self.body_i, self.body_j), self.points()):
            x, A = (np.zeros(3), np.eye(3)) if body is None else (body.position, _matrix(body.rotation))
            parts.append(A.T @ (np.asarray(p, dtype=float) - x))
        for body in (self.body_i, self.body_j):
            A = np.eye(3) if body is None else _matrix(body.rotation)
            parts.append((A.T @ self.frame()).reshape(9))
        return np.concatenate(parts)

    @staticmethod
    def _inverse_mass(mass_of, body, point=None, axis=None) -> float:
        """Inverse effective mass of a body: about an inertial ``axis``, ``uᵀ J⁻¹ u`` (u in the body
        frame, exact for a moment along u); at a point (translation), the bound ``1/m + r²/J_min``
        (``J_min`` the smallest principal inertia)."""
        if body is None:
            return 0.0
        m, J = mass_of(body)
        if axis is not None:
            u = _matrix(body.rotation).T @ np.asarray(axis, dtype=float)
            return float(u @ np.linalg.solve(J, u))
        J_min = float(np.linalg.eigvalsh(0.5 * (J + J.T))[0])
        r = 0.0 if point is None else float(np.linalg.norm(np.asarray(point) - body.position))
        return 1.0 / m + r * r / J_min


def _frame(axis, reference, label):
    """The element frame, refusing a zero axis or a reference along the axis."""
    axis = np.asarray(axis, dtype=float).reshape(3)
    if not np.linalg.norm(axis) > 0.0:
        raise ValueError(f"force element {label!r}: the axis is the zero vector; give a direction")
    return joint_frame(axis, reference)


def _check_bodies(body_i, body_j, label):
    if body_i is None:
        raise ValueError(f"force element {label!r}: body_i cannot be the ground")
    if body_i is body_j:
        raise ValueError(f"force element {label!r}: body_i and body_j are the same body")


@dataclass
class PointToPoint(ForceElement):
    """Linear spring-damper between two points (Exudyn's SpringDamper).

    Axial force ``N = k (ℓ − ℓ0) + c ℓ̇ + f_a(t)`` [N], positive in tension
    (pulling the points together).

    Parameters
    ----------
    body_i, body_j : Node or None
    point_i, point_j : array (3,)
        Attachment points, inertial at t = 0 [m] (body-fixed after).
    stiffness : float
        k [N/m] ≥ 0.
    damping : float
        c [N s/m] ≥ 0.
    rest_length : float, optional
        ℓ0 [m] (default: the initial distance).
    force_function : TimeFunction, optional
        Actuator force f_a(t) [N] along the line.
    """

    body_i: object
    point_i: np.ndarray
    body_j: object = None
    point_j: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stiffness: float = 0.0
    damping: float = 0.0
    rest_length: float | None = None
    force_function: TimeFunction | None = None
    label: str = "spring"
    kind = POINT_TO_POINT

    def __post_init__(self):
        _check_bodies(self.body_i, self.body_j, self.label)
        self.point_i = np.asarray(self.point_i, dtype=float).reshape(3)
        self.point_j = np.asarray(self.point_j, dtype=float).reshape(3)
        if self.stiffness < 0.0 or self.damping < 0.0:
            raise ValueError(f"spring {self.label!r}: stiffness and damping must not be negative")
        length = float(np.linalg.norm(self.point_j - self.point_i))
        if self.rest_length is None:
            if length <= 0.0:
                raise ValueError(f"spring {self.label!r}: the points coincide, so the rest length cannot default "
                                 "to the initial distance; give rest_length > 0")
            self.rest_length = length
        if length <= 0.0:
            raise ValueError(f"spring {self.label!r}: the points coincide, so the spring has no direction at "
                             "t = 0 (its force is undefined); place point_j away from point_i")
        if not self.rest_length > 0.0:
            raise ValueError(f"spring {self.label!r}: rest_length must be positive (a zero-length spring "
                             "has no direction)")

    def points(self):
        return self.point_i, self.point_j

    def rest(self):
        return float(self.rest_length)

    def stiffness_rate(self, mass_of):
        return self.stiffness * (self._inverse_mass(mass_of, self.body_i, self.point_i)
                                 + self._inverse_mass(mass_of, self.body_j, self.point_j))


@dataclass
class Rotational(ForceElement):
    """Torsional spring-damper about ``axis`` (Exudyn's TorsionalSpringDamper).

    Moment ``M = k (φ − φ0) + c φ̇`` [N m] about the axis, φ the rotation of
    body i relative to body j (continuous).

    Parameters
    ----------
    body_i, body_j : Node or None
    axis : array (3,)
        Inertial at t = 0 (body-fixed on both bodies after).
    stiffness : float
        k [N m/rad] ≥ 0.
    damping : float
        c [N m s/rad] ≥ 0.
    rest_angle : float
        φ0 [rad] (0: the initial configuration is unstressed).
    reference : array (3,), optional
        u1 of the element frame (only its plane matters).
    """

    body_i: object
    body_j: object = None
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    stiffness: float = 0.0
    damping: float = 0.0
    rest_angle: float = 0.0
    reference: np.ndarray | None = None
    label: str = "torsion spring"
    kind = ROTATIONAL

    def __post_init__(self):
        _check_bodies(self.body_i, self.body_j, self.label)
        if self.stiffness < 0.0 or self.damping < 0.0:
            raise ValueError(f"spring {self.label!r}: stiffness and damping must not be negative")
        self._frame = _frame(self.axis, self.reference, self.label)

    def points(self):
        p = self.body_i.position
        return p, p

    def frame(self):
        return self._frame

    def rest(self):
        return float(self.rest_angle)

    def stiffness_rate(self, mass_of):
        u = self._frame[:, 2]
        return self.stiffness * (self._inverse_mass(mass_of, self.body_i, axis=u)
                                 + self._inverse_mass(mass_of, self.body_j, axis=u))


@dataclass
class Bushing(ForceElement):
    """Six-component linear spring-damper in a frame at ``point`` (Exudyn's RigidBodySpringDamper,
    small rotations).

    Force ``K_t d + C_t ḋ`` along u1 u2 u3 of body i's frame and moment
    ``K_r θ + C_r θ̇`` (θ the small-rotation measure of the module table).

    Parameters
    ----------
    body_i, body_j : Node or None
    point : array (3,)
        Inertial at t = 0 [m].
    axis, reference : array (3,)
        u3 and u1 of the frame (as for a joint).
    stiffness, damping : array (6,)
        ``[k1, k2, k3 (N/m), k4, k5, k6 (N m/rad)]`` and the dampings [N s/m, N m s/rad], ≥ 0.
    """

    body_i: object
    body_j: object = None
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    reference: np.ndarray | None = None
    stiffness: np.ndarray = field(default_factory=lambda: np.zeros(6))
    damping: np.ndarray = field(default_factory=lambda: np.zeros(6))
    label: str = "bushing"
    kind = BUSHING

    def __post_init__(self):
        _check_bodies(self.body_i, self.body_j, self.label)
        self.point = np.asarray(self.point, dtype=float).reshape(3)
        self.stiffness = np.asarray(self.stiffness, dtype=float).reshape(6)
        self.damping = np.asarray(self.damping, dtype=float).reshape(6)
        if np.any(self.stiffness < 0.0) or np.any(self.damping < 0.0):
            raise ValueError(f"bushing {self.label!r}: stiffnesses and dampings must not be negative")
        self._frame = _frame(self.axis, self.reference, self.label)

    def points(self):
        return self.point, self.point

    def frame(self):
        return self._frame

    def stiffness_damping(self):
        return self.stiffness.copy(), self.damping.copy()

    def stiffness_rate(self, mass_of):
        kt = float(self.stiffness[:3].max())
        rate = 0.0
        for body in (self.body_i, self.body_j):
            rate += kt * self._inverse_mass(mass_of, body, self.point)
            rate += max(self.stiffness[3 + a] * self._inverse_mass(mass_of, body, axis=self._frame[:, a])
                        for a in range(3))
        return rate
