"""The compiled full-Newton loop of the static algorithm (:mod:`reference.algorithms.static`) and of the
arc-length corrector (:mod:`reference.algorithms.arc_length`).

One call of :func:`newton_loop` solves a load level, or makes a corrector: evaluate the residual, test it, assemble the
Newton matrix's values, scatter them into the CSC data of its fixed pattern
(:class:`reference.linalg.BlockPattern`), refactor numerically with the kept permutations
(:func:`reference.linalg.refactor`), solve (:func:`reference.linalg.lu_solve`) and update the
configuration (``x ← x + δx``, ``q ← q ⊗ exp(δθ)``, ``λ ← λ + μ``) — no Python per iteration.
Python only makes the factorisations that need SuperLU: the first one (its ordering and row
pivots) and any whose kept pivots go bad (the kernel returns :data:`reference.status.REFACTOR`;
the caller factors the matrix it left assembled and calls again, and the iteration resumes with
the correction from that factor).

The arithmetic is that of the Python loop it replaces, operation for operation (the scatter sums
the block values in the order ``numpy.bincount`` does), so the iterates are the same bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from reference.algorithms.implicit import compose, evaluate
from reference.evaluation.tangent import tangent_values
from reference.jit import kernel, named
from reference.linalg import SingularMatrix, lu_solve, refactor
from reference.modal import SYMMETRY
from reference.state import Model, RecordView, record_dtype
from reference.status import DIVERGED, NO_CONVERGENCE, OK, REFACTOR, SINGULAR

NO_FACTOR = (np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(1, np.int64),
             np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64))
"""Empty factor arrays, passed before the first factorisation (the kernel asks for one at once)."""

PAR = record_dtype("tolerance", "L", "max_iterations", "corrections", "resume", "U", "threshold", "factored",
                   "tangent", "sign", "bordered", "load")
"""The record of :func:`newton_loop`'s ``par`` (an array of shape (1,), :func:`reference.state.record_dtype`):
the Newton ``tolerance``, the model size ``L`` [m], the iteration limit ``max_iterations``, the ``corrections``
made (in/out), ``resume`` 1 to resume with a fresh factor of the matrix left assembled (in; cleared), the strain
energy ``U`` of the last evaluation [J] (out), the pivot ``threshold`` of the kept pivot order
(:attr:`reference.linalg.SparseLU.PIVOT_THRESHOLD`), ``factored`` 1 when a factor exists (in), what to leave at
the equilibrium for the static stability count, ``tangent`` (in: 0 nothing, 1 the tangent, 2 the tangent and the
sign of its determinant, :func:`tangent_sign`), that ``sign`` (out), ``bordered`` 1 when the load factor is an
unknown on a normal plane (arc length; in), the ``load`` factor λ (1 for the static algorithm; in/out)."""


class NewtonArrays:
    """What :func:`newton_loop` works in for one :class:`reference.algorithms.implicit.NewtonSystem`, made once
    per run: ``par`` (a :data:`PAR` array of shape (1,); ``fields`` its record as Python reads and writes it,
    :class:`~reference.state.RecordView`), the CSC arrays and scatter of the Newton matrix, the scratch of the
    tangent assembly (``dense`` (n, n) for the static stability sign, else empty), ``hist``
    (max_iterations + 1), the loop's ``arrays`` and, for a path, the scaled norm's ``weights`` (n_free) and the
    follower loads ``follower`` (node, code 1 force / 2 moment, f, vector (k, 3)), none by default."""

    def __init__(self, system, tolerance: float, L: float, max_iterations: int, dense=None, weights=None,
                 follower=None):
        n, N, nf = system.pattern.n, system.dof.shape[0], system.n_free
        self.system = system
        self.par = np.zeros(1, PAR)
        self.fields = par = RecordView(self.par)
        par["load"] = 1.0
        par["tolerance"], par["L"], par["max_iterations"] = tolerance, L, max_iterations
        par["threshold"] = system.slu.PIVOT_THRESHOLD
        A, wk = system.pattern.assembled, system.work
        self.csc = (A.indptr, A.indices, A.data)
        self.scatter = (system.pattern.slot, system.pattern.keep, wk.values)
        self.tangent_work = (system.tangent_arg, system.zero_psi, np.zeros((0, 0)) if dense is None else dense)
        self.arrays = (np.zeros(n), np.zeros(n), np.zeros((N, 6)), np.zeros((N, 3)), np.zeros((N, 4)), np.zeros(4),
                       np.zeros((N, 6)), np.zeros(n), np.zeros((N, 6)), np.zeros(nf), np.zeros(nf), np.zeros((N, 6)))
        self.hist = np.zeros(max_iterations + 1)
        self.weights = np.ones(nf) if weights is None else weights
        self.follower = follower if follower is not None else (np.zeros(0, np.int64), np.zeros(0, np.int64),
                                                               np.zeros(0), np.zeros((0, 3)))
        self.plane = np.zeros(nf + 1)  # the normal of a corrector without one (not read)
        self.moved = np.zeros(nf + 1)  # the path increment of a static solve (not read)

    def solve(self, x, q, lam, t, normal=None, moved=None) -> int:
        """:func:`newton_loop` from ``(x, q, λ)`` at t (load factor ``par["load"]``) in place, on the plane of
        ``normal`` when given (``par["bordered"]``), accumulating the scaled corrections into ``moved``; a status."""
        system, par = self.system, self.par
        self.fields["bordered"] = 0.0 if normal is None else 1.0
        plane = self.plane if normal is None else np.ascontiguousarray(normal, dtype=float)
        moved = self.moved if moved is None else moved
        return self.run(lambda factors, csc: newton_loop(system.arg, x, q, lam, t, system.dof, factors, csc, system.wt,
                                                         self.tangent_work, self.arrays, par, self.hist, plane,
                                                         self.weights, self.follower, moved))

    def run(self, call) -> int:
        """``call(factors, csc)`` (a compiled loop given its factor and CSC arrays) until it ends, with the
        SuperLU factorisations it asks for (REFACTOR: the matrix it left assembled, then resumed); a status."""
        slu, par = self.system.slu, self.fields
        par["corrections"], par["resume"] = 0.0, 0.0
        while True:
            par["factored"] = 0.0 if slu.f is None else 1.0
            csc = (*self.csc, NO_FACTOR[6] if slu.f is None else slu.inv_perm_c, slu.w, slu.work, slu.rs, slu.cs,
                   *self.scatter)
            code = call(NO_FACTOR if slu.f is None else slu.f, csc)
            if code != REFACTOR:
                return code
            try:
                slu.factor(self.system.pattern.assembled)
            except SingularMatrix:
                return SINGULAR
            par["resume"] = 1.0

    def history(self) -> list:
        """The residual norms of the last loop's evaluations."""
        return list(self.hist[: int(self.fields["corrections"]) + 1])


