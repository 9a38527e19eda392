"""Plain data for time stepping: the assembled model and the state.

Both are named tuples of numpy arrays so that the compiled kernels take them
as they are (numba passes named tuples of arrays without copying).  An
algorithm step is a function ``(model, state) → state``; nothing else is
carried between steps.
"""

from __future__ import annotations

import functools

from typing import NamedTuple

import numpy as np

from reference.elements.families import family_of


class Nodes(NamedTuple):
    """The N nodes: ``mass`` (N,) [kg], ``inertia`` (N,3,3) body frame [kg m²] (a full tensor where
    beams meet at an angle), ``inertia_inv`` (N,3,3) the inverse of its block of free rotations,
    zero-padded, ``free`` (N,6) 1.0 for a free and 0.0 for a fixed coordinate (translations
    inertial, rotations body frame), ``constrained`` (N,) 1 for a node of a joint (either
    formulation), else 0, and ``constrained_ids`` (C,) those nodes."""

    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    free: np.ndarray
    constrained: np.ndarray
    constrained_ids: np.ndarray


class Loads(NamedTuple):
    """The L nodal loads (line loads lumped onto their nodes): ``node`` (L,), ``code`` (L,) 0 dead
    force, 1 follower force, 2 dead moment, 3 follower moment; ``vec`` (L,3) [N or N m]; ``tf`` (L,)
    the row of the time function; ``arm`` (L,3) the body-fixed point of application of a force
    (zero: at the node; the moment ``arm × force`` follows)."""

    node: np.ndarray
    code: np.ndarray
    vec: np.ndarray
    tf: np.ndarray
    arm: np.ndarray


class TimeFunctions(NamedTuple):
    """The T time functions of loads, drives and actuators: ``kind`` (T,), ``par`` (T,P) parameters
    (:func:`reference.interactions.tf_value`)."""

    kind: np.ndarray
    par: np.ndarray


class Joints(NamedTuple):
    """The J joints with multiplier rows (:class:`reference.joints.formulation.Multipliers`), m rows in
    all: ``i``, ``j`` (J,) node indices (−1 the ground), ``par`` (J,24) body-fixed point and frames,
    ``rows`` (J,6) primitive rows (−1 padded), ``neq`` (J,) equations, ``row0`` (J,) first global
    row, ``drive`` (J,) drive code, ``tf`` (J,) time function; ``eps`` (m,) the ε of each row's
    solves; ``pattern`` the fixed sparsity of ``B M⁻¹ Bᵀ``
    (:class:`reference.joints.sparse.ConstraintPattern`); ``compliance`` (m,) the c of each row's
    equation ``Φ − c λ = 0``; ``iterations`` the most multiplier solves of a constraint stage (0: one
    direct solve) and ``tolerance`` the relative change of the multipliers that ends them."""

    i: np.ndarray
    j: np.ndarray
    par: np.ndarray
    rows: np.ndarray
    neq: np.ndarray
    row0: np.ndarray
    drive: np.ndarray
    tf: np.ndarray
    eps: np.ndarray
    pattern: tuple
    compliance: np.ndarray
    iterations: int
    tolerance: float


class MasterSlaveJoints(NamedTuple):
    """The K master/slave joints (:class:`reference.joints.MasterSlave`): ``master``, ``slave`` (K,)
    node indices, ``kind`` (K,) 0 spherical 1 revolute, ``par`` (K,9) the master's body-fixed
    offset and axis and the slave's body-fixed axis."""

    master: np.ndarray
    slave: np.ndarray
    kind: np.ndarray
    par: np.ndarray


class ForceElements(NamedTuple):
    """The F force elements (:mod:`reference.forces`): ``kind`` (F,), ``i``, ``j`` (F,) node indices
    (−1 the ground), ``par`` (F,24) body-fixed points and frames (the joints' layout), ``k``, ``c``
    (F,6) stiffnesses and dampings per measure, ``rest`` (F,) rest length or angle, ``tf`` (F,)
    actuator time function (−1 none)."""

    kind: np.ndarray
    i: np.ndarray
    j: np.ndarray
    par: np.ndarray
    k: np.ndarray
    c: np.ndarray
    rest: np.ndarray
    tf: np.ndarray


