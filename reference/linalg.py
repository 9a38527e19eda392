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
``numpy.bincount``) and refactorises numerically (:func:`factorize`, SuperLU
with partial pivoting, which handles the zero block of the saddle-point
systems).  Compiled loops solve with the factors through :func:`lu_solve`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.jit import kernel


class SingularMatrix(ArithmeticError):
    """The factorisation met an exactly singular matrix."""


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
    diag = lu.U.diagonal()
    if not np.all(np.isfinite(diag)):
        raise SingularMatrix("non-finite pivot")
    big = np.max(np.abs(diag)) if diag.size else 0.0
    if diag.size and np.min(np.abs(diag)) <= 1e-14 * big:
        raise SingularMatrix("pivot below 1e-14 of the largest (the matrix is numerically singular)")
    return lu


def factor_arrays(lu) -> tuple:
    """The SuperLU factors as plain arrays for :func:`lu_solve`:
    ``(Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c)`` with ``Pr A Pc = L U`` (CSC L and U)."""
    L, U = lu.L.tocsc(), lu.U.tocsc()
    return (L.indptr.astype(np.int64), L.indices.astype(np.int64), L.data, U.indptr.astype(np.int64),
            U.indices.astype(np.int64), U.data, lu.perm_r.astype(np.int64), lu.perm_c.astype(np.int64))


@kernel
def lu_solve(f, b, work, x):
    """Solve ``A x = b`` with the factor arrays ``f`` of :func:`factor_arrays` (compiled, no allocation).

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
