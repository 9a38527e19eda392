"""Sparsity of the constraint equations: B's block pattern and the fill of B M⁻¹ Bᵀ.

Every joint k contributes an ``m_k × 12`` block of the constraint Jacobian B,
columns ``[v_i | ω_i | v_j | ω_j]`` of its two nodes i and j (j = −1 the
ground, whose columns are dropped).  With the lumped, block-diagonal mass
matrix M, the matrix ``W = B M⁻¹ Bᵀ`` of the staggered scheme's constraint
stage couples two joints exactly when they share a node (the ground couples
nothing: its M⁻¹ is zero).  So W is sparse with the pattern of the **joint
graph** (vertices the joints, edges the shared nodes), fixed at model assembly.

This module does the symbolic work once, in Python, when the model is built:

1. :func:`joint_graph` — the joint graph;
2. :func:`elimination_order` — a minimum-degree ordering of the joints
   (George & Liu, *Computer Solution of Large Sparse Positive Definite
   Systems*, 1981, ch. 5): eliminating a leaf of a chain or tree creates no
   fill, so chains and trees factor in O(number of joints); a closed loop
   fills one row of blocks along the loop (the loop "fill");
3. :func:`constraint_pattern` — the pattern of the Cholesky factor L of the
   permuted W, row by row, with the joints' rows kept together, as index
   arrays in compressed-column form (diagonal first in each column), plus
   the row-wise view the numeric factorisation needs and the slots in L where
   each product of two joints' blocks lands.

The numeric factorisation over that fixed pattern is compiled
(``reference/joints/assembly.py``: a left-looking column Cholesky, George &
Liu ch. 2, without supernodes).  For solvers that build their own sparse
systems (scipy.sparse), :func:`jacobian_row_columns` gives the global column
of every entry of the joint blocks (the implicit algorithms' Newton matrix is
laid out with it) and :func:`jacobian_csr_structure` B's CSR structure with the
map from the per-joint blocks to its data, so there is one description of B's
sparsity.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


def joint_graph(jt_i: np.ndarray, jt_j: np.ndarray) -> list[set[int]]:
    """Neighbours of each joint: the other joints sharing one of its nodes (the ground excluded)."""
    by_node: dict[int, list[int]] = {}
    for k, (i, j) in enumerate(zip(jt_i.tolist(), jt_j.tolist())):
        if i == j:
            raise ValueError(f"joint {k} joins node {i} to itself")
        for n in (i, j):
            if n >= 0:
                by_node.setdefault(n, []).append(k)
    adj: list[set[int]] = [set() for _ in range(len(jt_i))]
    for joints in by_node.values():
        for a in joints:
            adj[a].update(joints)
    for a, nb in enumerate(adj):
        nb.discard(a)
    return adj


FILL_DEGREE = 24
"""Above this many neighbours a vertex's fill is taken as its upper bound ``d(d−1)/2``
instead of being counted (a hub joins many joints, which are mostly one clique already)."""


def elimination_order(adjacency: list[set[int]], weight: np.ndarray, group=None) -> np.ndarray:
    """Minimum-fill elimination order of a graph (the joints, weighted by their rows).

    Eliminating a vertex joins its remaining neighbours into a clique; the
    vertex chosen next is the one adding the fewest new edges (minimum fill,
    "minimum deficiency", George & Liu 1981 §5.1; counted up to ``FILL_DEGREE``
    neighbours), then the one of least degree
    (total weight of its neighbours), then the lowest index (the deck's order).
    The joint graph of a chain or a tree is chordal: it always has a vertex of
    zero fill, so this order factors it without any fill.  Vertices of a lower
    ``group`` (default: all 0) go first (the constraint stage puts the
    regularised joints, ε > 0, in group 1: eliminated last, they are the ones a
    redundancy is attributed to).

    Returns
    -------
    order : int array (n,)
        ``order[p]`` is the vertex eliminated p-th.
    """
    import heapq

    n = len(adjacency)
    adj = [set(nb) for nb in adjacency]
    weight = np.asarray(weight, dtype=np.int64)
    group = np.zeros(n, dtype=np.int64) if group is None else np.asarray(group, dtype=np.int64)

    def key(a):
        nb = list(adj[a])
        if len(nb) <= FILL_DEGREE:
            fill = sum(1 for u in range(len(nb)) for v in nb[u + 1:] if v not in adj[nb[u]])
        else:  # a hub: its bound, without the quadratic count
            fill = len(nb) * (len(nb) - 1) // 2
        return (int(group[a]), fill, int(sum(weight[b] for b in nb)), a)

    current = [key(a) for a in range(n)]
    heap = list(current)
    heapq.heapify(heap)
    alive = np.ones(n, dtype=bool)
    order = np.empty(n, dtype=np.int64)
    p = 0
    while heap:
        k = heapq.heappop(heap)
        a = k[3]
        if not alive[a] or k != current[a]:
            continue
        alive[a] = False
        order[p] = a
        p += 1
        nb = adj[a]
        for b in nb:
            adj[b].discard(a)
            adj[b] |= nb - {b}
        affected = set(nb)
        for b in nb:
            affected |= adj[b]
        for b in affected:
            current[b] = key(b)
            heapq.heappush(heap, current[b])
        adj[a] = set()
    return order


class ConstraintPattern(NamedTuple):
    """Fixed sparsity of the constraint stage (all arrays int64, rows m, nonzeros of L nnz); the
    :class:`~reference.state.Model`'s ``joints.pattern``.

    Attributes
    ----------
    row_perm, row_iperm : (m,)
        Elimination position → constraint row, and its inverse.
    L_colptr, L_rowidx : (m+1,), (nnz,)
        Compressed columns of L in elimination positions, the diagonal first
        in each column, the rows ascending.
    L_rowptr, L_rowcol, L_rowpos : (m+1,), (nnz−m,), (nnz−m,)
        Row view of L's strictly lower part: for row p, the columns c < p with
        ``L[p, c] ≠ 0`` (ascending) and the position of that entry in ``L_rowidx``.
    wc_joints : (T, 4)
        One row per pair of joint blocks meeting at a node:
        ``[joint a, joint b, side of the node in a, side in b]`` (side 0 = node i,
        1 = node j), with a ≥ b.
    wc_pos : (T, 6, 6)
        The slot in L's values of ``W[row0_a + r, row0_b + s]`` (lower triangle,
        elimination positions), −1 where the entry is not stored (padding, or the
        upper triangle of a diagonal block).
    """

    row_perm: np.ndarray
    row_iperm: np.ndarray
    L_colptr: np.ndarray
    L_rowidx: np.ndarray
    L_rowptr: np.ndarray
    L_rowcol: np.ndarray
    L_rowpos: np.ndarray
    wc_joints: np.ndarray
    wc_pos: np.ndarray

    @property
    def nnz(self) -> int:
        return int(self.L_rowidx.shape[0])


def _row_view(L_colptr, L_rowidx, m):
    """The row view of L's strictly lower part: ``L_rowptr`` (m+1,), and per row its columns
    ``L_rowcol`` (ascending) and their positions ``L_rowpos`` in ``L_rowidx``."""
    counts = np.zeros(m + 1, dtype=np.int64)
    for c in range(m):
        for s in range(L_colptr[c] + 1, L_colptr[c + 1]):
            counts[L_rowidx[s] + 1] += 1
    L_rowptr = np.cumsum(counts)
    fill = L_rowptr[:-1].copy()
    L_rowcol = np.zeros(L_rowptr[-1], dtype=np.int64)
    L_rowpos = np.zeros(L_rowptr[-1], dtype=np.int64)
    for c in range(m):  # ascending columns → each row's columns ascending
        for s in range(L_colptr[c] + 1, L_colptr[c + 1]):
            r = L_rowidx[s]
            L_rowcol[fill[r]] = c
            L_rowpos[fill[r]] = s
            fill[r] += 1
    return L_rowptr, L_rowcol, L_rowpos


def _block_products(jt_i, jt_j, jt_neq, adjacency, row0, row_iperm, L_colptr, L_rowidx, m):
    """The products of joint blocks meeting at a node (``[a, b, side in a, side in b]``, a ≥ b) and
    the slots of their entries in L's values (−1: not stored)."""
    J = len(jt_i)
    slot = {}
    for c in range(m):
        for s in range(L_colptr[c], L_colptr[c + 1]):
            slot[(int(L_rowidx[s]), c)] = s
    pairs, positions = [], []
    nodes = np.stack([jt_i, jt_j], axis=1) if J else np.zeros((0, 2), np.int64)
    for a in range(J):
        for b in [a] + sorted(b for b in adjacency[a] if b < a):
            for sa in range(2):
                for sb in range(2):
                    n = nodes[a, sa]
                    if n < 0 or n != nodes[b, sb]:
                        continue
                    pos = np.full((6, 6), -1, dtype=np.int64)
                    for r in range(jt_neq[a]):
                        for s in range(jt_neq[b]):
                            pr, ps = row_iperm[row0[a] + r], row_iperm[row0[b] + s]
                            if a == b and pr < ps:
                                continue
                            pos[r, s] = slot[(int(max(pr, ps)), int(min(pr, ps)))]
                    pairs.append((a, b, sa, sb))
                    positions.append(pos)
    return pairs, positions


