"""Joints between bodies (the paper's ``Joint``, §4.2.3, Fig. 5).

A joint connects body i to body j (a beam node or a rigid body) or to the
ground (``body_j = None``).  It is defined in the inertial frame at t = 0 by a
point P and a joint frame ``(u1, u2, u3)``, u3 the joint axis; these are
stored body-fixed on both bodies, and the constraint equations are the
sympy-derived primitives of ``reference/generated/joints.py`` (equations in
``derivations/joints.py``):

================  ==========================================  =========
kind              constrains                                  equations
================  ==========================================  =========
spherical         P coincident                                3
revolute          P coincident, u3_i ∥ u3_j                   5
universal         P coincident, pin u1_i ⟂ pin u2_j           4
cylindrical       u3_i ∥ u3_j, P_j on the line (P_i, u3)      4
translational     cylindrical + rotation about u3 locked      5
fixed             P coincident, frames aligned                6
rotation_drive    relative rotation about u3 = θ(t)           1
displacement_drive  sliding along u3 = s(t)                   1
prescribed_displacement  P_i moves by s(t) along a fixed        1
                  inertial direction u3 (body_j the ground)
================  ==========================================  =========

A drive prescribes the rotation (or sliding) of body i relative to body j about (along) u3,
measured from the initial configuration — positive: body i turns by +θ about, or moves by +s
along, u3 (one sign rule for both drives) — either as the value of a time function (``mode =
"position"``) or as its integral (``mode = "velocity"``: the time function is
the angular velocity / sliding speed).
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from reference.connector import Connector, body_or_ground
from reference.generated import joints as generated
from reference.interactions import Constant, TimeFunction

PRESCRIBED = "prescribed_displacement"
"""The joint kind of a prescribed displacement (the deck's ``[[prescribed_displacements]]``)."""
ROWS = {**generated.JOINT_ROWS, "rotation_drive": (5, 9), "displacement_drive": (8,), PRESCRIBED: (0, 1, 2)}
EQUATIONS = {**{k: len(v) for k, v in generated.JOINT_ROWS.items()}, "rotation_drive": 1, "displacement_drive": 1,
             PRESCRIBED: 1}
DRIVE_CODES = {("rotation_drive", "position"): 1, ("rotation_drive", "velocity"): 2,
               ("displacement_drive", "position"): 3, ("displacement_drive", "velocity"): 4,
               (PRESCRIBED, "position"): 5}


def joint_frame(axis, reference=None) -> np.ndarray:
    """Orthonormal frame with columns ``(u1, u2, u3)``, ``u3`` along ``axis``.

    ``u1`` is ``reference`` made orthogonal to the axis (default: the
    coordinate axis least aligned with it).
    """
    u3 = np.asarray(axis, dtype=float)
    u3 = u3 / np.linalg.norm(u3)
    if reference is None:
        reference = np.eye(3)[int(np.argmin(np.abs(u3)))]
    u1 = np.asarray(reference, dtype=float) - np.dot(reference, u3) * u3
    if np.linalg.norm(u1) < 1e-9:
        raise ValueError("the reference direction of a joint frame is parallel to its axis")
    u1 /= np.linalg.norm(u1)
    return np.column_stack([u1, np.cross(u3, u1), u3])


@dataclass
class Joint(Connector):
    """One joint of the Domain's joint list.

    Parameters
    ----------
    kind : str
        One of ``ROWS``.
    body_i, body_j : Node, "ground" or None
        The two bodies; ``"ground"`` (or ``None``) is the ground (only one of them).
    point : array (3,)
        Joint point P, inertial, at t = 0 [m].
    frame : array (3, 3)
        Joint frame, columns ``u1, u2, u3`` (inertial, t = 0); see :func:`joint_frame`.
    formulation : JointFormulation
        How the constraint enters the equations of motion (:meth:`reference.domain.Domain.add_joint`
        gives Lagrange multipliers, :class:`~reference.joints.formulation.Jacobian`, by default; a joint
        knows no formulation class, so that the formulations may read joints).
    time_function : TimeFunction
        For drives: θ(t) or s(t) (``mode = "position"``), or their rates (``"velocity"``); for a
        prescribed displacement s(t) [m].
    mode : str
        ``"position"`` or ``"velocity"`` (drives only).
    label : str
    intended_offset : bool
        The point lies away from both bodies by design (no warning of
        :func:`reference.validation.joint_offsets`).
    """

    kind: str
    body_i: object
    body_j: object
    point: np.ndarray
    frame: np.ndarray
    _: KW_ONLY
    formulation: object = None
    time_function: TimeFunction = field(default_factory=lambda: Constant(0.0))
    mode: str = "position"
    label: str = ""
    intended_offset: bool = False

    def __post_init__(self):
        if self.kind not in ROWS:
            raise ValueError(f"unknown joint kind {self.kind!r}; valid: {', '.join(ROWS)}")
        self.body_i = body_or_ground(self.body_i, f"joint {self.label!r} body_i")
        self.body_j = body_or_ground(self.body_j, f"joint {self.label!r} body_j")
        if self.body_i is None and self.body_j is None:
            raise ValueError("a joint needs at least one body")
        if self.body_i is None:  # keep the ground on side j
            self.body_i, self.body_j = self.body_j, None
        self.point = np.asarray(self.point, dtype=float).reshape(3)
        self.frame = np.asarray(self.frame, dtype=float).reshape(3, 3)
        if not np.allclose(self.frame.T @ self.frame, np.eye(3), atol=1e-9):
            raise ValueError(f"joint {self.label!r}: the joint frame is not orthonormal")
        if self.mode not in ("position", "velocity"):
            raise ValueError(f"joint {self.label!r}: mode must be 'position' or 'velocity'")
        if self.kind == PRESCRIBED and (self.body_j is not None or self.mode != "position"):
            raise ValueError(f"prescribed displacement {self.label!r}: it moves one body along a direction fixed "
                             "on the ground (body_j the ground, mode 'position')")

    @property
    def n_equations(self) -> int:
        return EQUATIONS[self.kind]

    @property
    def rows(self) -> np.ndarray:
        """The primitive constraint rows of ``reference/generated/joints.py`` its kind uses (:data:`ROWS`),
        padded with −1 to six: a row of the joint table's ``rows``."""
        rows = np.full(6, -1, dtype=np.int64)
        rows[: len(ROWS[self.kind])] = ROWS[self.kind]
        return rows

    @property
    def drive_code(self) -> int:
        return DRIVE_CODES.get((self.kind, self.mode), 0)

    def attachment(self):
        """The joint point on both bodies and the joint frame (:meth:`Connector.body_fixed`)."""
        return self.point, self.point, self.frame

    def evaluate(self, x, q, t: float = 0.0):
        """Φ (m,), B (m, 12) and Φ_t (m,) at positions ``x`` (N,3) and Euler parameters ``q`` (N,4).

        The plain-Python face of the compiled assembly (``reference/joints/assembly.py``);
        B's columns are ``[v_i | ω_i | v_j | ω_j]`` (the ground's are zero).
        """
        from reference.joints.assembly import joint_rows

        par = self.body_fixed()
        i = self.body_i.id
        j = -1 if self.body_j is None else self.body_j.id
        tf = self.time_function
        m = self.n_equations
        phi, phit, B = np.zeros(m), np.zeros(m), np.zeros((m, 12))
        joint_rows(np.asarray(x, dtype=float), np.asarray(q, dtype=float), i, j, par, self.rows, self.drive_code,
                   tf.kind, tf.parameters(), float(t), phi, B, phit, np.zeros(10), np.zeros(120))
        return phi, B, phit
