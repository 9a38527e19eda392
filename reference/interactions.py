"""Interactions: boundary conditions, loads and the time functions that scale them.

The paper's Domain keeps two interaction lists, boundary conditions and loading
(Fig. 7).  Here a boundary condition fixes nodal coordinates (:class:`Clamp`,
:class:`FixedCoordinates`); a load is a nodal force or moment, **dead** (fixed
in the inertial frame) or **follower** (fixed in the node's body frame), or
gravity; each load is scaled by a :class:`TimeFunction`.

Units are whatever consistent set the deck uses (SI in the examples): forces
[N], moments [N m], time [s].

Every time function is evaluated by one compiled routine, :func:`tf_value`
(and :func:`tf_derivative`, :func:`tf_integral`, used by driving constraints),
which the time-stepping kernel calls too: the formula of each kind is written
exactly once.
"""

from __future__ import annotations

import math
from abc import ABC
from dataclasses import dataclass, field

import numpy as np

from reference.jit import kernel

CONSTANT, RAMP, STEP, PIECEWISE_LINEAR, SINE, SMOOTH_STEP = range(6)


@kernel
def _smooth(x):
    """3x² − 2x³ clipped to [0, 1] (C¹ smooth step)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


@kernel
def tf_value(kind, p, t):
    """Value of time function ``kind`` with parameters ``p`` at time ``t``.

    ========================  ==================================  ======================================
    kind                      parameters ``p``                    value
    ========================  ==================================  ======================================
    CONSTANT                  c                                   c
    RAMP                      t0, t1, v0, v1                      v0 → v1 linearly on [t0, t1], held outside
    STEP                      t0, v0, v1                          v0 for t < t0, v1 after
    PIECEWISE_LINEAR          n, t_1…t_n, v_1…v_n                 linear interpolation, held outside
    SINE                      A, ω [rad/s], φ [rad], offset       offset + A sin(ω t + φ)
    SMOOTH_STEP               t0, t1, v0, v1                      v0 + (v1 − v0)(3x² − 2x³), x = (t−t0)/(t1−t0)
    ========================  ==================================  ======================================
    """
    if kind == CONSTANT:
        return p[0]
    if kind == RAMP:
        if t <= p[0]:
            return p[2]
        if t >= p[1]:
            return p[3]
        return p[2] + (p[3] - p[2]) * (t - p[0]) / (p[1] - p[0])
    if kind == STEP:
        return p[1] if t < p[0] else p[2]
    if kind == PIECEWISE_LINEAR:
        n = int(p[0])
        if t <= p[1]:
            return p[1 + n]
        for i in range(1, n):
            if t <= p[1 + i]:
                s = (t - p[i]) / (p[1 + i] - p[i])
                return p[n + i] + s * (p[n + 1 + i] - p[n + i])
        return p[2 * n]
    if kind == SINE:
        return p[3] + p[0] * math.sin(p[1] * t + p[2])
    # SMOOTH_STEP
    return p[2] + (p[3] - p[2]) * _smooth((t - p[0]) / (p[1] - p[0]))


@kernel
def tf_derivative(kind, p, t):
    """Time derivative of :func:`tf_value` (one-sided at the kinks)."""
    if kind == CONSTANT or kind == STEP:
        return 0.0
    if kind == RAMP:
        if t < p[0] or t >= p[1]:
            return 0.0
        return (p[3] - p[2]) / (p[1] - p[0])
    if kind == PIECEWISE_LINEAR:
        n = int(p[0])
        if t < p[1]:
            return 0.0
        for i in range(1, n):
            if t < p[1 + i]:
                return (p[n + 1 + i] - p[n + i]) / (p[1 + i] - p[i])
        return 0.0
    if kind == SINE:
        return p[0] * p[1] * math.cos(p[1] * t + p[2])
    x = (t - p[0]) / (p[1] - p[0])
    if x <= 0.0 or x >= 1.0:
        return 0.0
    return (p[3] - p[2]) * 6.0 * x * (1.0 - x) / (p[1] - p[0])


@kernel
def tf_integral(kind, p, t):
    """``∫_0^t f(s) ds`` in closed form (a prescribed angle from a prescribed rate)."""
    if kind == CONSTANT:
        return p[0] * t
    if kind == SINE:
        if p[1] == 0.0:
            return (p[3] + p[0] * math.sin(p[2])) * t
        return p[3] * t - p[0] / p[1] * (math.cos(p[1] * t + p[2]) - math.cos(p[2]))
    if kind == STEP:
        if t <= p[0]:
            return p[1] * t
        return p[1] * p[0] + p[2] * (t - p[0])
    if kind == SMOOTH_STEP:
        d = p[1] - p[0]
        x = min(max(t / d - p[0] / d, 0.0), 1.0)
        before = p[2] * min(t, p[0])
        during = d * (p[2] * x + (p[3] - p[2]) * (x**3 - 0.5 * x**4))
        after = p[3] * max(t - p[1], 0.0)
        return before + during + after
    # RAMP and PIECEWISE_LINEAR: exact trapezoids over the breakpoints
    if kind == RAMP:
        total = p[2] * min(t, p[0])
        if t > p[0]:
            te = min(t, p[1])
            total += 0.5 * (p[2] + tf_value(kind, p, te)) * (te - p[0])
        if t > p[1]:
            total += p[3] * (t - p[1])
        return total
    n = int(p[0])
    total = p[1 + n] * min(t, p[1])
    for i in range(1, n):
        a, b = p[i], p[1 + i]
        if t <= a:
            break
        te = min(t, b)
        total += 0.5 * (p[n + i] + tf_value(kind, p, te)) * (te - a)
    if t > p[n]:
        total += p[2 * n] * (t - p[n])
    return total


class TimeFunction(ABC):
    """Scalar function of time that scales a load or drives a motion.

    Subclasses provide ``kind`` (one of the module constants) and
    ``parameters()`` (the array read by :func:`tf_value`); evaluation is common.
    """

    kind: int

    def parameters(self) -> np.ndarray:
        raise NotImplementedError

    def __call__(self, t: float) -> float:
        return tf_value(self.kind, self.parameters(), float(t))

    def derivative(self, t: float) -> float:
        return tf_derivative(self.kind, self.parameters(), float(t))

    def integral(self, t: float) -> float:
        return tf_integral(self.kind, self.parameters(), float(t))


@dataclass
class Constant(TimeFunction):
    value: float = 1.0
    kind = CONSTANT

    def parameters(self):
        return np.array([self.value], dtype=float)


@dataclass
class Ramp(TimeFunction):
    """Linear from ``v0`` at ``t0`` to ``v1`` at ``t1``, held constant outside."""

    t0: float = 0.0
    t1: float = 1.0
    v0: float = 0.0
    v1: float = 1.0
    kind = RAMP

    def parameters(self):
        return np.array([self.t0, self.t1, self.v0, self.v1], dtype=float)


@dataclass
class Step(TimeFunction):
    """``v0`` before ``t0``, ``v1`` from ``t0`` on."""

    t0: float = 0.0
    v0: float = 0.0
    v1: float = 1.0
    kind = STEP

    def parameters(self):
        return np.array([self.t0, self.v0, self.v1], dtype=float)


@dataclass
class PiecewiseLinear(TimeFunction):
    """Linear interpolation of a table ``(times, values)``, held outside it."""

    times: list = field(default_factory=lambda: [0.0, 1.0])
    values: list = field(default_factory=lambda: [0.0, 1.0])
    kind = PIECEWISE_LINEAR

    def parameters(self):
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        return np.concatenate([[len(t)], t, v])


@dataclass
class Sine(TimeFunction):
    """``offset + amplitude sin(omega t + phase)``, omega in rad/s."""

    amplitude: float = 1.0
    omega: float = 1.0
    phase: float = 0.0
    offset: float = 0.0
    kind = SINE

    def parameters(self):
        return np.array([self.amplitude, self.omega, self.phase, self.offset], dtype=float)


@dataclass
class SmoothStep(TimeFunction):
    """``v0 + (v1 − v0)(3x² − 2x³)``, ``x = (t − t0)/(t1 − t0)`` clipped to [0, 1]."""

    t0: float = 0.0
    t1: float = 1.0
    v0: float = 0.0
    v1: float = 1.0
    kind = SMOOTH_STEP

    def parameters(self):
        return np.array([self.t0, self.t1, self.v0, self.v1], dtype=float)


class Interaction(ABC):
    """Anything in the Domain's boundary-condition or loading list (paper Fig. 7)."""


