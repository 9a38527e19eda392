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
from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from reference.expressions import expression_parameters, expression_value
from reference.generated import rotation_maps as rm
from reference.jit import kernel
from reference.rotation import EulerParameters
from reference.scalar import scalar_twin
from reference.state import Loads, TimeFunctions
from reference.validation import vector

CONSTANT, RAMP, STEP, PIECEWISE_LINEAR, SINE, SMOOTH_STEP, EXPRESSION = range(7)


@kernel
def _segment(p, n, t):
    """Index i (1…n−1) of the table segment [t_i, t_{i+1}] holding t, by bisection (O(log n))."""
    lo, hi = 1, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if t < p[mid]:
            hi = mid
        else:
            lo = mid
    return lo


@kernel
def _pwl_antiderivative(p, n, t):
    """``G(t) = ∫_{t_1}^t f`` of a piecewise-linear row (prefix sums ``S_i = G(t_i)`` stored after the values)."""
    if t <= p[1]:
        return p[1 + n] * (t - p[1])
    if t >= p[n]:
        return p[3 * n] + p[2 * n] * (t - p[n])
    i = _segment(p, n, t)
    s = (t - p[i]) / (p[1 + i] - p[i])
    fi = p[n + i] + s * (p[n + 1 + i] - p[n + i])
    return p[2 * n + i] + 0.5 * (p[n + i] + fi) * (t - p[i])


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
    PIECEWISE_LINEAR          n, t_1…t_n, v_1…v_n, S_1…S_n        linear interpolation, held outside
                              (S_i = ∫_{t_1}^{t_i} f, prefix sums)
    SINE                      A, ω [rad/s], φ [rad], offset       offset + A sin(ω t + φ)
    SMOOTH_STEP               t0, t1, v0, v1                      v0 + (v1 − v0)(3x² − 2x³), x = (t−t0)/(t1−t0)
    EXPRESSION                postfix programs                    a formula in t (:mod:`reference.expressions`)
    ========================  ==================================  ======================================

    A piecewise-linear table is searched by bisection: O(log n) per call, and
    its integral is O(log n) from the prefix sums.
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
        if t >= p[n]:
            return p[2 * n]
        i = _segment(p, n, t)
        s = (t - p[i]) / (p[1 + i] - p[i])
        return p[n + i] + s * (p[n + 1 + i] - p[n + i])
    if kind == SINE:
        return p[3] + p[0] * math.sin(p[1] * t + p[2])
    if kind == EXPRESSION:
        return expression_value(p, t, 0)
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
        if t < p[1] or t >= p[n]:
            return 0.0
        i = _segment(p, n, t)
        return (p[n + 1 + i] - p[n + i]) / (p[1 + i] - p[i])
    if kind == SINE:
        return p[0] * p[1] * math.cos(p[1] * t + p[2])
    if kind == EXPRESSION:
        return expression_value(p, t, 1)
    x = (t - p[0]) / (p[1] - p[0])
    if x <= 0.0 or x >= 1.0:
        return 0.0
    return (p[3] - p[2]) * 6.0 * x * (1.0 - x) / (p[1] - p[0])


@kernel
def tf_integral(kind, p, t):
    """``∫_0^t f(s) ds`` in closed form (a prescribed angle from a prescribed rate).

    An expression without a closed-form integral gives NaN (the deck reader
    refuses it where an integral is needed)."""
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
    if kind == EXPRESSION:
        return expression_value(p, t, 2)
    if kind == PIECEWISE_LINEAR:
        n = int(p[0])
        return _pwl_antiderivative(p, n, t) - _pwl_antiderivative(p, n, 0.0)
    # RAMP: exact trapezoids over the breakpoints
    total = p[2] * min(t, p[0])
    if t > p[0]:
        te = min(t, p[1])
        total += 0.5 * (p[2] + tf_value(kind, p, te)) * (te - p[0])
    if t > p[1]:
        total += p[3] * (t - p[1])
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
        prefix = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        return np.concatenate([[len(t)], t, v, prefix])


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