@kernel
def newton_loop(model, x, q, lam, t, dof, factors, csc, wt, tangent_work, arr, par, hist, normal, weights,
                follower, moved):
    """Full Newton–Raphson on ``S − Λ F + Bᵀλ = 0``, ``Φ − ελ = 0`` at time (load factor) t from
    ``(x, q, λ)``, in place (docs/formulation.md §10, §12), Λ = ``par["load"]`` the arc length's load factor
    (1 for the static algorithm: the residual of the evaluation as it is).

    Converged when the residual is balanced (every free residual force below ``tolerance`` times the largest
    internal force, ``|Λ|`` times the largest external force or the largest joint force, and ``|Φ − ελ|``
    below ``tolerance × L``) or, after a correction, when the correction is below ``tolerance``
    (translations over L, rotations in rad).  With ``par["bordered"] = 1`` Λ is an unknown on the plane of
    the unit ``normal`` (n_free + 1, scaled: translations × ``weights``), solved by bordering (two solves
    with the one factor, :func:`_bordered`); ``moved`` (n_free + 1) accumulates the scaled corrections and
    ΔΛ.  At Λ ≠ 1 the configuration-dependent load blocks of the matrix, assembled at Λ = 1, are scaled to
    Λ (``follower`` of :class:`NewtonArrays`).  ``csc`` = ``(indptr, indices, data, inv_perm_c, w, work,
    rs, cs, slot, keep, values)``: the Newton matrix's CSC arrays, the factor's scratch
    (:class:`reference.linalg.SparseLU`; ``w`` the refactorisation's, zero between calls, ``work`` the
    solve's), the pattern's scatter (:class:`reference.linalg.BlockPattern`) and the block values;
    ``tangent_work`` and ``arr`` as :class:`NewtonArrays` makes them; ``hist`` the residual norms
    ``‖[R; Φ − ελ]‖`` of the evaluations (one per correction, plus the last).

    Returns OK, DIVERGED (non-finite residual), SINGULAR (a pivot below the equilibrated threshold, a
    non-finite correction or ΔΛ), NO_CONVERGENCE (``max_iterations`` corrections) or REFACTOR (the kept
    pivot order failed, or there is no factor yet: the matrix at the iterate is assembled in ``data``;
    factor it with SuperLU and call again with ``par["resume"] = 1``).

    Takes 17 parameters: the iterate's arrays and the factor's and tangent's scratch (:class:`NewtonArrays`).
    """
    mdl = named(model, Model)
    Ap, Ai, Ax, work, slot, keep, values = csc[0], csc[1], csc[2], csc[5], csc[8], csc[9], csc[10]
    tw, psi, dense = tangent_work
    rhs, sol, delta, dth, q_new, tmp, rows, solF, dF, sc, scF, reff = arr
    f_node, f_code, f_val, f_vec = follower
    S, F, r, PHI = wt[0], wt[1], wt[2], wt[3]
    Bl = wt[5]
    eps = mdl.joints.compliance  # the rows' equations are Φ − c λ = 0 (the Newton matrix keeps ε)
    jt_i, jt_j, jt_row0, jt_neq = mdl.joints.i, mdl.joints.j, mdl.joints.row0, mdl.joints.neq
    par = par[0]
    tol, L, max_it = par["tolerance"], par["L"], int(par["max_iterations"])
    n_free = rhs.shape[0] - lam.shape[0]
    while True:
        it = int(par["corrections"])
        load = par["load"]
        if par["resume"] != 1.0:
            par["U"] = evaluate(model, x, q, x, x, x, lam, t, False, wt)
            hist[it] = _load_residual(r, F, PHI, eps, lam, load, dof, reff)
            if not math.isfinite(hist[it]):
                return DIVERGED
            if _balanced(S, abs(load) * _largest(F), reff, PHI, Bl, lam, eps, dof, jt_i, jt_j, jt_row0, jt_neq,
                         rows, tol, L) or (it > 0 and _correction_size(delta, L) <= tol):
                if par["tangent"] > 0.0:
                    # the stability count's tangent at the equilibrium: [K Bᵀ; B 0] (c_e = 0) at zero velocity
                    tangent_values(model, x, q, psi, psi, t, lam, 0.0, 0.0, 1.0, 0.0, values, wt, tw)
                    _scatter(Ax, slot, keep, values)
                    if par["tangent"] == 2.0:
                        par["sign"] = tangent_sign(Ap, Ai, Ax, dense)
                return OK
            if it == max_it:
                return NO_CONVERGENCE
            tangent_values(model, x, q, x, psi, t, lam, 0.0, 0.0, 1.0, 1.0, values, wt, tw)
            if load != 1.0:
                _scale_load_blocks(values, q, load, f_node, f_code, f_val, f_vec)
            code = _refactor_values(factors, csc, par)
            if code != OK:
                return code
        par["resume"] = 0.0
        _newton_rhs(reff, PHI, eps, lam, dof, rhs)
        if not _solve(factors, rhs, work, sol, dof, delta):
            return SINGULAR
        dload = 0.0
        if par["bordered"] == 1.0:
            dload = _bordered(factors, F, dof, weights, normal, rhs, work, sol, solF, delta, dF, sc, scF)
            if not math.isfinite(dload):
                return SINGULAR
        _update(x, q, lam, delta, sol, dth, q_new, tmp)
        par["load"] = load + dload
        _scaled(delta, dof, weights, sc)
        for k in range(n_free):
            moved[k] += sc[k]
        moved[n_free] += dload
        par["corrections"] = it + 1


