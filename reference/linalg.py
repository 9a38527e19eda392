"""Sparse linear algebra of the implicit algorithms (scipy.sparse, SuperLU).

The Newton matrices of :mod:`reference.algorithms.static` and
:mod:`reference.algorithms.generalized_alpha` are assembled from fixed dense
blocks (a node's 6×6 inertia block, an element's 12×12 tangent, a joint's
12×12 λ-weighted constraint Hessian, its rows of B and Bᵀ).  The **symbolic**
work is done once per model by :class:`BlockPattern`: the row and column of
every block entry, which entries survive (fixed coordinates are removed from
the unknowns), and the position of each surviving entry in the compressed
sparse column (CSC) arrays, repeated entries summed.  Every Newton iteration
then only scatters the new block values into the CSC data (one
``numpy.bincount``) and refactorises numerically (:class:`SparseLU`: SuperLU
with partial pivoting — which handles the zero block of the saddle-point
systems — chooses the ordering and the pivots once, the fill pattern follows
from the structure, and later matrices are refactored in compiled code with
the same permutations).  Compiled loops solve with the factors through
:func:`lu_solve`.  :func:`null_space` gives a sparse basis of the null space of a constraint
Jacobian (the linearised analyses, :mod:`reference.algorithms.linearization`).

**Singularity** is judged on the equilibrated matrix (:func:`equilibrate`): with rows and
then columns scaled to a largest entry of 1 (the scaling of LAPACK's ``dgeequ``; Higham 2002,
*Accuracy and Stability of Numerical Algorithms*, §9.8), the pivots of the same factorisation are
the raw pivots times their row and column scales, and the matrix is called singular when the
smallest of those is below :data:`SINGULAR_PIVOT` of the largest.  A test on the raw pivots
does not scale with the model: the Newton matrix of a steel mechanism holds stiffnesses of
1e8 N/m beside constraint rows of 1, and its raw pivots spread over 1e-15 although it is
regular (condition about 1e10 after scaling).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from reference.jit import kernel


SINGULAR_PIVOT = 1e-14
"""Smallest equilibrated pivot, relative to the largest, of a matrix taken as regular.  After
equilibration a regular matrix of condition κ has pivots down to about 1/κ of the largest; a
pivot of 1e-14 (≈ 50 machine epsilons) means κ ≳ 1e14, where a Newton correction has no
correct digit left, and the round-off pivot of an exactly singular matrix is of order ε."""
RANK_TOLERANCE = 1e-10
"""A singular value of a group of constraint rows below this fraction of the group's largest counts
as zero (a redundant row).  Redundant rows give round-off, ~1e-16 of the largest; the independent rows
of the shipped mechanisms stay above 1e-3 of it (their joint offsets against unit direction rows)."""
SINGULAR_MESSAGE = (f"pivot below {SINGULAR_PIVOT:g} of the largest after equilibration "
                    "(the matrix is numerically singular)")


class SingularMatrix(ArithmeticError):
    """The factorisation met a singular matrix (see :data:`SINGULAR_PIVOT`)."""


class BlockPattern:
    """The fixed sparsity pattern of a matrix assembled from block entries.

    Parameters
    ----------
    rows, cols : int arrays (K,)
        Global row and column of every block entry, in the order in which an
        assembly kernel writes their values; an index ``< 0`` drops the entry
        (a fixed coordinate, the ground).
    n : int
        Size of the square matrix.
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, n: int):
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        self.n = int(n)
        self.keep = np.flatnonzero((rows >= 0) & (cols >= 0))
        key = cols[self.keep] * self.n + rows[self.keep]
        unique, self.slot = np.unique(key, return_inverse=True)
        self.nnz = unique.shape[0]
        self.indices = (unique % self.n).astype(np.int32)
        self.indptr = np.zeros(self.n + 1, dtype=np.int32)
        np.cumsum(np.bincount(unique // self.n, minlength=self.n), out=self.indptr[1:])

        self._matrix = sps.csc_matrix((np.zeros(self.nnz), self.indices, self.indptr), shape=(self.n, self.n))
        self._matrix.has_sorted_indices = True

    def matrix(self, values: np.ndarray) -> sps.csc_matrix:
        """The CSC matrix of the block ``values`` (K,) (same order as ``rows``/``cols``).

        The matrix object is made once; its data are overwritten in place on every call.
        """
        self._matrix.data[:] = np.bincount(self.slot, weights=values[self.keep], minlength=self.nnz)
        return self._matrix

    @property
    def assembled(self) -> sps.csc_matrix:
        """The matrix object of :meth:`matrix` with its data as last written (by :meth:`matrix` or by a
        compiled loop that scatters the values itself, ``data[slot[k]] += values[keep[k]]``)."""
        return self._matrix


def factorize(matrix: sps.csc_matrix):
    """SuperLU factor of ``matrix`` (column approximate minimum degree ordering).

    Raises
    ------
    SingularMatrix
        When a pivot is exactly zero or the factor is not finite.
    """
    try:
        lu = spla.splu(matrix, permc_spec="COLAMD")
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise SingularMatrix(str(exc)) from None
    if not np.all(np.isfinite(lu.U.diagonal())):
        raise SingularMatrix("non-finite pivot")
    return lu


@kernel
def equilibrate(Ap, Ai, Ax, perm_r, inv_perm_c, rs, cs):
    """Row scales ``rs`` and column scales ``cs`` (n,) of the factored matrix ``Pr A Pc`` (CSC ``A``,
    the permutations of :class:`SparseLU`), in factored order: ``rs`` makes every row's largest
    entry 1, then ``cs`` every column's of the row-scaled matrix (an empty row or column keeps 1).
    The pivot ``u_jj`` of ``Pr A Pc = L U`` is that of the scaled matrix divided by
    ``rs[j] cs[j]`` (the diagonal scalings commute with the triangular factors)."""
    n = Ap.shape[0] - 1
    for r in range(n):
        rs[r] = 0.0
    for k in range(n):
        for p in range(Ap[k], Ap[k + 1]):
            r = perm_r[Ai[p]]
            rs[r] = max(rs[r], abs(Ax[p]))
    for r in range(n):
        rs[r] = 1.0 / rs[r] if rs[r] > 0.0 else 1.0
    for j in range(n):
        k = inv_perm_c[j]
        big = 0.0
        for p in range(Ap[k], Ap[k + 1]):
            big = max(big, abs(Ax[p]) * rs[perm_r[Ai[p]]])
        cs[j] = 1.0 / big if big > 0.0 else 1.0


@kernel
def lu_solve(f, b, work, x):
    """Solve ``A x = b`` with the factor arrays ``f = (Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c)`` of
    :class:`SparseLU` (CSC L and U with ``Pr A Pc = L U``; compiled, no allocation).

    ``y[perm_r] = b``, forward substitution with L, back substitution with U,
    ``x = w[perm_c]`` (SuperLU's ``Pr A Pc = L U``).
    """
    Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c = f
    n = b.shape[0]
    for i in range(n):
        work[perm_r[i]] = b[i]
    for j in range(n):
        d = 1.0
        for p in range(Lp[j], Lp[j + 1]):
            if Li[p] == j:
                d = Lx[p]
        zj = work[j] / d
        work[j] = zj
        for p in range(Lp[j], Lp[j + 1]):
            if Li[p] > j:
                work[Li[p]] -= Lx[p] * zj
    for j in range(n - 1, -1, -1):
        d = 1.0
        for p in range(Up[j], Up[j + 1]):
            if Ui[p] == j:
                d = Ux[p]
        zj = work[j] / d
        work[j] = zj
        for p in range(Up[j], Up[j + 1]):
            if Ui[p] < j:
                work[Ui[p]] -= Ux[p] * zj
    for i in range(n):
        x[i] = work[perm_c[i]]


@kernel
def refactor(f, Ap, Ai, Ax, inv_perm_c, w, threshold, rs, cs):
    """Numeric LU of a matrix with the pattern, row pivots and column order of the factor ``f``.

    Left-looking, column by column, on the fill pattern SuperLU found (the factor's L and U
    receive the result; ``w`` (n,) is zero on entry and on exit).  Returns 0; 1 when a pivot
    falls below ``threshold`` times the largest candidate of its column (the kept pivot
    order is no longer safe: factor afresh); 2 when the smallest equilibrated pivot (scales
    ``rs``, ``cs`` of :func:`equilibrate`, written here) is below :data:`SINGULAR_PIVOT` of the
    largest (singular).
    """
    Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c = f
    n = Ap.shape[0] - 1
    equilibrate(Ap, Ai, Ax, perm_r, inv_perm_c, rs, cs)
    dmin, dmax = math.inf, 0.0
    for j in range(n):
        k = inv_perm_c[j]
        for p in range(Ap[k], Ap[k + 1]):
            w[perm_r[Ai[p]]] += Ax[p]
        for p in range(Up[j], Up[j + 1]):
            kk = Ui[p]
            if kk >= j:
                continue
            ukj = w[kk]
            Ux[p] = ukj
            for s in range(Lp[kk], Lp[kk + 1]):
                r = Li[s]
                if r > kk:
                    w[r] -= Lx[s] * ukj
        pivot = w[j]
        big = 0.0
        for s in range(Lp[j], Lp[j + 1]):
            if Li[s] >= j:
                big = max(big, abs(w[Li[s]]))
        big = max(big, abs(pivot))
        if not abs(pivot) > threshold * big:
            for p in range(Up[j], Up[j + 1]):
                w[Ui[p]] = 0.0
            for s in range(Lp[j], Lp[j + 1]):
                w[Li[s]] = 0.0
            w[j] = 0.0
            for r in range(n):
                w[r] = 0.0
            return 1
        scaled = abs(pivot) * rs[j] * cs[j]
        dmin = min(dmin, scaled)
        dmax = max(dmax, scaled)
        for p in range(Up[j], Up[j + 1]):
            if Ui[p] == j:
                Ux[p] = pivot
            w[Ui[p]] = 0.0
        for s in range(Lp[j], Lp[j + 1]):
            r = Li[s]
            if r == j:
                Lx[s] = 1.0
            elif r > j:
                Lx[s] = w[r] / pivot
            w[r] = 0.0
        w[j] = 0.0
    if n > 0 and not dmin > SINGULAR_PIVOT * dmax:
        return 2
    return 0


@kernel
def _heap_push(heap, size, value):
    """Push ``value`` onto the binary min-heap ``heap[:size]``; return the new size."""
    i = size
    heap[i] = value
    while i > 0:
        parent = (i - 1) // 2
        if heap[parent] <= heap[i]:
            break
        heap[parent], heap[i] = heap[i], heap[parent]
        i = parent
    return size + 1


@kernel
def _heap_pop(heap, size):
    """Remove the smallest entry of the binary min-heap ``heap[:size]``; return it and the new size."""
    top = heap[0]
    size -= 1
    heap[0] = heap[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and heap[child + 1] < heap[child]:
            child += 1
        if heap[i] <= heap[child]:
            break
        heap[i], heap[child] = heap[child], heap[i]
        i = child
    return top, size


@kernel
def symbolic_lu(Ap, Ai, perm_r, inv_perm_c, Lp, Li, Up, Ui, mark):
    """Fill pattern of ``L U = Pr A Pc`` for fixed permutations, from the structure of A alone
    (explicit zeros count): column j of U ∪ L is the set reached from column j of ``Pr A Pc``
    through the columns of L before j.  Writes CSC ``Lp, Li`` (unit diagonal first) and
    ``Up, Ui`` (diagonal last), rows ascending; returns (nnz L, nnz U), or (−1, −1) when the
    capacity of ``Li``/``Ui`` is too small.  ``mark`` (3n,) integer scratch.

    The rows above the diagonal are visited in ascending order through a binary heap, each
    reached column of L once (the set of the left-looking recurrence, Gilbert & Peierls 1988);
    the cost is that of the fill, not n² per factorisation.
    """
    n = Ap.shape[0] - 1
    stamp, heap, below = mark[:n], mark[n:2 * n], mark[2 * n:3 * n]
    stamp[:] = -1
    nl, nu = 0, 0
    Lp[0], Up[0] = 0, 0
    for j in range(n):
        size, m = 0, 0
        k = inv_perm_c[j]
        stamp[j] = j
        below[m] = j
        m += 1
        for p in range(Ap[k], Ap[k + 1]):
            r = perm_r[Ai[p]]
            if stamp[r] != j:
                stamp[r] = j
                if r < j:
                    size = _heap_push(heap, size, r)
                else:
                    below[m] = r
                    m += 1
        while size > 0:
            kk, size = _heap_pop(heap, size)
            if nu >= Ui.shape[0]:
                return -1, -1
            Ui[nu] = kk
            nu += 1
            for s in range(Lp[kk], Lp[kk + 1]):
                r = Li[s]
                if stamp[r] != j:
                    stamp[r] = j
                    if r < j:
                        size = _heap_push(heap, size, r)
                    else:
                        below[m] = r
                        m += 1
        if nu >= Ui.shape[0] or nl + m > Li.shape[0]:
            return -1, -1
        Ui[nu] = j
        nu += 1
        rows = np.sort(below[:m])
        for s in range(m):
            Li[nl + s] = rows[s]
        nl += m
        Lp[j + 1], Up[j + 1] = nl, nu
    return nl, nu


class SparseLU:
    """LU factors of the matrices of one :class:`BlockPattern`, refactored cheaply.

    The first factorisation (and any whose pivots go bad) takes SuperLU's ordering and row
    pivots; the fill pattern for them is made from the structure (:func:`symbolic_lu`), and
    the numbers by :func:`refactor`.  Later matrices of the same pattern are refactored in
    compiled code with the same permutations, falling back to SuperLU when a kept pivot
    drops below ``PIVOT_THRESHOLD`` of its column.  :meth:`solve` and :func:`lu_solve` use the factor arrays ``self.f``.
    """

    PIVOT_THRESHOLD = 0.01

    def __init__(self, n: int):
        self.f = None
        self.w = np.zeros(n)
        self.work = np.zeros(n)
        self.rs, self.cs = np.zeros(n), np.zeros(n)
        self.refactored = 0
        self.fresh = 0

    def factor(self, matrix: sps.csc_matrix):
        """Factor ``matrix``; raises :class:`SingularMatrix`."""
        if self.f is not None:
            code = refactor(self.f, matrix.indptr, matrix.indices, matrix.data, self.inv_perm_c, self.w,
                            self.PIVOT_THRESHOLD, self.rs, self.cs)
            if code == 0:
                self.refactored += 1
                return self.f
            if code == 2:
                raise SingularMatrix(SINGULAR_MESSAGE)
        # SuperLU chooses the ordering and the pivots on the actual values; the fill pattern for
        # those permutations is then made from the structure (entries that happen to be zero now
        # may not be later), and the factor computed on it
        lu = factorize(matrix)
        n = matrix.shape[0]
        perm_r, perm_c = lu.perm_r.astype(np.int64), lu.perm_c.astype(np.int64)
        self.inv_perm_c = np.argsort(perm_c).astype(np.int64)
        Lp, Up, mark = np.zeros(n + 1, np.int64), np.zeros(n + 1, np.int64), np.zeros(3 * n, np.int64)
        cap = max(4 * (lu.L.nnz + lu.U.nnz), 2 * matrix.nnz, n)
        while True:
            Li, Ui = np.zeros(cap, np.int64), np.zeros(cap, np.int64)
            nl, nu = symbolic_lu(matrix.indptr, matrix.indices, perm_r, self.inv_perm_c, Lp, Li, Up, Ui, mark)
            if nl >= 0:
                break
            cap *= 2
        self.f = (Lp, Li[:nl].copy(), np.zeros(nl), Up, Ui[:nu].copy(), np.zeros(nu), perm_r, perm_c)
        self.fresh += 1
        code = refactor(self.f, matrix.indptr, matrix.indices, matrix.data, self.inv_perm_c, self.w, 0.0,
                        self.rs, self.cs)
        if code != 0:
            # 1 at threshold 0: a pivot exactly zero (or not finite) on SuperLU's own permutations,
            # where SuperLU's round-off left a nonzero one; the factor is incomplete (a compiled
            # lu_solve would divide by its zero)
            self.f = None
            raise SingularMatrix(SINGULAR_MESSAGE)
        return self.f

    def solve(self, b: np.ndarray) -> np.ndarray:
        x = np.empty_like(b)
        lu_solve(self.f, b, self.work, x)
        return x


def permutation_sign(perm) -> int:
    """The sign of a permutation (−1 for an odd number of transpositions), from its cycles
    (compiled: the arc-length path takes two per point, of a few hundred entries each)."""
    perm = np.asarray(perm, dtype=np.int64)
    return int(_permutation_sign(perm, np.zeros(perm.size, dtype=np.bool_)))


@kernel
def _permutation_sign(perm, seen):
    transpositions = 0
    for start in range(perm.shape[0]):
        length, k = 0, start
        while not seen[k]:
            seen[k] = True
            k = perm[k]
            length += 1
        transpositions += max(length - 1, 0)
    return -1 if transpositions % 2 else 1


def null_space(B: sps.csr_matrix, tol: float = RANK_TOLERANCE) -> tuple[sps.csr_matrix, int]:
    """A sparse basis Z (n, n − r) of the null space of B (m, n), and r = rank B.

    Coordinates that no row touches get identity columns.  The touched ones fall into groups that
    share rows (the joints of one loop or chain); each group's block of B is decomposed by a dense SVD
    (Golub & Van Loan 2013, §5.4.6), its rank counted with :data:`RANK_TOLERANCE`, and the right
    singular vectors of the zero singular values are its columns of Z (orthonormal).  Cost: one SVD of
    at most (rows × 12 joints) per group.
    """
    m, n = B.shape
    B = sps.csr_matrix(B)
    touched = np.zeros(n, dtype=bool)
    touched[B.indices[B.data != 0.0]] = True
    cols, rows, vals = [], [], []
    untouched = np.flatnonzero(~touched)
    rows.append(untouched)
    cols.append(np.arange(untouched.size))
    vals.append(np.ones(untouched.size))
    k, rank = untouched.size, 0
    if m:
        # the groups: coordinates linked through a common row
        link = abs(B).T @ abs(B)
        _, label = connected_components(link, directed=False)
        for g in np.unique(label[touched]):
            members = np.flatnonzero((label == g) & touched)
            sub = B[:, members]
            used = np.flatnonzero(np.diff(sub.tocsr().indptr) > 0)
            block = sub[used].toarray()
            _, s, vt = sla.svd(block, full_matrices=True)
            r = int(np.sum(s > tol * s[0])) if s.size and s[0] > 0.0 else 0
            basis = vt[r:].T
            rank += r
            rr, cc = np.nonzero(np.ones_like(basis, dtype=bool))
            rows.append(members[rr])
            cols.append(k + cc)
            vals.append(basis[rr, cc])
            k += basis.shape[1]
    Z = sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, k))
    return Z, rank
