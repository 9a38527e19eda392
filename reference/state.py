"""Plain data for time stepping: the assembled model and the state.

Both are named tuples of numpy arrays so that the compiled kernels take them
as they are (numba passes named tuples of arrays without copying).  An
algorithm step is a function ``(model, state) → state``; nothing else is
carried between steps.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Model(NamedTuple):
    """Everything about the system that does not change during a run.

    Nodes (N): ``mass`` (N,) [kg], ``inertia`` (N,3,3) body frame [kg m²]
    (a full tensor where beams meet at an angle), ``inertia_inv`` (N,3,3) the
    inverse of its block of free rotations, zero-padded, ``free`` (N,6) 1.0 for a free and 0.0 for a fixed
    coordinate (translations inertial, rotations body frame).
    Beam2 elements (E): ``conn`` (E,2), ``offset`` (E,2,4), ``L0`` (E,),
    ``psi0`` (E,3), ``gamma0`` (E,3), ``stiff`` (E,6) = EA, GA2, GA3, GJ, EI2,
    EI3.  **Offsets**: ``offset[e, a]`` are the constant Euler parameters
    ``o_a`` of the rotation from the frame of node ``conn[e, a]`` to element
    e's own section frame at that end, ``Λ_a = A(q_a) A(o_a)``, i.e. section
    quaternion ``p_a = q_a ⊗ o_a``; fixed at t = 0 as ``o_a = q_a⁰* ⊗ p_a⁰``.
    The identity ``(1, 0, 0, 0)`` where the node frame is the section frame
    (a straight beam's own nodes).  Body-frame quantities of an end transform
    as ``δθ_section = A(o_a)ᵀ δθ_node``, forces as ``S_θ,node = A(o_a) S_θ,section``
    and a section-frame tangent ``K_node = T K_sec Tᵀ`` with
    ``T = blockdiag(I, A(o_1), I, A(o_2))`` (see
    :func:`reference.elements.formulation.section_quaternion` and
    :func:`~reference.elements.formulation.to_node_frame`).  ``psi0`` and
    ``gamma0`` are of the section frames (0 and E1 for a straight element).
    Loads (L): ``load_node`` (L,), ``load_code`` (L,) 0 dead force,
    1 follower force, 2 dead moment, 3 follower moment; ``load_vec`` (L,3);
    ``load_tf`` (L,) index of the time function.
    Time functions (T): ``tf_kind`` (T,), ``tf_par`` (T,P) parameters
    (see :func:`reference.interactions.tf_value`).
    ``gravity`` (3,) [m/s²]; ``damping`` mass-proportional coefficient c
    [1/s] (force −c m v, moment −c J ω).
    Joints (J) with m constraint rows in all: ``jt_i``, ``jt_j`` (J,) node
    indices (−1 the ground), ``jt_par`` (J,24) body-fixed point and frames,
    ``jt_rows`` (J,6) primitive rows (−1 padded), ``jt_neq`` (J,) equations,
    ``jt_row0`` (J,) first global row, ``jt_drive`` (J,) drive code,
    ``jt_tf`` (J,) time function; ``row_eps`` (m,) the ε of each row;
    ``row_nodes`` (m,2) the nodes a row involves (−1 the ground).
    Master/slave joints (K): ``ms_master``, ``ms_slave`` (K,) node indices,
    ``ms_kind`` (K,) 0 spherical 1 revolute, ``ms_par`` (K,9) the master's
    body-fixed offset and axis and the slave's body-fixed axis.
    """

    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    free: np.ndarray
    conn: np.ndarray
    offset: np.ndarray
    L0: np.ndarray
    psi0: np.ndarray
    gamma0: np.ndarray
    stiff: np.ndarray
    load_node: np.ndarray
    load_code: np.ndarray
    load_vec: np.ndarray
    load_tf: np.ndarray
    tf_kind: np.ndarray
    tf_par: np.ndarray
    gravity: np.ndarray
    damping: float
    jt_i: np.ndarray
    jt_j: np.ndarray
    jt_par: np.ndarray
    jt_rows: np.ndarray
    jt_neq: np.ndarray
    jt_row0: np.ndarray
    jt_drive: np.ndarray
    jt_tf: np.ndarray
    row_eps: np.ndarray
    row_nodes: np.ndarray
    ms_master: np.ndarray
    ms_slave: np.ndarray
    ms_kind: np.ndarray
    ms_par: np.ndarray

    @property
    def n_constraints(self) -> int:
        return int(self.row_eps.shape[0])


class State(NamedTuple):
    """The state at step n.

    ``x`` (N,3) positions, ``q`` (N,4) Euler parameters at ``t_n``; ``v``
    (N,3) inertial and ``w`` (N,3) body-frame velocities at ``t_{n−½}``
    (before the first step: the initial velocities at ``t_0``); ``f_prev``
    (N,6) external generalised forces of the previous step (for the work
    integral); ``clock`` = [t, n, external work, dissipated energy].
    """

    x: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w: np.ndarray
    f_prev: np.ndarray
    clock: np.ndarray

    @property
    def t(self) -> float:
        return float(self.clock[0])

    @property
    def n(self) -> int:
        return int(self.clock[1])

    def copy(self) -> "State":
        return State(*(a.copy() for a in self))


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
    """Work arrays reused every step (the hot loop allocates nothing)."""

    S: np.ndarray
    F: np.ndarray
    v_new: np.ndarray
    w_new: np.ndarray
    s_el: np.ndarray
    q_tmp: np.ndarray
    A: np.ndarray
    PHI: np.ndarray
    PHIt: np.ndarray
    Bg: np.ndarray
    BM: np.ndarray
    W: np.ndarray
    lam: np.ndarray
    jphi: np.ndarray
    jB: np.ndarray
    jphit: np.ndarray
    prim_phi: np.ndarray
    prim_B: np.ndarray
    T: np.ndarray
    A_m: np.ndarray
    A_s: np.ndarray
    MT: np.ndarray
    TMT: np.ndarray
    rhs: np.ndarray
    r4: np.ndarray

    @classmethod
    def for_model(cls, model: Model) -> "Scratch":
        N, m = model.mass.shape[0], model.n_constraints
        return cls(np.zeros((N, 6)), np.zeros((N, 6)), np.zeros((N, 3)), np.zeros((N, 3)), np.zeros(40),
                   np.zeros(4), np.zeros(9), np.zeros(m), np.zeros(m), np.zeros((m, 6 * N)), np.zeros((m, 6 * N)),
                   np.zeros((m, m)), np.zeros(m), np.zeros(6), np.zeros((6, 12)), np.zeros(6), np.zeros(10),
                   np.zeros(120), np.zeros((12, 9)), np.zeros(9), np.zeros(9), np.zeros((12, 9)), np.zeros((9, 9)),
                   np.zeros(9), np.zeros(4))