@kernel
def _load_residual(r, F, PHI, eps, lam, load, dof, reff):
    """The residual at load factor Λ = ``load`` of the evaluation's (at Λ = 1), ``r + (1 − Λ) F``, into
    ``reff`` (``r`` itself at Λ = 1); returns ``‖[reff; Φ − ελ]‖`` over the free coordinates."""
    size2 = 0.0
    for i in range(r.shape[0]):
        for k in range(6):
            reff[i, k] = r[i, k] if load == 1.0 else r[i, k] + (1.0 - load) * F[i, k]
            if dof[i, k] >= 0:
                size2 += reff[i, k] * reff[i, k]
    for k in range(lam.shape[0]):
        size2 += (PHI[k] - eps[k] * lam[k]) ** 2
    return math.sqrt(size2)


@kernel
def _refactor_values(factors, csc, par):
    """Scatter the block values into the CSC data and refactor with the kept permutations: OK, REFACTOR (no
    factor yet, or a kept pivot below the threshold: SuperLU's turn) or SINGULAR."""
    Ap, Ai, Ax, inv_perm_c, w_lu, work, rs, cs, slot, keep, values = csc
    _scatter(Ax, slot, keep, values)
    if par["factored"] != 1.0:
        return REFACTOR
    code = refactor(factors, Ap, Ai, Ax, inv_perm_c, w_lu, par["threshold"], rs, cs)
    return REFACTOR if code == 1 else SINGULAR if code == 2 else OK


