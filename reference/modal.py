"""Modes, linear buckling and the inertia of a tangent, on the reduced linearisation (docs/formulation.md §11).

Given the reduced matrices of :func:`reference.algorithms.linearization.reduce` (``M_r``, ``D_r``, ``K_r`` on
independent coordinates):

- **undamped modes** (:func:`modes`, ``D_r = 0`` and ``K_r`` symmetric): ``K_r φ = ω² M_r φ``, the lowest
  by shift-invert Lanczos (``scipy.sparse.linalg.eigsh``; Ericsson & Ruhe 1980) about a shift slightly
  below zero, so that zero (rigid-body, mechanism) modes do not make the shifted matrix singular; dense
  ``scipy.linalg.eigh`` for small models;
- **damped or gyroscopic modes** (``D_r ≠ 0``, or ``K_r`` not symmetric: follower loads): the quadratic
  problem ``(s² M_r + s D_r + K_r) φ = 0`` in first-order form ``[0 I; −K −D] y = s [I 0; 0 M] y``
  (Tisseur & Meerbergen 2001, §3.4), shift-invert Arnoldi (``eigs``); frequency ``|Im s|/2π``, damping
  ratio ``−Re s/|s|``;
- **linear buckling** (:func:`buckling`): ``(K_0 + μ K_g) φ = 0`` with ``K_g = K_1 − K_0`` the change of
  the tangent from the unloaded state to the state under the loads of load factor 1;
- **the inertia of a tangent** (:func:`negative_eigenvalues`): the number of negative pivots of an
  ``L D Lᵀ`` factorisation with symmetric ordering (Sylvester's law of inertia).

A mode whose ``|ω²|`` is below :data:`ZERO_MODE` times the stiffness scale (the largest
``K_ii/M_ii``) is a *zero* mode; a negative ``ω²`` beyond it an *unstable* one (a divergence); a root of
the damped or gyroscopic problem whose damping ratio is below ``−``:data:`UNSTABLE_DAMPING` an unstable
one (a flutter or a divergence).
Mode shapes are mass-normalised (``φᵀ M_r φ = 1``; ``φᴴ M_r φ = 1`` for complex ones, rotated so that
the largest entry is real and positive).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.linalg import permutation_sign

ZERO_MODE = 1e-12
"""``|ω²|`` below this fraction of the stiffness scale s (:func:`stiffness_scale`) is a zero mode.  The
shift-inverted solution finds an exact zero eigenvalue orders of magnitude below it, and the lowest
elastic mode of a free, very slender beam orders of magnitude above it (docs/benchmarks.md §10), the
lowest elastic or gravity mode of the shipped decks and tests higher still."""
SHIFT = 1e-9
"""The shift of the shift-invert solutions, ``σ = −SHIFT × s`` (s as in :data:`ZERO_MODE`): ``K − σM`` is
positive definite with zero modes (condition about 1e9), σ lies below every elastic eigenvalue, and the
eigenvalues near it come out accurate to round-off of |σ| (not of the largest eigenvalue, as with the
plain ``eigh(K, M)``, which moves the same rigid modes off zero and the first elastic one visibly:
docs/benchmarks.md §10)."""
DENSE = 600
"""Reduced systems up to this size are solved densely (all eigenvalues; faster than ARPACK there)."""
DENSE_FIRST_ORDER = 200
"""First-order (damped, gyroscopic) problems up to this size (twice the reduced coordinates) are solved
densely (QZ of the pencil); above it shift-invert Arnoldi is faster, with the same frequencies, though
the real parts of imaginary roots come out less accurate than dense (the shifted pencil of a stiff beam,
its axial stiffness far above the bending one, is ill-conditioned; docs/benchmarks.md §10)."""
UNSTABLE_DAMPING = 1e-6
"""A root of the first-order problem is *unstable* when its damping ratio ``−Re s/|s|`` is below
``−UNSTABLE_DAMPING`` (its amplitude grows by more than ``2π × 1e-6`` per cycle); a smaller ``|Re s|`` is the
solver's round-off, relative to the root itself: both solvers leave less than that on the imaginary roots
of the spinning cantilever (``models/rotating_cantilever.toml``), shift-invert Arnoldi more than the dense QZ
(:data:`DENSE_FIRST_ORDER`; docs/benchmarks.md §10).  The same bound tells an undamped (imaginary) root from a damped one in the
Campbell table (:mod:`flexmbs.campbell`)."""
SMALL = 200
"""Tangents up to this size are counted densely by :func:`negative_eigenvalues` (faster than the sparse
factorisation's set-up there: the static path counts at every load step)."""
SYMMETRY = 1e-9
"""``K_r`` is treated as symmetric when ``|K − Kᵀ|`` is below this fraction of ``|K|`` (its
symmetric part is then used).  At an equilibrium under conservative loads (dead forces, gravity, joints,
springs) the skew parts of the tangents cancel to round-off (docs/tangents.md, "Skew part"); dead or
follower moments and follower forces leave one (they are not conservative: docs/formulation.md §11)."""


@dataclass
class ModeSet:
    """Eigenvalues and mass-normalised shapes on the reduced coordinates.

    ``s`` (k,) complex: the roots of ``det(s² M + s D + K) = 0`` (undamped: ``s = i ω``, or ``s = |ω|``
    for an unstable ``ω² < 0``); ``omega2`` (k,) ``−s²`` real part for undamped sets;
    ``phi`` (n_r, k) shapes; ``kind`` (k,) "elastic", "zero" or "unstable"; ``scale`` the stiffness
    scale s of :data:`ZERO_MODE`; ``damped`` whether the first-order form was used.
    """

    s: np.ndarray
    phi: np.ndarray
    kind: np.ndarray
    scale: float
    damped: bool

    @property
    def frequency(self) -> np.ndarray:
        """``|Im s| / 2π`` [Hz] (for an undamped unstable mode ``|s|/2π``, the growth rate)."""
        f = np.where(self.kind == "unstable", np.abs(self.s), np.abs(self.s.imag))
        return f / (2.0 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        """``−Re s / |s|`` (0 for a zero mode)."""
        mag = np.abs(self.s)
        return np.where(mag > 0.0, -self.s.real / np.where(mag > 0.0, mag, 1.0), 0.0) + 0.0

    @property
    def omega2(self) -> np.ndarray:
        """``−Re(s²)`` [rad²/s²]: ω² of an undamped mode (negative: unstable)."""
        return -(self.s * self.s).real + 0.0


def stiffness_scale(K, M) -> float:
    """``Σ |K_ii| / Σ M_ii``: the stiffness over the mass of the coordinates that carry them, about the
    element frequency² of the translations (the rotary inertias, small, hardly count); 1 if K is zero."""
    k, m = float(np.sum(np.abs(K.diagonal()))), float(np.sum(np.abs(M.diagonal())))
    return k / m if k > 0.0 and m > 0.0 else 1.0


def is_symmetric(K, tol: float = SYMMETRY) -> bool:
    big = abs(K).max() if K.nnz else 0.0
    return bool(big == 0.0 or abs(K - K.T).max() <= tol * big)


def modes(M, D, K, n: int) -> ModeSet:
    """The ``n`` modes of lowest ``|s|`` of the reduced system (sparse M, D, K of size n_r).

    Undamped (:func:`undamped`) when D is zero and K symmetric, else first-order (:func:`damped`).
    Raises ValueError when ``n`` is not in 1 … n_r.
    """
    size = M.shape[0]
    if not 1 <= n <= size:
        raise ValueError(f"{n} modes asked of a model with {size} independent coordinates; ask at most {size}")
    D = sps.csr_matrix(D)
    if (D.nnz == 0 or abs(D).max() == 0.0) and is_symmetric(K):
        return undamped(M, K, n)
    return damped(M, D, K, n)


def undamped(M, K, n: int) -> ModeSet:
    """``K φ = ω² M φ`` (K symmetrised), the n eigenvalues nearest ``σ = −SHIFT s``: for a stable system
    the lowest n."""
    K = sps.csr_matrix(0.5 * (K + K.T))
    M = sps.csr_matrix(0.5 * (M + M.T))
    scale = stiffness_scale(K, M)
    size = M.shape[0]
    if size <= DENSE or n >= size - 1:
        try:  # shift-invert in dense form: M φ = ν (K − σM) φ, ω² = σ + 1/ν (accurate near σ)
            nu, phi = sla.eigh(M.toarray(), (K + SHIFT * scale * M).toarray())
            w2 = -SHIFT * scale + 1.0 / nu
        except np.linalg.LinAlgError:  # K − σM indefinite: unstable modes
            w2, phi = sla.eigh(K.toarray(), M.toarray())
        order = np.argsort(np.abs(w2 + SHIFT * scale), kind="stable")[:n]
    else:
        w2, phi = spla.eigsh(K.tocsc(), k=n, M=M.tocsc(), sigma=-SHIFT * scale, which="LM", ncv=_ncv(n, size))
        order = np.argsort(np.abs(w2 + SHIFT * scale), kind="stable")
    w2, phi = w2[order], phi[:, order]
    order = np.argsort(w2, kind="stable")
    w2, phi = w2[order], _normalise(phi[:, order], M)
    kind = _kind(w2, scale)
    s = np.where(w2 >= 0.0, 1j * np.sqrt(np.abs(w2)), np.sqrt(np.abs(w2)) + 0j)
    s[kind == "zero"] = 0.0
    return ModeSet(s, phi, kind, scale, False)


def _kind(w2: np.ndarray, scale: float) -> np.ndarray:
    zero = np.abs(w2) <= ZERO_MODE * scale
    return np.where(zero, "zero", np.where(w2 < 0.0, "unstable", "elastic"))


def damped(M, D, K, n: int) -> ModeSet:
    """The quadratic problem in first-order form; a conjugate pair is one mode (Im s > 0 kept), a real
    root one mode, a zero mode's double root (a Jordan block) one mode."""
    size = M.shape[0]
    scale = stiffness_scale(K, M)
    eye = sps.identity(size, format="csr")
    A = sps.bmat([[None, eye], [-K, -D]], format="csc")
    Bm = sps.bmat([[eye, None], [None, M]], format="csc")
    sigma = -np.sqrt(SHIFT * scale)
    want = min(2 * n + 2, 2 * size)
    if 2 * size <= DENSE_FIRST_ORDER or want >= 2 * size - 1:
        s, y = sla.eig(A.toarray(), Bm.toarray())
    else:
        lu = spla.splu(sps.csc_matrix(A - sigma * Bm))

        def solve(z):  # the real factor solves the real and imaginary parts (SuperLU takes no complex b here)
            b = Bm @ z
            return lu.solve(np.ascontiguousarray(b.real)) + 1j * lu.solve(np.ascontiguousarray(b.imag))

        op = spla.LinearOperator(A.shape, matvec=solve, dtype=complex)
        # a fixed start vector: the same roots at every run (ARPACK's random one moves them by ~1e-9 |s|)
        nu, y = spla.eigs(op, k=want, which="LM", ncv=_ncv(want, 2 * size), v0=np.ones(2 * size, dtype=complex))
        s = sigma + 1.0 / nu
    keep = np.isfinite(s)
    s, y = s[keep], y[:, keep]
    zero = np.abs(s) ** 2 <= ZERO_MODE * scale
    n_zero = (int(zero.sum()) + 1) // 2
    rest = ~zero & (s.imag >= -1e-12 * np.abs(s))
    # a pair with Im s = ±0 (an overdamped root) is kept once per root
    order = np.flatnonzero(rest)[np.lexsort((-s[rest].imag, np.abs(s[rest])))]
    picked = list(np.flatnonzero(zero)[:n_zero]) + list(order)
    picked = picked[:n]
    s, phi = s[picked], y[:size, picked]
    s[: min(n_zero, len(picked))] = 0.0
    kind = np.where(np.abs(s) == 0.0, "zero", np.where(s.real > UNSTABLE_DAMPING * np.abs(s), "unstable", "elastic"))
    return ModeSet(s, _normalise(phi, M), kind, scale, True)


def _ncv(k: int, size: int) -> int:
    """Lanczos/Arnoldi vectors for k eigenvalues: at least 40 more than k (ARPACK's default 2k + 1
    restarts often on a large model; more vectors cut the time many times over with the same eigenvalues,
    docs/benchmarks.md §10)."""
    return min(size - 1, max(2 * k + 1, k + 40))


def _normalise(phi: np.ndarray, M) -> np.ndarray:
    """``φᴴ M φ = 1`` per column, the largest entry real and positive."""
    phi = np.array(phi)
    norm = np.sqrt(np.abs(np.sum(np.conj(phi) * (M @ phi), axis=0)))
    big = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    phase = np.where(np.abs(big) > 0.0, np.conj(big) / np.where(np.abs(big) > 0.0, np.abs(big), 1.0), 1.0)
    return phi * phase / np.where(norm > 0.0, norm, 1.0)


def buckling(K0, K1, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The smallest positive load factors μ of ``(K_0 + μ (K_1 − K_0)) φ = 0`` and their shapes (n_r, k),
    normalised to ``max |φ| = 1``.

    ``K_0`` the reduced tangent of the unloaded state, ``K_1`` that under the loads of load factor 1.
    Solved as ``−K_g φ = (1/μ) K_0 φ`` for the largest positive ``1/μ``: with ``K_0`` positive definite (a
    restrained structure) and ``K_g`` symmetric (conservative loads), by ``eigh``/``eigsh``; with a
    ``K_g`` that is not (follower loads: divergence), by ``eig``/``eigs`` on ``K_0⁻¹(−K_g)``, real roots
    only.  Raises ValueError when ``K_0`` is singular or not positive definite (a mechanism, an
    unconstrained body, a reference state beyond a buckling load) or when ``n`` exceeds the coordinates; returns fewer than n factors when fewer
    are positive (the loads stiffen the structure in the other modes).
    """
    size = K0.shape[0]
    if not 1 <= n <= size:
        raise ValueError(f"{n} buckling modes asked of a model with {size} independent coordinates; ask at most {size}")
    K0 = sps.csr_matrix(0.5 * (K0 + K0.T))
    Kg = sps.csr_matrix(K1) - K0
    symmetric = is_symmetric(Kg, 1e-7)
    if symmetric:
        Kg = 0.5 * (Kg + Kg.T)
    try:
        if size <= DENSE or n >= size - 1:
            if symmetric:
                nu, phi = sla.eigh(-Kg.toarray(), K0.toarray())
            else:
                sla.cholesky(K0.toarray())  # positive definite, as in the symmetric case
                nu, phi = sla.eig(-Kg.toarray(), K0.toarray())
        elif symmetric:
            nu, phi = spla.eigsh(-Kg.tocsc(), k=n, M=K0.tocsc(), which="LA", ncv=_ncv(n, size))
        else:
            lu = spla.splu(K0.tocsc())
            op = spla.LinearOperator(K0.shape, matvec=lambda z: lu.solve(np.asarray(-(Kg @ z))), dtype=float)
            nu, phi = spla.eigs(op, k=min(2 * n, size - 2), which="LR", ncv=_ncv(2 * n, size))
    except (np.linalg.LinAlgError, RuntimeError, spla.ArpackError):
        raise ValueError(_NOT_RESTRAINED) from None
    real = np.abs(np.imag(nu)) <= 1e-9 * np.abs(nu)
    nu, phi = np.real(nu[real]), np.real(phi[:, real])
    positive = nu > 1e-12 * max(float(np.max(np.abs(nu), initial=0.0)), 1e-300)
    nu, phi = nu[positive], phi[:, positive]
    order = np.argsort(-nu)[:n]
    mu, phi = 1.0 / nu[order], phi[:, order]
    big = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    return mu, phi / np.where(big != 0.0, big, 1.0)


_NOT_RESTRAINED = ("the tangent of the reference state (at t = 0, or without the loads) is not positive definite: a "
                   "mechanism, an unconstrained body, or loads at t = 0 already beyond a buckling load; linear buckling "
                   "needs a restrained structure, stable at t = 0: clamp or fix the free motions, or lower the loads "
                   "at t = 0")


def negative_eigenvalues(K, known: tuple | None = None) -> tuple[int, int]:
    """``(count, sign)``: the number of negative real eigenvalues of K (sparse or dense), its directions of
    divergence, and the sign of ``det K``.

    When the symmetric part of K is positive definite there is none (a real eigenpair has
    ``λ |φ|² = φᵀ K φ > 0``): a Cholesky factorisation that succeeds answers 0 at the cost of one
    factorisation, the common case.  Otherwise, for a symmetric K (conservative loads), its inertia by
    Sylvester's law (Bathe 1996, §8.2.5, the Sturm sequence property): the pivot blocks of the dense
    Bunch–Kaufman ``P K Pᵀ = L D Lᵀ`` below :data:`SMALL` coordinates (:func:`_ldl_negatives`), else the pivots of ``P K Pᵀ = L D Lᵀ`` (SuperLU in its symmetric mode with diagonal
    pivots, ``diag_pivot_thresh = 0``, and a minimum-degree ordering, so that ``U = D Lᵀ``).  A K that is
    not symmetric (dead or follower moments, follower forces: non-conservative loads) has no inertia in that
    sense: its real eigenvalues are counted (densely), unless ``known`` = the ``(count, sign)`` of the
    previous state on the path says that none went through zero (the sign of the determinant, from an LU
    factorisation, has not changed).  A count of −1: not known (a non-symmetric K above 4 × :data:`DENSE`
    coordinates, or a singular one).
    """
    size = K.shape[0]
    if size == 0:
        return 0, 1
    if size <= SMALL:
        K = K.toarray() if sps.issparse(K) else np.asarray(K)
        symmetric = np.abs(K - K.T).max() <= SYMMETRY * np.abs(K).max()
        if not symmetric and known is not None and known[0] >= 0:
            lu, piv, _ = sla.lapack.dgetrf(K)
            sign = _sign(np.diag(lu), piv != np.arange(size))
            if known[1] == sign:
                return known[0], sign
        if _cholesky(K + K.T):
            return 0, 1
        if symmetric:
            count = _ldl_negatives(0.5 * (K + K.T))
            return count, (-1) ** count
        ev = sla.eigvals(K, check_finite=False)
        count = int(np.sum((ev.imag == 0.0) & (ev.real < 0.0)))
        return count, (-1) ** count
    symmetric = is_symmetric(K)
    A = sps.csc_matrix(0.5 * (K + K.T)) if symmetric else sps.csc_matrix(K)
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0 if symmetric else 1.0,
                       options={"SymmetricMode": symmetric})
    except RuntimeError:
        return -1, 0
    d = lu.U.diagonal()
    sign = _sign(d, None) * permutation_sign(lu.perm_r) * permutation_sign(lu.perm_c)
    if symmetric and np.array_equal(lu.perm_r, lu.perm_c) and np.all(d != 0.0):
        return int(np.sum(d < 0.0)), sign
    if not symmetric and known is not None and known[0] >= 0 and known[1] == sign:
        return known[0], sign
    if size > 4 * DENSE:
        return -1, sign
    ev = np.linalg.eigvals(A.toarray())
    return int(np.sum((ev.imag == 0.0) & (ev.real < 0.0))), sign


def _ldl_negatives(S: np.ndarray) -> int:
    """The number of negative eigenvalues of the dense symmetric S: those of the 1×1 and 2×2 pivot blocks of its
    Bunch–Kaufman factorisation ``P S Pᵀ = L D Lᵀ`` (LAPACK ``sytrf``; Sylvester's law of inertia).  A third of
    the work of the eigenvalues, and no multithreaded reduction, which on a loaded machine waits for a busy
    core: much faster than ``eigvalsh`` on the tangents the arc-length path counts at every point
    (docs/benchmarks.md §10)."""
    _, D, _ = sla.ldl(S, lower=True, hermitian=True, check_finite=False)
    count, i, n = 0, 0, D.shape[0]
    while i < n:
        if i + 1 < n and D[i + 1, i] != 0.0:  # a 2×2 block: one negative root if det < 0, two if det > 0 and trace < 0
            a, b, c = D[i, i], D[i + 1, i], D[i + 1, i + 1]
            det = a * c - b * b
            count += 1 if det < 0.0 else 2 if det > 0.0 and a + c < 0.0 else 1 if det == 0.0 and a + c < 0.0 else 0
            i += 2
        else:
            count += int(D[i, i] < 0.0)
            i += 1
    return count


def _cholesky(S: np.ndarray) -> bool:
    """Whether the dense symmetric S is positive definite (LAPACK ``dpotrf`` succeeds)."""
    _, info = sla.lapack.dpotrf(S, lower=False, clean=False, overwrite_a=False)
    return info == 0


def _sign(diagonal, swapped) -> int:
    """The sign of a determinant from its LU pivots and, for LAPACK's, the row interchanges."""
    sign = -1 if np.sum(diagonal < 0.0) % 2 else 1
    if swapped is not None and np.sum(swapped) % 2:
        sign = -sign
    return 0 if np.any(diagonal == 0.0) else sign


def nearest_zero(K, M) -> tuple[float, np.ndarray]:
    """The real eigenvalue of ``K φ = μ M φ`` nearest zero and its shape: where the count of
    :func:`negative_eigenvalues` changes, the eigenvalue that crosses zero."""
    size = K.shape[0]
    if not is_symmetric(K):
        mu, phi = sla.eig(K.toarray(), M.toarray())
        real = np.flatnonzero(np.isfinite(mu) & (mu.imag == 0.0))
        k = real[np.argmin(np.abs(mu[real].real))]
        return float(mu[k].real), phi[:, k].real
    K = sps.csc_matrix(0.5 * (K + K.T))
    M = sps.csc_matrix(M)
    if size <= SMALL:  # above it shift-invert is faster than the dense pencil (docs/benchmarks.md §10)
        mu, phi = sla.eigh(K.toarray(), M.toarray())
    else:
        # a fixed start vector (ARPACK's default is random): the same critical load factor on every run
        start = np.random.default_rng(0).standard_normal(size)
        mu, phi = spla.eigsh(K, k=min(4, size - 1), M=M, sigma=ZERO_MODE * stiffness_scale(K, M), which="LM",
                             v0=start)
    k = int(np.argmin(np.abs(mu)))
    return float(mu[k]), phi[:, k]