@dataclass
class FixedCoordinates(Interaction):
    """Fix nodal coordinates: ``dofs`` ⊂ {0,1,2: translations x,y,z (inertial); 3,4,5: rotations (body)}."""

    node: object
    dofs: tuple = (0, 1, 2, 3, 4, 5)


@dataclass
class Clamp(FixedCoordinates):
    """All six coordinates of a node fixed (the embedded end of a beam)."""

    dofs: tuple = (0, 1, 2, 3, 4, 5)


@dataclass
class NodalLoad(Interaction):
    """A nodal force or moment ``vector · f(t)``.

    Parameters
    ----------
    node : Node
    vector : array (3,)
        Force [N] or moment [N m]; inertial components for a dead load,
        body-frame components for a follower load.
    moment : bool
        A moment rather than a force.
    follower : bool
        Fixed in the node's body frame (turns with the node) instead of the
        inertial frame.
    time_function : TimeFunction
    """

    node: object
    vector: np.ndarray
    moment: bool = False
    follower: bool = False
    time_function: TimeFunction = field(default_factory=Constant)

    @property
    def code(self) -> int:
        """0 dead force, 1 follower force, 2 dead moment, 3 follower moment."""
        return 2 * int(self.moment) + int(self.follower)


@dataclass
class Gravity(Interaction):
    """Uniform gravitational acceleration [m/s²] acting on every nodal mass."""

    g: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