@kernel
def _newton_rhs(r, PHI, eps, lam, dof, rhs):
    """``rhs = −[r (free coordinates); Φ − ελ]``."""
    m = lam.shape[0]
    n_free = rhs.shape[0] - m
    for i in range(r.shape[0]):
        for k in range(6):
            if dof[i, k] >= 0:
                rhs[dof[i, k]] = -r[i, k]
    for k in range(m):
        rhs[n_free + k] = -(PHI[k] - eps[k] * lam[k])


@kernel
def _update(x, q, lam, delta, sol, dth, q_new, tmp):
    """``x ← x + δx``, ``q ← q ⊗ exp(δθ)``, ``λ ← λ + μ`` (μ the tail of ``sol``)."""
    N, m = x.shape[0], lam.shape[0]
    n_free = sol.shape[0] - m
    for i in range(N):
        for k in range(3):
            x[i, k] += delta[i, k]
            dth[i, k] = delta[i, 3 + k]
    compose(q, dth, q_new, tmp)
    for i in range(N):
        for k in range(4):
            q[i, k] = q_new[i, k]
    for k in range(m):
        lam[k] += sol[n_free + k]


@kernel
def _balanced(S, big_F, r, PHI, Bl, lam, eps, dof, jt_i, jt_j, jt_row0, jt_neq, rows, tol, L):
    """Equilibrium: every free residual force below ``tol`` times the largest internal force, the external
    forces' scale ``big_F`` (``|Λ| max |F|``) or the largest joint force ``Bᵀλ`` (into ``rows``), and
    ``|Φ − ελ|`` below ``tol × L``.

    Takes 15 parameters: the residual's arrays, the joint table's columns :func:`newton_loop` binds once (not the
    Model, :mod:`reference.jit`) and the tolerance.
    """
    scale = 0.0
    for i in range(S.shape[0]):
        for k in range(6):
            scale = max(scale, abs(S[i, k]))
    scale = max(scale, big_F, 1e-300)
    m = lam.shape[0]
    if m > 0:
        for i in range(rows.shape[0]):
            for k in range(6):
                rows[i, k] = 0.0
        for j in range(jt_i.shape[0]):
            r0, neq, a, b = jt_row0[j], jt_neq[j], jt_i[j], jt_j[j]
            for k in range(6):
                acc = 0.0
                for rr in range(neq):
                    acc += Bl[r0 + rr, k] * lam[r0 + rr]
                rows[a, k] += acc
                if b >= 0:
                    acc = 0.0
                    for rr in range(neq):
                        acc += Bl[r0 + rr, 6 + k] * lam[r0 + rr]
                    rows[b, k] += acc
        big = 0.0
        for i in range(rows.shape[0]):
            for k in range(6):
                big = max(big, abs(rows[i, k]))
        scale = max(scale, big)
    res = 0.0
    for i in range(r.shape[0]):
        for k in range(6):
            if dof[i, k] >= 0:
                res = max(res, abs(r[i, k]))
    phi = 0.0
    for k in range(m):
        phi = max(phi, abs(PHI[k] - eps[k] * lam[k]))
    return res <= tol * scale and phi <= tol * L