@dataclass
class Expression(TimeFunction):
    """A formula in t (sympy syntax, e.g. ``"sin(3*t)**2"``), with its derivative and,
    if ``with_integral``, its integral from 0 derived symbolically
    (:mod:`reference.expressions`; refused with :class:`~reference.expressions.ExpressionError`)."""

    expr: str = "0"
    _: KW_ONLY
    with_integral: bool = False
    kind = EXPRESSION

    def __post_init__(self):
        expression_parameters(self.expr, self.with_integral)  # refuse a bad formula now

    def parameters(self):
        return expression_parameters(self.expr, self.with_integral)


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
    point : array (3,), optional
        Point of application of a force, inertial at t = 0 [m] and fixed in
        the node's body frame after (a point of a rigid body); the moment of
        the force about the node follows.  Default: the node.

    Examples
    --------
    Everything after the vector is keyword-only, so a flag cannot be mistaken for another:

    >>> from reference import Domain, NodalLoad, Ramp
    >>> node = Domain().add_node((1.0, 0.0, 0.0), label="tip")
    >>> load = NodalLoad(node, [0.0, 0.0, -5.0], follower=True, time_function=Ramp(0.0, 1.0))
    >>> load.code  # a follower force
    1
    >>> NodalLoad(node, [0.0, 0.0, 1.0], True)
    Traceback (most recent call last):
    ...
    TypeError: NodalLoad.__init__() takes 3 positional arguments but 4 were given
    """

    node: object
    vector: np.ndarray
    _: KW_ONLY
    moment: bool = False
    follower: bool = False
    time_function: TimeFunction = field(default_factory=Constant)
    point: np.ndarray | None = None

    def __post_init__(self):
        label = getattr(self.node, "label", self.node)
        self.vector = vector(self.vector, f"load on {label!r}", fix="give the force or moment as [x, y, z]")
        if self.point is not None:
            self.point = vector(self.point, f"load on {label!r}: point")

    @property
    def code(self) -> int:
        """0 dead force, 1 follower force, 2 dead moment, 3 follower moment."""
        return 2 * int(self.moment) + int(self.follower)


@dataclass
class LineLoad(Interaction):
    """A distributed force and/or moment per unit length along a beam, ``q · f(t)``.

    Lumped onto the nodes element by element: each two-node element of
    reference length L gives ``q L / 2`` to each of its nodes.  With the
    linear shape functions of Beam2 this is the consistent load vector
    ``∫ N_a q ds`` of a uniform load, exactly.

    Parameters
    ----------
    nodes : list of Node
        The beam's nodes in order.
    force_per_length : array (3,)
        [N/m].
    moment_per_length : array (3,)
        [N m/m].
    follower : bool
        False: inertial components (dead load); True: components in each
        node's section frame (e1 along the beam), turning with it.
    time_function : TimeFunction
    """

    nodes: list
    force_per_length: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _: KW_ONLY
    moment_per_length: np.ndarray = field(default_factory=lambda: np.zeros(3))
    follower: bool = False
    time_function: TimeFunction = field(default_factory=Constant)

    def __post_init__(self):
        self.force_per_length = vector(self.force_per_length, "line load force_per_length")
        self.moment_per_length = vector(self.moment_per_length, "line load moment_per_length")

    def nodal_loads(self) -> list[NodalLoad]:
        """The equivalent nodal loads (half of each element's share to each of its nodes)."""
        share = [0.0] * len(self.nodes)
        for a, b in zip(range(len(self.nodes) - 1), range(1, len(self.nodes))):
            half = 0.5 * float(np.linalg.norm(self.nodes[b].position - self.nodes[a].position))
            share[a] += half
            share[b] += half
        loads = []
        for node, length in zip(self.nodes, share):
            for vec, moment in ((self.force_per_length, False), (self.moment_per_length, True)):
                vec = np.asarray(vec, dtype=float)
                if np.any(vec != 0.0):
                    loads.append(NodalLoad(node, vec * length, moment=moment, follower=self.follower,
                                            time_function=self.time_function))
        return loads


@dataclass
class Gravity(Interaction):
    """Uniform gravitational acceleration [m/s²] acting on every nodal mass."""

    g: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))

    def __post_init__(self):
        self.g = vector(self.g, "Gravity g [m/s²]", fix="give a vector, e.g. Gravity([0.0, 0.0, -9.81])")


class TimeFunctionTable:
    """The Model's table of time functions, built while the groups that use them are packed:
    :meth:`index` gives a function's row (adding it the first time it is seen, by identity),
    :meth:`pack` the :class:`~reference.state.TimeFunctions` (one constant row if empty)."""

    def __init__(self):
        self.functions: list[TimeFunction] = []

    def index(self, tf: TimeFunction) -> int:
        for k, known in enumerate(self.functions):
            if known is tf:
                return k
        self.functions.append(tf)
        return len(self.functions) - 1

    def pack(self) -> TimeFunctions:
        pars = [tf.parameters() for tf in self.functions]
        width = max([len(p) for p in pars] + [1])
        par = np.zeros((max(len(pars), 1), width))
        for j, p in enumerate(pars):
            par[j, : len(p)] = p
        return TimeFunctions(np.array([tf.kind for tf in self.functions] or [0], dtype=np.int64), par)


def pack_loads(loading: list, node_of, tf_index) -> Loads:
    """The Model's :class:`~reference.state.Loads` from the Domain's loading list: its nodal loads and
    its line loads lumped onto their nodes (:meth:`LineLoad.nodal_loads`), gravity excepted.

    ``node_of(key) → Node`` finds a load's node; ``tf_index(tf) → int`` a time function's row.
    A force applied at a point gets its body-fixed arm from the node (at t = 0).
    """
    loads = [ld for ld in loading if isinstance(ld, NodalLoad)]
    loads += [nl for ld in loading if isinstance(ld, LineLoad) for nl in ld.nodal_loads()]
    tf = np.array([tf_index(ld.time_function) for ld in loads], dtype=np.int64)
    arm = np.zeros((len(loads), 3))
    for k, ld in enumerate(loads):
        if ld.point is not None and not ld.moment:
            node = node_of(ld.node)
            A = np.empty(9)  # A(q) by the kernel's Python form: nothing to compile while the model is built
            scalar_twin(rm.rotation_matrix)(EulerParameters(node.rotation).q, A)
            A = A.reshape(3, 3)
            arm[k] = A.T @ (np.asarray(ld.point, float) - node.position)
    return Loads(np.array([node_of(ld.node).id for ld in loads], dtype=np.int64),
                 np.array([ld.code for ld in loads], dtype=np.int64),
                 np.array([np.asarray(ld.vector, dtype=float) for ld in loads]).reshape(len(loads), 3), tf, arm)
