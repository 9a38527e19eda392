"""Plain data for time stepping: the assembled model and the state.

Both are named tuples of numpy arrays so that the compiled kernels take them
as they are (numba passes named tuples of arrays without copying).  An
algorithm step is a function ``(model, state) → state``; nothing else is
carried between steps.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.elements.families import family_of


class Model(NamedTuple):
    """Everything about the system that does not change during a run.

    Nodes (N): ``mass`` (N,) [kg], ``inertia`` (N,3,3) body frame [kg m²]
    (a full tensor where beams meet at an angle), ``inertia_inv`` (N,3,3) the
    inverse of its block of free rotations, zero-padded, ``free`` (N,6) 1.0 for a free and 0.0 for a fixed
    coordinate (translations inertial, rotations body frame).
    Elements: ``elements``, a tuple with one entry per element family present
    (:mod:`reference.elements.families`, in registry order), each the family's
    plain data (e.g. :class:`reference.elements.beam2.Beam2Data`), whose first
    fields are ``conn`` (E_f, n) and ``index`` (E_f,) the elements' numbers in
    the Domain.  **Offsets**: a family with section frames keeps per element
    end the constant Euler parameters ``o_a`` of the rotation from the frame
    of its node to the element's own section frame there, ``Λ_a = A(q_a) A(o_a)``,
    i.e. section quaternion ``p_a = q_a ⊗ o_a``; fixed at t = 0 as
    ``o_a = q_a⁰* ⊗ p_a⁰``; the identity ``(1, 0, 0, 0)`` where the node frame is
    the section frame (a straight beam's own nodes).  Body-frame quantities of
    an end transform as ``δθ_section = A(o_a)ᵀ δθ_node``, forces as
    ``S_θ,node = A(o_a) S_θ,section`` (see
    :func:`reference.elements.formulation.section_quaternion` and
    :func:`~reference.elements.formulation.to_node_frame`).
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
    ``jt_tf`` (J,) time function; ``row_eps`` (m,) the ε of each row.
    Sparsity of ``B M⁻¹ Bᵀ`` (fixed at assembly,
    :class:`reference.joints.sparse.ConstraintPattern`): ``row_iperm`` (m,)
    each row's elimination position; the Cholesky factor's pattern
    ``L_colptr`` (m+1,), ``L_rowidx`` (nnz,), its row view ``L_rowptr``
    (m+1,), ``L_rowcol``, ``L_rowpos`` (nnz−m,); the block products
    ``wc_joints`` (T,4) and their slots ``wc_pos`` (T,6,6).
    ``node_constrained`` (N,) 1 for a node of a joint (either formulation),
    else 0; ``constrained_nodes`` (C,) those nodes.
    Master/slave joints (K): ``ms_master``, ``ms_slave`` (K,) node indices,
    ``ms_kind`` (K,) 0 spherical 1 revolute, ``ms_par`` (K,9) the master's
    body-fixed offset and axis and the slave's body-fixed axis.
    ``load_arm`` (L,3) body-fixed point of application of a force load
    (zero: at the node; the moment ``arm × force`` follows).
    Force elements (F, :mod:`reference.forces`): ``fe_kind`` (F,),
    ``fe_i``, ``fe_j`` (F,) node indices (−1 the ground), ``fe_par`` (F,24)
    body-fixed points and frames (the joint layout), ``fe_k``, ``fe_c`` (F,6)
    stiffnesses and dampings per measure, ``fe_rest`` (F,) rest length or
    angle, ``fe_tf`` (F,) actuator time function (−1 none).
    """

    mass: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    free: np.ndarray
    elements: tuple
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
    row_iperm: np.ndarray
    L_colptr: np.ndarray
    L_rowidx: np.ndarray
    L_rowptr: np.ndarray
    L_rowcol: np.ndarray
    L_rowpos: np.ndarray
    wc_joints: np.ndarray
    wc_pos: np.ndarray
    node_constrained: np.ndarray
    constrained_nodes: np.ndarray
    ms_master: np.ndarray
    ms_slave: np.ndarray
    ms_kind: np.ndarray
    ms_par: np.ndarray
    load_arm: np.ndarray
    fe_kind: np.ndarray
    fe_i: np.ndarray
    fe_j: np.ndarray
    fe_par: np.ndarray
    fe_k: np.ndarray
    fe_c: np.ndarray
    fe_rest: np.ndarray
    fe_tf: np.ndarray

    @property
    def n_constraints(self) -> int:
        return int(self.row_eps.shape[0])

    @property
    def n_elements(self) -> int:
        return sum(int(data.conn.shape[0]) for data in self.elements)


class State(NamedTuple):
    """The state at step n.

    ``x`` (N,3) positions, ``q`` (N,4) Euler parameters at ``t_n``; ``v``
    (N,3) inertial and ``w`` (N,3) body-frame velocities at ``t_{n−½}``
    (before the first step: the initial velocities at ``t_0``); ``f_prev``
    (N,6) external generalised forces of the previous step (for the work
    integral); ``clock`` = [t, n, external work, dissipated energy];
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
        return float(self.clock[0])

    @property
    def n(self) -> int:
        return int(self.clock[1])

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
    """Energy-balance guard ``[E₀, S, tolerance, residual, energy]`` (:mod:`reference.monitor`): an
    algorithm that supports it stops when the residual exceeds tolerance × S; tolerance 0 turns it off."""
    elements: tuple
    G: np.ndarray

    @classmethod
    def for_model(cls, model: Model) -> "Scratch":
        N, m, J = model.mass.shape[0], model.n_constraints, model.jt_i.shape[0]
        return cls(np.zeros((N, 6)), np.zeros((N, 6)), np.zeros((N, 3)), np.zeros((N, 3)),
                   np.zeros(4), np.zeros(9), np.zeros(m), np.zeros(m), np.zeros((J, 6, 12)), np.zeros((J, 6, 12)),
                   np.zeros(model.L_rowidx.shape[0]), np.zeros(m), np.zeros(m), np.zeros(10),
                   np.zeros(120), np.zeros((12, 9)), np.zeros(9), np.zeros(9), np.zeros((12, 9)), np.zeros((9, 9)),
                   np.zeros(9), np.zeros(4), np.zeros(5), element_work(model), np.zeros((N, 6)))