@kernel
def _correction_size(delta, L):
    """Largest correction: translations over the model size L, rotations in rad (the order of
    :meth:`reference.algorithms.implicit.ImplicitAlgorithm.correction_size`: the largest translation, then /L)."""
    big_x = 0.0
    big_t = 0.0
    for i in range(delta.shape[0]):
        for k in range(3):
            big_x = max(big_x, abs(delta[i, k]))
            big_t = max(big_t, abs(delta[i, 3 + k]))
    return max(big_x / L, big_t)


@kernel
def _scatter(Ax, slot, keep, values):
    """The CSC data of the block values: ``Ax[slot[k]] += values[keep[k]]`` in order, from zero (the sums of
    :meth:`reference.linalg.BlockPattern.matrix`'s ``numpy.bincount``, term for term)."""
    for p in range(Ax.shape[0]):
        Ax[p] = 0.0
    for p in range(slot.shape[0]):
        Ax[slot[p]] += values[keep[p]]


@kernel
def tangent_sign(Ap, Ai, Ax, dense):
    """The sign of ``det K`` (−1, 0 or 1) of the square CSC matrix K, or 2 when K is symmetric (to
    :data:`reference.modal.SYMMETRY`): what :func:`reference.modal.negative_eigenvalues` compares with the
    previous state's sign for a non-symmetric K below :data:`reference.modal.SMALL` coordinates, computed
    the same way (the dense K; LAPACK's ``getrf``, through ``slogdet``); ``dense`` (n, n) is overwritten."""
    n = dense.shape[0]
    for i in range(n):
        for j in range(n):
            dense[i, j] = 0.0
    for j in range(n):
        for p in range(Ap[j], Ap[j + 1]):
            dense[Ai[p], j] += Ax[p]
    skew, big = 0.0, 0.0
    for i in range(n):
        for j in range(n):
            skew = max(skew, abs(dense[i, j] - dense[j, i]))
            big = max(big, abs(dense[i, j]))
    if skew <= SYMMETRY * big:
        return 2.0
    sign, _ = np.linalg.slogdet(dense)
    return sign


@kernel
def _largest(F):
    big = 0.0
    for i in range(F.shape[0]):
        for k in range(F.shape[1]):
            big = max(big, abs(F[i, k]))
    return big