class Model(NamedTuple):
    """Everything about the system that does not change during a run, in named groups, each packed
    by the classes of its objects.

    ``nodes`` (:class:`Nodes`); ``elements``, a tuple with one entry per element family present
    and per engine family (:mod:`reference.elements.families`, in registry order), each the family's plain data (e.g.
    :class:`reference.elements.beam2.Beam2Data`), whose first fields are ``conn`` (E_f, n) and
    ``index`` (E_f,) the elements' numbers in the Domain; ``loads`` (:class:`Loads`); ``gravity``
    (3,) [m/s²]; ``damping`` the mass-proportional coefficient c [1/s] (force −c m v, moment
    −c J ω); ``time_functions`` (:class:`TimeFunctions`); ``joints`` (:class:`Joints`, packed by
    :meth:`reference.joints.Jacobian.model_fields`); ``master_slave`` (:class:`MasterSlaveJoints`);
    ``force_elements`` (:class:`ForceElements`, packed by :func:`reference.forces.pack_force_elements`).

    **Offsets**: a family with section frames keeps per element end the constant Euler
    parameters ``o_a`` of the rotation from the frame of its node to the element's own section
    frame there, ``Λ_a = A(q_a) A(o_a)``, i.e. section quaternion ``p_a = q_a ⊗ o_a``; fixed at
    t = 0 as ``o_a = q_a⁰* ⊗ p_a⁰``; the identity ``(1, 0, 0, 0)`` where the node frame is the
    section frame (a straight beam's own nodes).  Body-frame quantities of an end transform as
    ``δθ_section = A(o_a)ᵀ δθ_node``, forces as ``S_θ,node = A(o_a) S_θ,section`` (see
    :func:`reference.elements.formulation.section_quaternion` and
    :func:`~reference.elements.formulation.to_node_frame`).
    """

    nodes: Nodes
    elements: tuple
    loads: Loads
    gravity: np.ndarray
    damping: float
    time_functions: TimeFunctions
    joints: Joints
    master_slave: MasterSlaveJoints
    force_elements: ForceElements

    @property
    def n_constraints(self) -> int:
        return int(self.joints.eps.shape[0])

    @property
    def n_elements(self) -> int:
        return sum(int(data.conn.shape[0]) for data in self.elements)


def record_dtype(*names: str) -> np.dtype:
    """The dtype of a record of float fields ``names``, read and written by name, ``clock["t"]``, in the compiled
    kernels (numba compiles a field as the slot of an array) and in Python (a :class:`numpy.void`, so that
    ``NUMBA_DISABLE_JIT=1`` runs the kernels too; a :class:`numpy.record`'s attributes are Python code, too slow
    for the per-output loop, docs/benchmarks.md §9).  Aligned, so that numba takes an array of them as an aligned
    array.  The algorithms keep one record in an array of shape (1,) and pass the array to a kernel (numba takes
    an array faster than a record), which works on its record ``[0]``."""
    return np.dtype([(name, "f8") for name in names], align=True)


class RecordView:
    """The record of a (1,) array of a :func:`record_dtype`, read and written from Python by field name,
    ``view["h"]``, as its :class:`numpy.void` is, through a float view of the array and each field's position: a
    fraction of the void's cost per access (docs/benchmarks.md §21), for the drivers that read and write their
    kernels' records between every two compiled calls.  The numbers are the array's (a view, not a copy)."""

    __slots__ = ("_values", "_position")

    def __init__(self, array: np.ndarray):
        self._values = array.view(np.float64)
        self._position = _positions(array.dtype)

    def __getitem__(self, name: str):
        return self._values[self._position[name]]

    def __setitem__(self, name: str, value) -> None:
        self._values[self._position[name]] = value


