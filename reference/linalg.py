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
systems).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla


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

    def matrix(self, values: np.ndarray) -> sps.csc_matrix:
        """The CSC matrix of the block ``values`` (K,) (same order as ``rows``/``cols``)."""
        data = np.bincount(self.slot, weights=values[self.keep], minlength=self.nnz)
        return sps.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


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