def constraint_pattern(jt_i: np.ndarray, jt_j: np.ndarray, jt_neq: np.ndarray, group=None,
                       order: np.ndarray | None = None) -> ConstraintPattern:
    """Symbolic factorisation of ``W = B M⁻¹ Bᵀ`` for joints ``jt_i``, ``jt_j`` with ``jt_neq`` rows each.

    ``order`` (joint elimination order) defaults to :func:`elimination_order`
    of the joint graph with the joints' ``group``.  The fill is computed on the joint graph (blocks of
    rows), so L's pattern is a union of dense joint-by-joint blocks.
    """
    jt_i, jt_j = np.asarray(jt_i, dtype=np.int64), np.asarray(jt_j, dtype=np.int64)
    jt_neq = np.asarray(jt_neq, dtype=np.int64)
    J = len(jt_i)
    adjacency = joint_graph(jt_i, jt_j)
    if order is None:
        order = elimination_order(adjacency, jt_neq, group)
    order = np.asarray(order, dtype=np.int64)
    rank = np.empty(J, dtype=np.int64)
    rank[order] = np.arange(J)
    row0 = np.concatenate([[0], np.cumsum(jt_neq)[:-1]]) if J else np.zeros(0, dtype=np.int64)
    m = int(jt_neq.sum())
    # elimination positions: the joints' rows stay together, in the joints' elimination order
    pos0 = np.zeros(J, dtype=np.int64)
    acc = 0
    for a in order:
        pos0[a] = acc
        acc += jt_neq[a]
    row_iperm = np.concatenate([pos0[a] + np.arange(jt_neq[a]) for a in range(J)]) if J else np.zeros(0, np.int64)
    row_perm = np.empty(m, dtype=np.int64)
    row_perm[row_iperm] = np.arange(m)
    # block fill: eliminating joint a joins its later neighbours into a clique
    later = [set(b for b in adjacency[a] if rank[b] > rank[a]) for a in range(J)]
    for a in order:
        nb = sorted(later[a], key=rank.__getitem__)
        if nb:
            first = nb[0]  # the parent in the elimination tree collects the others (George & Liu 1981)
            later[first].update(b for b in nb[1:])
    colptr = [0]
    rowidx: list[int] = []
    for a in order:
        blocks = sorted(later[a], key=rank.__getitem__)
        below = np.concatenate([pos0[b] + np.arange(jt_neq[b]) for b in blocks]) if blocks else np.zeros(0, np.int64)
        for u in range(jt_neq[a]):
            p = pos0[a] + u
            rowidx.append(p)
            rowidx.extend(range(p + 1, pos0[a] + jt_neq[a]))
            rowidx.extend(below.tolist())
            colptr.append(len(rowidx))
    L_colptr = np.array(colptr, dtype=np.int64)
    L_rowidx = np.array(rowidx, dtype=np.int64)
    L_rowptr, L_rowcol, L_rowpos = _row_view(L_colptr, L_rowidx, m)
    pairs, positions = _block_products(jt_i, jt_j, jt_neq, adjacency, row0, row_iperm, L_colptr, L_rowidx, m)
    return ConstraintPattern(
        row_perm=row_perm, row_iperm=row_iperm, L_colptr=L_colptr, L_rowidx=L_rowidx, L_rowptr=L_rowptr,
        L_rowcol=L_rowcol, L_rowpos=L_rowpos,
        wc_joints=np.array(pairs, dtype=np.int64).reshape(-1, 4),
        wc_pos=np.array(positions, dtype=np.int64).reshape(-1, 6, 6),
    )


