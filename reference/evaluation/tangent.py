"""The Newton matrix of the implicit algorithms: its block pattern and its values.

Newton matrix with coefficients ``(c_m, c_c, c_k)`` (static: 0, 0, 1;
generalized-α: 1, γ'/β', 1/β')::

    [ c_m M + c_c C + c_k K    Bᵀ  ] [δ]      [c_k r]
    [ B                      −ε/c_k] [μ]  = − [Φ − ελ]

``C = ∂r/∂V`` (damping, the gyroscopic tangent and the force elements' dampers),
``K = ∂r/∂δ`` at fixed velocities: the element families' tangent stiffness
(material + geometric, :func:`reference.elements.families.tangent_values`), the
joints' λ-weighted constraint Hessian ``∂(Bᵀλ)/∂δ``
(:func:`reference.joints.hessian.joint_rows_hessian`), the follower-load tangents
and the force elements' stiffness — all sympy-derived kernels
(``reference/generated/tangents.py``, ``reference/generated/forces.py``;
docs/tangents.md), exact derivatives under the update ``x ← x + δx``,
``q ← q ⊗ exp(δθ)``, so that Newton converges quadratically.

:func:`newton_pattern` lays the blocks out once per model
(:class:`reference.linalg.BlockPattern`); :func:`tangent_values` writes their
values in that order: the nodes' 6×6 blocks, the elements' (family by family),
the joints' Hessian blocks, B's rows and columns, the −ε diagonal, the force elements'.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.elements.families import tangent_values as element_tangent_values
from reference.evaluation.force_elements import force_element_tangent
from reference.generated import tangents as generated_tangents
from reference.interactions import tf_value
from reference.jit import inlined, kernel, named, parallel_kernel, prange
from reference.joints.hessian import joint_rows_hessian
from reference.joints.sparse import jacobian_row_columns
from reference.linalg import BlockPattern
from reference.newton_blocks import times_right_jacobian
from reference.parallel import CHUNK, PARALLEL_NODES, n_chunks
from reference.state import Model


class TangentWork(NamedTuple):
    """The scratch of :func:`tangent_values`, made once per Newton system (:meth:`for_sizes`): ``weights``
    (10,) the joint primitives' multiplier weights of a constraint Hessian, ``B_row`` (1, 12) one row of B
    times ``J_r(ψ)``, ``Jr`` (9,) a node's tangent operator ``J_r(ψ)``, ``J9`` (9,) a node's inertia tensor
    (row-major) for the gyroscopic tangent, ``K12`` (12, 12) a joint's or force element's block, ``Kel`` (flat)
    one element's tangent block, the largest family's (``block`` [entries])."""

    weights: np.ndarray
    B_row: np.ndarray
    Jr: np.ndarray
    J9: np.ndarray
    K12: np.ndarray
    Kel: np.ndarray

    @classmethod
    def for_sizes(cls, block: int) -> "TangentWork":
        return cls(np.zeros(10), np.zeros((1, 12)), np.zeros(9), np.zeros(9), np.zeros((12, 12)), np.zeros(block))


@inlined
def _loads_tangent(node, code_, tf_, vec, tf_kind, tf_par, q, t, i, K6, T9):
    """:func:`load_tangent` on the loads' arrays (``model.loads``, ``model.time_functions``).

    Takes 11 parameters: the loads' and the time functions' arrays :func:`_node_range` binds once, and one node's
    outputs.
    """
    for l in range(node.shape[0]):
        if node[l] != i:
            continue
        code = code_[l]
        if code != 1 and code != 2:
            continue
        tf = tf_[l]
        f = tf_value(tf_kind[tf], tf_par[tf], t)
        if code == 1:
            generated_tangents.follower_force_tangent(q[i], vec[l], T9)
            r0 = 0
        else:
            generated_tangents.dead_moment_tangent(q[i], vec[l], T9)
            r0 = 3
        for a in range(3):
            for b in range(3):
                K6[r0 + a, 3 + b] -= f * T9[3 * a + b]


@kernel
def load_tangent(model, q, t, i, K6, T9):
    """Add ``−∂F/∂δ`` of the configuration-dependent loads on node i into the 6×6 block ``K6``:
    follower forces (generated ``follower_force_tangent``) and dead moments (``dead_moment_tangent``)."""
    loads, tfs = model.loads, model.time_functions
    _loads_tangent(loads.node, loads.code, loads.tf, loads.vec, tfs.kind, tfs.par, q, t, i, K6, T9)


@inlined
def _node_range(lo, hi, node, code, tf, vec, tf_kind, tf_par, c, J, mass, q, w, psi, t, cm, cc, ck, values, p0,
                blk, Jr, J9, A):
    """The 6×6 blocks of the nodes ``lo … hi − 1`` (see :func:`_node_blocks`), node i's from ``p0 + 36 i`` on.

    Takes 24 parameters: the node range of the serial and the parallel loop, the node, load and time-function arrays
    bound once (:mod:`reference.jit`), the coefficients and each thread's scratch.
    """
    for i in range(lo, hi):
        p = p0 + 36 * i
        for a in range(6):
            for b in range(6):
                blk[a, b] = 0.0
        _loads_tangent(node, code, tf, vec, tf_kind, tf_par, q, t, i, blk, A)
        for a in range(6):
            for b in range(6):
                blk[a, b] *= ck
        times_right_jacobian(blk, 3, psi[i], Jr)
        for a in range(3):
            blk[a, a] += mass[i] * (cm + cc * c)
        for a in range(3):
            for b in range(3):
                blk[3 + a, 3 + b] += (cm + cc * c) * J[i, a, b]
        if cc != 0.0:
            for a in range(3):
                for b in range(3):
                    J9[3 * a + b] = J[i, a, b]
            generated_tangents.gyroscopic_tangent(J9, w[i], A)
            for a in range(3):
                for b in range(3):
                    blk[3 + a, 3 + b] += cc * A[3 * a + b]
        for a in range(6):
            for b in range(6):
                values[p] = blk[a, b]
                p += 1


@parallel_kernel
def _node_blocks_parallel(node, code, tf, vec, tf_kind, tf_par, c, J, mass, q, w, psi, t, cm, cc, ck, values, p):
    """The node blocks of :func:`_node_blocks` chunk by chunk in a parallel loop (:func:`_node_range` per chunk).

    Takes 18 parameters: those of :func:`_node_range` but the range and the scratch, which its parallel loop
    chooses and allocates per chunk.
    """
    N = q.shape[0]
    for k in prange(n_chunks(N)):
        blk, Jr, J9, A = np.empty((6, 6)), np.empty(9), np.empty(9), np.empty(9)
        _node_range(k * CHUNK, min(N, (k + 1) * CHUNK), node, code, tf, vec, tf_kind, tf_par, c, J, mass, q, w, psi, t,
                    cm, cc, ck, values, p, blk, Jr, J9, A)


@inlined
def _node_blocks(model, q, w, psi, t, cm, cc, ck, values, p, K12, Jr, J9, A):
    """Each node's 6×6 block: ``c_k`` times the load tangents (times ``J_r(ψ)``), the mass and damping
    ``(c_m + c_c c) M`` and ``c_c`` times the gyroscopic tangent, node after node from ``p`` on (a
    parallel loop from :data:`~reference.parallel.PARALLEL_NODES` nodes on); returns the position after them.

    Takes 14 parameters: the configuration, the coefficients c_m, c_c, c_k and the scratch of
    :func:`tangent_values`, whose node part it is.
    """
    c, J, mass = model.damping, model.nodes.inertia, model.nodes.mass
    node, code, tf, vec = model.loads.node, model.loads.code, model.loads.tf, model.loads.vec
    tf_kind, tf_par = model.time_functions.kind, model.time_functions.par
    N = q.shape[0]
    if N >= PARALLEL_NODES:
        _node_blocks_parallel(node, code, tf, vec, tf_kind, tf_par, c, J, mass, q, w, psi, t, cm, cc, ck, values, p)
        return p + 36 * N
    _node_range(0, N, node, code, tf, vec, tf_kind, tf_par, c, J, mass, q, w, psi, t, cm, cc, ck, values, p,
                K12[:6, :6], Jr, J9, A)
    return p + 36 * N


@inlined
def _joint_blocks(model, x, q, psi, t, lam, ck, ce, values, p, w_, tw):
    """The joints' λ-weighted constraint Hessians ``c_k ∂(Bᵀλ)/∂δ`` (12×12 each), B's rows (times
    ``J_r(ψ)``) and columns, and the −ε diagonal times ``c_e``; returns the position after them.

    Takes 12 parameters: the configuration, λ, the coefficients c_k, c_e and the work tuples of
    :func:`tangent_values`, whose joint part it is.
    """
    S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi, prim_B, fe, element_work = w_
    K12, Jr, Bs = tw.K12, tw.Jr, tw.B_row
    joints, tfs = model.joints, model.time_functions
    NJ = joints.i.shape[0]
    m = lam.shape[0]
    for k in range(NJ):
        if ck != 0.0:
            neq = joints.neq[k]
            r0 = joints.row0[k]
            tf = joints.tf[k]
            joint_rows_hessian(x, q, joints.i[k], joints.j[k], joints.par[k], joints.rows[k], joints.drive[k],
                               tfs.kind[tf], tfs.par[tf], t, lam[r0:r0 + neq], jphi[:neq], jB[:neq], jphit[:neq],
                               K12, prim_phi, prim_B, tw.weights)
        else:
            K12[:, :] = 0.0
        times_right_jacobian(K12, 3, psi[joints.i[k]], Jr)
        if joints.j[k] >= 0:
            times_right_jacobian(K12, 9, psi[joints.j[k]], Jr)
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b]
                p += 1
    for k in range(NJ):
        for rr in range(joints.row0[k], joints.row0[k] + joints.neq[k]):
            for b in range(12):
                Bs[0, b] = Bl[rr, b]
            times_right_jacobian(Bs, 3, psi[joints.i[k]], Jr)
            if joints.j[k] >= 0:
                times_right_jacobian(Bs, 9, psi[joints.j[k]], Jr)
            for b in range(12):
                values[p] = Bs[0, b]
                p += 1
    for rr in range(m):
        for b in range(12):
            values[p] = Bl[rr, b]
            p += 1
    for rr in range(m):
        values[p] = -joints.eps[rr] * ce
        p += 1
    return p


@inlined
def _force_element_blocks(model, x, q, psi, t, cc, ck, values, p, w_, K12, Jr):
    """The force elements' blocks ``c_k K T + c_c C`` at the velocities and angles of the last
    evaluation, K with the actuator forces' tangent; returns the position after them.

    Takes 12 parameters: the configuration, the coefficients c_c, c_k and the work and scratch of
    :func:`tangent_values`, whose force-element part it is.
    """
    S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi, prim_B, fe, element_work = w_
    G, angle, fe_e, fe_B, fe_G, C12, fv, fw, fe_out = fe
    elements, tfs = model.force_elements, model.time_functions
    for k in range(elements.kind.shape[0]):
        force_element_tangent(model, x, q, fv, fw, angle, k, K12, C12, fe_e, fe_B, fe_G)
        tf = elements.tf[k]
        if tf >= 0:
            # a point-to-point actuator force f_a(t) (an external load −B_ℓᵀ f_a turning with the line):
            # its tangent f_a G_ℓ, G_ℓ the tangent of the length's Jacobian row that
            # force_element_tangent leaves in the first 144 entries of its work array
            fa = tf_value(tfs.kind[tf], tfs.par[tf], t)
            nc = 12 if elements.j[k] >= 0 else 6
            for a in range(nc):
                for b in range(nc):
                    K12[a, b] += fa * fe_G[12 * a + b]
        times_right_jacobian(K12, 3, psi[elements.i[k]], Jr)
        if elements.j[k] >= 0:
            times_right_jacobian(K12, 9, psi[elements.j[k]], Jr)
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b] + cc * C12[a, b]
                p += 1
    return p


@kernel
def tangent_values(model, x, q, w, psi, t, lam, cm, cc, ck, ce, values, w_, tw):
    """Block values of the Newton matrix (order of :func:`newton_pattern`) into ``values``; returns
    how many were written.

    ``c_e`` multiplies the −ε diagonal (``1/c_k`` in Newton); with ``c_k = 0`` the
    stiffness blocks are zero and not computed (the mass matrix of the initial accelerations).
    ``psi`` (N,3): when the unknown rotation δ enters as ``q = q_n ⊗ exp(ψ + δ)`` (generalized-α),
    the configuration-dependent blocks are multiplied on the right by the tangent operator
    ``J_r(ψ)`` of each node (``exp(ψ + δ) = exp(ψ) exp(J_r(ψ) δ) + O(δ²)``); zeros for the
    static update ``q ⊗ exp(δ)``.  The force elements' blocks come last, at the velocities and
    angles of the last :func:`reference.algorithms.implicit.evaluate`.  ``w_`` the implicit
    algorithms' work tuple (:func:`reference.algorithms.implicit.work_tuple`); ``tw`` the scratch
    (:class:`TangentWork`, or its :func:`reference.jit.boundary` copy).

    Takes 14 parameters: the compiled entry from Python, given the Model, the iterate (x, q, w, ψ, t, λ), the Newton
    matrix's four coefficients and the work tuples.
    """
    model, tw = named(model, Model), named(tw, TangentWork)
    A = w_[6]
    p = _node_blocks(model, q, w, psi, t, cm, cc, ck, values, 0, tw.K12, tw.Jr, tw.J9, A)
    p = element_tangent_values(model.elements, w_[13], x, q, psi, ck, values, p, tw.Jr, tw.Kel)
    p = _joint_blocks(model, x, q, psi, t, lam, ck, ce, values, p, w_, tw)
    return _force_element_blocks(model, x, q, psi, t, cc, ck, values, p, w_, tw.K12, tw.Jr)


def newton_pattern(model) -> tuple[BlockPattern, np.ndarray]:
    """The block pattern of the Newton matrix and the unknown index of every node coordinate.

    Returns the :class:`~reference.linalg.BlockPattern` and ``dof`` (N,6): the
    unknown of each coordinate, −1 if fixed; the multipliers follow the free coordinates.
    """
    N, m = model.nodes.mass.shape[0], model.n_constraints
    free = model.nodes.free.reshape(-1) > 0.5
    dof = np.full(6 * N, -1, dtype=np.int64)
    dof[free] = np.arange(int(free.sum()))
    n_free = int(free.sum())
    dof6 = dof.reshape(N, 6)
    rows, cols = [], []

    def blocks(nodes):
        """The square blocks of the node lists ``nodes`` (B, k) (−1 the ground), row-major each, in order."""
        nodes = np.asarray(nodes, dtype=np.int64)
        idx = np.where(nodes[:, :, None] >= 0, dof6[np.maximum(nodes, 0)], -1).reshape(nodes.shape[0],
                                                                                       6 * nodes.shape[1])
        n = idx.shape[1]
        rows.append(np.repeat(idx, n, axis=1).reshape(-1))
        cols.append(np.tile(idx, (1, n)).reshape(-1))

    blocks(np.arange(N)[:, None])
    for data in model.elements:
        blocks(data.conn)
    blocks(np.stack([model.joints.i, model.joints.j], axis=1))
    row_dofs = jacobian_row_columns(model.joints.i, model.joints.j, model.joints.neq, dof6)
    for rr, idx in enumerate(row_dofs):
        rows.append(np.full(12, n_free + rr))
        cols.append(idx)
    for rr, idx in enumerate(row_dofs):
        rows.append(idx)
        cols.append(np.full(12, n_free + rr))
    rows.append(n_free + np.arange(m))
    cols.append(n_free + np.arange(m))
    blocks(np.stack([model.force_elements.i, model.force_elements.j], axis=1))
    rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    cols = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
    return BlockPattern(rows, cols, n_free + m), dof6


