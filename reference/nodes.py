"""Nodes: the kinematic coordinates shared by beams and rigid bodies (paper §3.1).

A node carries a position ``x`` (inertial), Euler parameters ``q`` (scalar
first, see :mod:`reference.rotation`), a translational velocity ``v``
(inertial) and an angular velocity ``ω`` in its **body frame**.  For a beam
node the body frame is the cross-section triad (axis 1 along the beam axis);
for a rigid body it is the body frame at its centre of mass.  Mass and rotary
inertia are gathered onto nodes by the element formulations (lumped), so a beam
node and a rigid body obey the same equations (paper eq. 3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Node:
    """One node of the Domain.

    Parameters
    ----------
    id : int
        Stable identifier (its index in the Domain's node list).
    label : str
        Name used in results, e.g. ``"beam:12"`` or ``"crank"``.
    position : array (3,)
        Initial position [m], inertial.
    rotation : array (4,)
        Initial Euler parameters (scalar first).
    velocity : array (3,)
        Initial velocity [m/s], inertial.
    angular_velocity : array (3,)
        Initial angular velocity [rad/s], body frame.
    mass : float
        Lumped translational mass [kg] (accumulated from elements or set).
    inertia : array (3, 3)
        Rotary inertia [kg m²] in the body frame (accumulated or set).
    points : dict
        Named points of a rigid body, inertial coordinates at t = 0 [m].
    frame_given : bool
        The rotation was given (a ``[[nodes]]`` rotation, a rigid body, or set
        by the first beam that uses the node): later beams keep it and refer
        their section frames to it through constant offsets.
    """

    id: int
    label: str
    position: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mass: float = 0.0
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    points: dict = field(default_factory=dict)
    frame_given: bool = False

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=float).reshape(3)
        q = np.asarray(self.rotation, dtype=float).reshape(4)
        self.rotation = q / np.linalg.norm(q)
        self.velocity = np.asarray(self.velocity, dtype=float).reshape(3)
        self.angular_velocity = np.asarray(self.angular_velocity, dtype=float).reshape(3)
        self.inertia = np.asarray(self.inertia, dtype=float).reshape(3, 3)
