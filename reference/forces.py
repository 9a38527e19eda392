"""Force elements: springs, dampers and bushings between bodies (the paper's loads between bodies).

A force element connects body i to body j (a rigid body or a beam node) or to
the ground.  Like a joint (:mod:`reference.joints.joint`) it is a
:class:`~reference.connector.Connector`: defined in the inertial frame at t = 0 by
points and a frame stored body-fixed on both bodies, and evaluated with the same
derived primitives, with measures derived in sympy (``derivations/forces.py`` →
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

The compiled evaluation is in :mod:`reference.evaluation.force_elements`
(forces and energy, which every algorithm calls through the generalised forces,
the dampers' dissipation, and the stiffness and damping matrices of one element
for the implicit algorithms); an actuator force along a point-to-point line is
an external load (its work counts as external work).  :func:`pack_force_elements`
lays the elements out in the Model.
"""

from __future__ import annotations

from abc import ABC
from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from reference.connector import Connector, body_matrix, body_or_ground
from reference.interactions import TimeFunction
from reference.joints.joint import joint_frame
from reference.state import ForceElements

POINT_TO_POINT, ROTATIONAL, BUSHING = 0, 1, 2
KINDS = {"point_to_point": POINT_TO_POINT, "rotational": ROTATIONAL, "bushing": BUSHING}


class ForceElement(Connector, ABC):
    """A spring-damper between ``body_i`` and ``body_j`` (``"ground"`` or ``None``: the ground).

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

    def attachment(self):
        """The attachment points and the element frame (:meth:`Connector.body_fixed`)."""
        p_i, p_j = self.points()
        return p_i, p_j, self.frame()

    @staticmethod
    def _inverse_mass(mass_of, body, point=None, axis=None) -> float:
        """Inverse effective mass of a body: about an inertial ``axis``, ``uᵀ J⁻¹ u`` (u in the body
        frame, exact for a moment along u); at a point (translation), the bound ``1/m + r²/J_min``
        (``J_min`` the smallest principal inertia)."""
        if body is None:
            return 0.0
        m, J = mass_of(body)
        if axis is not None:
            u = body_matrix(body).T @ np.asarray(axis, dtype=float)
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
    """The two bodies, ``"ground"`` read as None, after the checks: body i is a body, not body j."""
    body_i = body_or_ground(body_i, f"force element {label!r} body_i")
    body_j = body_or_ground(body_j, f"force element {label!r} body_j")
    if body_i is None:
        raise ValueError(f"force element {label!r}: body_i cannot be the ground")
    if body_i is body_j:
        raise ValueError(f"force element {label!r}: body_i and body_j are the same body")
    return body_i, body_j


@dataclass
class PointToPoint(ForceElement):
    """Linear spring-damper between two points (Exudyn's SpringDamper).

    Axial force ``N = k (ℓ − ℓ0) + c ℓ̇ + f_a(t)`` [N], positive in tension
    (pulling the points together).

    Parameters
    ----------
    body_i, body_j : Node, "ground" or None
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
    _: KW_ONLY
    stiffness: float = 0.0
    damping: float = 0.0
    rest_length: float | None = None
    force_function: TimeFunction | None = None
    label: str = "spring"
    kind = POINT_TO_POINT

    def __post_init__(self):
        self.body_i, self.body_j = _check_bodies(self.body_i, self.body_j, self.label)
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
    body_i, body_j : Node, "ground" or None
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
    _: KW_ONLY
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    stiffness: float = 0.0
    damping: float = 0.0
    rest_angle: float = 0.0
    reference: np.ndarray | None = None
    label: str = "torsion spring"
    kind = ROTATIONAL

    def __post_init__(self):
        self.body_i, self.body_j = _check_bodies(self.body_i, self.body_j, self.label)
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
    body_i, body_j : Node, "ground" or None
    point : array (3,)
        Inertial at t = 0 [m].
    axis, reference : array (3,)
        u3 and u1 of the frame (as for a joint).
    stiffness, damping : array (6,)
        ``[k1, k2, k3 (N/m), k4, k5, k6 (N m/rad)]`` and the dampings [N s/m, N m s/rad], ≥ 0.
    """

    body_i: object
    body_j: object = None
    _: KW_ONLY
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    reference: np.ndarray | None = None
    stiffness: np.ndarray = field(default_factory=lambda: np.zeros(6))
    damping: np.ndarray = field(default_factory=lambda: np.zeros(6))
    label: str = "bushing"
    kind = BUSHING

    def __post_init__(self):
        self.body_i, self.body_j = _check_bodies(self.body_i, self.body_j, self.label)
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


def pack_force_elements(elements: list, tf_index) -> ForceElements:
    """The Model's :class:`~reference.state.ForceElements` from the Domain's force elements, in order;
    ``tf_index(tf) → int`` gives an actuator's time function row (−1: no actuator)."""
    n = len(elements)
    return ForceElements(
        np.array([f.kind for f in elements], dtype=np.int64), np.array([f.body_i.id for f in elements], dtype=np.int64),
        np.array([-1 if f.body_j is None else f.body_j.id for f in elements], dtype=np.int64),
        np.array([f.body_fixed() for f in elements]).reshape(n, 24),
        np.array([f.stiffness_damping()[0] for f in elements]).reshape(n, 6),
        np.array([f.stiffness_damping()[1] for f in elements]).reshape(n, 6),
        np.array([f.rest() for f in elements], dtype=float),
        np.array([-1 if getattr(f, "force_function", None) is None else tf_index(f.force_function)
                  for f in elements], dtype=np.int64))