@kernel
def _bordered(factors, F, dof, weights, normal, rhs, work, sol, solF, delta, dF, sc, scF):
    """The load-factor correction on the normal plane: ``K δ_F = F``, ``Δλ = −nᵀδ_R / (nᵀδ_F + n_λ)`` (scaled
    norm), and ``δ ← δ_R + Δλ δ_F``, ``μ ← μ_R + Δλ μ_F`` in ``delta`` and ``sol``; returns Δλ (NaN: singular).

    Takes 13 parameters: the factor, the load, the plane (``normal``, ``weights``) and the solve's scratch arrays
    :func:`newton_loop` allocates once.
    """
    m = rhs.shape[0] - sc.shape[0]
    n_free = sc.shape[0]
    for i in range(F.shape[0]):
        for k in range(6):
            if dof[i, k] >= 0:
                rhs[dof[i, k]] = F[i, k]
    for k in range(m):
        rhs[n_free + k] = 0.0
    if not _solve(factors, rhs, work, solF, dof, dF):
        return math.nan
    _scaled(delta, dof, weights, sc)
    _scaled(dF, dof, weights, scF)
    n_u = normal[:-1]
    den = np.dot(n_u, scF) + normal[-1]
    dlam = -np.dot(n_u, sc) / den
    if math.isfinite(dlam):
        for i in range(F.shape[0]):
            for k in range(6):
                delta[i, k] += dlam * dF[i, k]
        for k in range(m):
            sol[n_free + k] += dlam * solF[n_free + k]
    return dlam


@kernel
def _solve(factors, rhs, work, sol, dof, out):
    """``sol`` of the factored system and its node part ``out`` (N, 6), zero where fixed; false when not finite."""
    lu_solve(factors, rhs, work, sol)
    for k in range(sol.shape[0]):
        if not math.isfinite(sol[k]):
            return False
    for i in range(out.shape[0]):
        for k in range(6):
            out[i, k] = sol[dof[i, k]] if dof[i, k] >= 0 else 0.0
    return True


@kernel
def _scaled(d, dof, weights, out):
    """The free coordinates of ``d`` (N, 6) in the path norm's units: ``d[free] × weights``."""
    for i in range(d.shape[0]):
        for k in range(6):
            if dof[i, k] >= 0:
                out[dof[i, k]] = d[i, k] * weights[dof[i, k]]


@kernel
def _scale_load_blocks(values, q, lam, f_node, f_code, f_val, f_vec):
    """The follower forces' and dead moments' load-tangent blocks (written at λ = 1) scaled to λ:
    a follower force ``F = R f``: ``∂F/∂δθ = −R [f×]``; a dead moment ``F_θ = Rᵀ M``: ``∂F_θ/∂δθ = [(RᵀM)×]``."""
    R = np.empty((3, 3))
    Sk = np.empty((3, 3))
    for k in range(f_node.shape[0]):
        n = f_node[k]
        w, a, b, c = q[n, 0], q[n, 1], q[n, 2], q[n, 3]
        R[0, 0], R[0, 1], R[0, 2] = 1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b)
        R[1, 0], R[1, 1], R[1, 2] = 2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a)
        R[2, 0], R[2, 1], R[2, 2] = 2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)
        if f_code[k] == 1:
            _skew(f_vec[k], Sk)
            block = (-R) @ Sk
            r0 = 0
        else:
            _skew(np.ascontiguousarray(R.T) @ f_vec[k], Sk)
            block = Sk
            r0 = 3
        for i in range(3):
            for j in range(3):
                values[36 * n + 6 * (r0 + i) + 3 + j] -= (lam - 1.0) * f_val[k] * block[i, j]


@kernel
def _skew(v, out):
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -v[2], v[1]
    out[1, 0], out[1, 1], out[1, 2] = v[2], 0.0, -v[0]
    out[2, 0], out[2, 1], out[2, 2] = -v[1], v[0], 0.0