def jacobian_row_columns(jt_i, jt_j, jt_neq, dof6: np.ndarray) -> np.ndarray:
    """The global column of each entry of the joint blocks of B: (m, 12) ints, −1 dropped.

    Row r of joint k has the block columns ``[v_i | ω_i | v_j | ω_j]``; ``dof6``
    (N, 6) maps a node coordinate to its global column (−1: not an unknown, e.g.
    a fixed coordinate).  The ground's columns are −1.  Both the explicit
    scheme's sparse stage (:func:`jacobian_csr_structure`) and the implicit
    algorithms' Newton matrix (``reference.algorithms.implicit.newton_pattern``)
    lay out B with it.
    """
    none = np.full(6, -1, dtype=np.int64)
    out = []
    for i, j, m in zip(np.asarray(jt_i).tolist(), np.asarray(jt_j).tolist(), np.asarray(jt_neq).tolist()):
        idx = np.concatenate([dof6[n] if n >= 0 else none for n in (i, j)])
        out += [idx] * m
    return np.array(out, dtype=np.int64).reshape(-1, 12)


def jacobian_csr_structure(jt_i, jt_j, jt_neq, n_nodes: int):
    """CSR structure of the global B (m × 6N, columns ``[v_n | ω_n]`` per node) from the joint blocks.

    Returns ``(indptr, indices, source)``: with the per-joint blocks ``Bj``
    (J, 6, 12) as filled by ``reference.joints.assembly.assemble_constraints``,
    ``scipy.sparse.csr_matrix((Bj.reshape(-1)[source], indices, indptr),
    shape=(m, 6 * n_nodes))`` is B; the structure is fixed for a model, so only
    the gather ``Bj.reshape(-1)[source]`` is repeated per evaluation.
    """
    jt_i, jt_j, jt_neq = (np.asarray(a, dtype=np.int64) for a in (jt_i, jt_j, jt_neq))
    if np.any(jt_i == jt_j):
        raise ValueError(f"joint {int(np.flatnonzero(jt_i == jt_j)[0])} joins a node to itself")
    if max(jt_i.max(initial=-1), jt_j.max(initial=-1)) >= n_nodes:
        raise ValueError("a joint refers to a node beyond n_nodes")
    columns = jacobian_row_columns(jt_i, jt_j, jt_neq, np.arange(6 * n_nodes, dtype=np.int64).reshape(-1, 6))
    joint = np.repeat(np.arange(len(jt_i)), jt_neq)
    local = np.concatenate([np.arange(m) for m in jt_neq.tolist()]) if len(jt_i) else np.zeros(0, np.int64)
    indptr, indices, source = [0], [], []
    for r in range(columns.shape[0]):
        order = np.argsort(columns[r], kind="stable")
        order = order[columns[r][order] >= 0]
        indices.extend(columns[r][order].tolist())
        source.extend(((joint[r] * 6 + local[r]) * 12 + order).tolist())
        indptr.append(len(indices))
    return np.array(indptr, dtype=np.int64), np.array(indices, dtype=np.int64), np.array(source, dtype=np.int64)
