"""What joints and force elements share: two bodies connected at body-fixed points and frames.

A *connector* acts between body i and body j (``"ground"`` or ``None``: the ground) — a joint
(:class:`reference.joints.joint.Joint`, paper §4.2.3) or a force element
(:class:`reference.forces.ForceElement`, a load between bodies).  It is defined in the
inertial frame at t = 0 by a point on each body and a frame (columns u1, u2, u3), and
stored body-fixed on both bodies in the layout the compiled kernels read
(``Model.joints.par``, ``Model.force_elements.par``)::

    [s_i (3), s_j (3), f_i (9), f_j (9)]      s = Aᵀ (p − x),  f = Aᵀ F  (row-major)

with ``x``, ``A`` each body's position and rotation matrix at t = 0 (the ground's: 0, I).
"""

from __future__ import annotations

import numpy as np

from reference.generated import rotation_maps as rm
from reference.jit import inlined
from reference.scalar import scalar_twin


GROUND = "ground"
"""The ground's name, in a deck and in the API alike (``None`` is accepted for it too)."""


def body_or_ground(body, entry: str):
    """``body`` (a node), or None for the ground (``"ground"`` or None); any other string is refused."""
    if isinstance(body, str):
        if body != GROUND:
            raise ValueError(f"{entry}: got the string {body!r}; give a node (as the Domain returned it) or "
                             f"{GROUND!r}")
        return None
    return body


@inlined
def body_fixed_parts(par):
    """The parts of a connector's packed ``par`` (24,) (the layout above, :meth:`Connector.body_fixed`): the
    points ``s_i``, ``s_j`` (3,) [m] and the frames ``f_i``, ``f_j`` (9,) (row-major), each in its body's
    frame; views, for the compiled kernels and Python alike."""
    return par[0:3], par[3:6], par[6:15], par[15:24]


def body_matrix(body) -> np.ndarray:
    """The rotation matrix ``A(q)`` (body → inertial) of a node at t = 0, the identity for the ground."""
    if body is None:
        return np.eye(3)
    out = np.empty(9)
    scalar_twin(rm.rotation_matrix)(np.asarray(body.rotation, dtype=float), out)
    return out.reshape(3, 3)


class Connector:
    """Base of joints and force elements.

    Subclasses have ``body_i``, ``body_j`` (a node, or None for the ground) and provide
    :meth:`attachment`: the two points and the frame, inertial at t = 0.
    """

    body_i: object
    body_j: object

    def attachment(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(p_i, p_j, F)``: the point on body i, on body j [m] and the frame (3×3), inertial at t = 0."""
        raise NotImplementedError

    def body_fixed(self) -> np.ndarray:
        """``[s_i, s_j, f_i (9), f_j (9)]`` (24,): the points and the frame in each body's frame."""
        p_i, p_j, frame = self.attachment()
        parts = []
        for body, p in ((self.body_i, p_i), (self.body_j, p_j)):
            x = np.zeros(3) if body is None else body.position
            parts.append(body_matrix(body).T @ (np.asarray(p, dtype=float) - x))
        for body in (self.body_i, self.body_j):
            parts.append((body_matrix(body).T @ frame).reshape(9))
        return np.concatenate(parts)