@functools.cache
def _positions(dtype: np.dtype) -> dict:
    """Field name → its slot in the float view of a :func:`record_dtype` (every field a float, aligned: no gaps)."""
    return {name: dtype.fields[name][1] // 8 for name in dtype.names}


CLOCK = record_dtype("t", "n", "work", "dissipated")
"""The record of :attr:`State.clock`: the time ``t`` [s] (the load factor of a static run), the step count
``n``, the external ``work`` done since t₀ and the ``dissipated`` energy [J]."""

GUARD = record_dtype("E0", "scale", "tolerance", "residual", "energy")
"""The record of :attr:`Scratch.guard`, the energy-balance guard (:mod:`reference.monitor`): the energy ``E0``
[J] at the first step, the ``scale`` S [J] (the largest ``|E₀| + |W| + |D|`` so far), the relative
``tolerance`` (0: off), the balance ``residual`` [J] and the kinetic + strain ``energy`` [J] of the last
guarded step; an algorithm that supports it stops when the residual exceeds tolerance × S."""


def new_clock(t: float = 0.0) -> np.ndarray:
    """A :data:`CLOCK` (shape (1,): the kernels take its record ``clock[0]``) at time ``t``, step 0."""
    clock = np.zeros(1, CLOCK)
    clock[0]["t"] = t
    return clock


class State(NamedTuple):
    """The state at step n.

    ``x`` (N,3) positions, ``q`` (N,4) Euler parameters at ``t_n``; ``v``
    (N,3) inertial and ``w`` (N,3) body-frame velocities at ``t_{n−½}``
    (before the first step: the initial velocities at ``t_0``); ``f_prev``
    (N,6) external generalised forces of the previous step (for the work
    integral); ``clock`` (1,) the :data:`CLOCK` record of t, n, external work and dissipated energy;
    ``angle`` (F,) the continuous angle of each rotational force element
    (:mod:`reference.forces`; 0 for the others).
    """

    x: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w: np.ndarray
    f_prev: np.ndarray
    clock: np.ndarray
    angle: np.ndarray

    @property
    def t(self) -> float:
        return float(self.clock[0]["t"])

    @property
    def n(self) -> int:
        return int(self.clock[0]["n"])

    @property
    def work(self) -> float:
        """The external work done since t₀ [J]."""
        return float(self.clock[0]["work"])

    def copy(self) -> "State":
        return State(*(a.copy() for a in self))


def element_work(model: Model) -> tuple:
    """The element families' work arrays for ``model`` (one per entry of ``model.elements``)."""
    return tuple(family_of(data).work(data) for data in model.elements)


class Record(NamedTuple):
    """One output record at an integer step: configuration, integer-step
    velocities (mean of the two half-step ones), energies
    ``[kinetic, strain, external work, dissipated]`` and constraint residuals
    ``[‖Φ‖, ‖B V + Φ_t‖]``; ``lam`` the Lagrange multipliers of the step."""

    x: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w: np.ndarray
    energy: np.ndarray
    constraint: np.ndarray
    lam: np.ndarray

    @classmethod
    def empty(cls, n_nodes: int, n_constraints: int = 0) -> "Record":
        return cls(np.zeros((n_nodes, 3)), np.zeros((n_nodes, 4)), np.zeros((n_nodes, 3)),
                   np.zeros((n_nodes, 3)), np.zeros(4), np.zeros(2), np.zeros(n_constraints))


class Scratch(NamedTuple):
    """Work arrays reused every step (the hot loop allocates nothing).

    Constraints: ``PHI``, ``PHIt``, ``lam``, ``work`` (m,); the joints' blocks of
    B and of B M⁻¹, ``Bj`` and ``BMj`` (J,6,12); the values of the sparse
    Cholesky factor ``Lx`` (nnz,).  ``elements``: the element families' work
    arrays, one entry per entry of :attr:`Model.elements` (the family's ``work``).
    """

    S: np.ndarray
    F: np.ndarray
    v_new: np.ndarray
    w_new: np.ndarray
    q_tmp: np.ndarray
    A: np.ndarray
    PHI: np.ndarray
    PHIt: np.ndarray
    Bj: np.ndarray
    BMj: np.ndarray
    Lx: np.ndarray
    lam: np.ndarray
    work: np.ndarray
    prim_phi: np.ndarray
    prim_B: np.ndarray
    T: np.ndarray
    A_m: np.ndarray
    A_s: np.ndarray
    MT: np.ndarray
    TMT: np.ndarray
    rhs: np.ndarray
    r4: np.ndarray
    guard: np.ndarray
    """The energy-balance guard, a :data:`GUARD` record of shape (1,)."""
    elements: tuple
    G: np.ndarray

    @classmethod
    def for_model(cls, model: Model) -> "Scratch":
        N, m, J = model.nodes.mass.shape[0], model.n_constraints, model.joints.i.shape[0]
        return cls(np.zeros((N, 6)), np.zeros((N, 6)), np.zeros((N, 3)), np.zeros((N, 3)),
                   np.zeros(4), np.zeros(9), np.zeros(m), np.zeros(m), np.zeros((J, 6, 12)), np.zeros((J, 6, 12)),
                   np.zeros(model.joints.pattern.L_rowidx.shape[0]), np.zeros(m), np.zeros(m), np.zeros(10),
                   np.zeros(120), np.zeros((12, 9)), np.zeros(9), np.zeros(9), np.zeros((12, 9)), np.zeros((9, 9)),
                   np.zeros(9), np.zeros(4), np.zeros(1, GUARD), element_work(model), np.zeros((N, 6)))
