"""Compiled constraint assembly and the stabilised Lagrange-multiplier solve, sparse.

``assemble_constraints`` evaluates every joint's rows (the generated
primitives, combined for drives) into the global ``Φ`` (m,), ``Φ_t`` (m,) and
the joint's own block of B, ``Bj[k]`` (m_k × 12, columns ``[v_i | ω_i | v_j |
ω_j]``): B is never formed as an m × 6N array.

``constraint_impulse`` is the implicit stage of Park's staggered step with the
Park–Chiou stabilisation (docs/formulation.md §7, a reconstruction): with the predicted
velocities ``V*`` and the kick length ``h_k`` (``h``, or ``h/2`` at start-up),
the impulse ``Λ = h_k λ`` solves::

    (B M⁻¹ Bᵀ + ε/(h h_k) I) Λ = B V* + Φ_t + Φ/h

and ``V = V* − M⁻¹ Bᵀ Λ``.  For ``h_k = h`` this is
``(B M⁻¹ Bᵀ + ε/h² I) λ = (1/h) B V* + (1/h²) Φ + (1/h) Φ_t`` (backward
Euler on ``ε λ = Φ``): the drift of the next positions makes ``Φ`` vanish to
first order, so ``Φ`` stays bounded instead of drifting as it does under a pure
velocity projection.  ``ε = 0`` is a linearised position projection; ``ε > 0``
regularises redundant constraints.

The matrix ``W = B M⁻¹ Bᵀ + ε/(h h_k) I`` couples two joints only when they
share a node; its pattern, a fill-reducing elimination order and the pattern
of its Cholesky factor L are fixed when the model is assembled
(:mod:`reference.joints.sparse`).  Each step assembles W straight into L's
slots and factors it there (a left-looking sparse Cholesky): the cost grows
with the number of joints for chains and trees, and with the fill of the
loops for closed loops.  Nothing is allocated per step.
"""

from __future__ import annotations

import math

import numpy as np

from reference.connector import body_fixed_parts
from reference.generated import joints as generated
from reference.interactions import tf_derivative, tf_integral, tf_value
from reference.jit import inlined
from reference.status import OK, SINGULAR

GROUND_X = np.zeros(3)
GROUND_Q = np.array([1.0, 0.0, 0.0, 0.0])
"""The ground's position and Euler parameters (read-only constants)."""


@inlined
def joint_rows(x, q, i, j, par, rows, drive, tf_kind, tf_par, t, phi, B, phit, prim_phi, prim_B):
    """Rows of one joint: Φ (m,), local B (m, 12) = [v_i | ω_i | v_j | ω_j], Φ_t (m,).

    ``j = -1`` is the ground (x = 0, identity rotation; its columns are zero).
    ``drive`` 0 none; 1/2 rotation drive with θ = f(t) / θ = ∫f; 3/4 displacement
    drive with s = f(t) / s = ∫f; 5 prescribed displacement, s = f(t) along the ground-fixed
    u3 (of ``f_j``, the ground's frame, is inertial).

    Takes 15 parameters: one joint's row of the joint table, its time function, t, and the outputs and scratch, as
    the explicit, implicit and Hessian callers hold them.
    """
    xj, qj = GROUND_X, GROUND_Q  # one type for both branches: the generated kernel compiles once
    if j >= 0:
        xj, qj = x[j], q[j]
    s_i, s_j, f_i, f_j = body_fixed_parts(par)
    generated.joint_primitives(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, prim_phi, prim_B)
    if drive == 0:
        for r in range(phi.shape[0]):
            row = rows[r]
            phi[r] = prim_phi[row]
            phit[r] = 0.0
            for c in range(12):
                B[r, c] = prim_B[12 * row + c]
    elif drive <= 2:
        if drive == 1:
            th, thd = tf_value(tf_kind, tf_par, t), tf_derivative(tf_kind, tf_par, t)
        else:
            th, thd = tf_integral(tf_kind, tf_par, t), tf_value(tf_kind, tf_par, t)
        c, s = math.cos(th), math.sin(th)
        phi[0] = prim_phi[5] * c - prim_phi[9] * s
        phit[0] = -(prim_phi[5] * s + prim_phi[9] * c) * thd
        for k in range(12):
            B[0, k] = prim_B[60 + k] * c - prim_B[108 + k] * s
    elif drive <= 4:
        if drive == 3:
            sv, sd = tf_value(tf_kind, tf_par, t), tf_derivative(tf_kind, tf_par, t)
        else:
            sv, sd = tf_integral(tf_kind, tf_par, t), tf_value(tf_kind, tf_par, t)
        phi[0] = prim_phi[8] + sv  # u3_i · (P_j − P_i) = −s: body i slides by +s relative to body j
        phit[0] = sd
        for k in range(12):
            B[0, k] = prim_B[96 + k]
    else:
        # prescribed displacement: u · (P − P_i) = −s with u = u3 of the ground's frame (inertial, fixed)
        u0, u1, u2 = f_j[2], f_j[5], f_j[8]  # u3, the last column of the ground's frame
        phi[0] = u0 * prim_phi[0] + u1 * prim_phi[1] + u2 * prim_phi[2] + tf_value(tf_kind, tf_par, t)
        phit[0] = tf_derivative(tf_kind, tf_par, t)
        for k in range(12):
            B[0, k] = u0 * prim_B[k] + u1 * prim_B[12 + k] + u2 * prim_B[24 + k]
    if j < 0:
        for r in range(phi.shape[0]):
            for k in range(6, 12):
                B[r, k] = 0.0


@inlined
def assemble_constraints(model, x, q, t, PHI, PHIt, Bj, prim_phi, prim_B):
    """Φ (m,), Φ_t (m,) and every joint's block of B, ``Bj[k, :m_k]`` (J, 6, 12), at time t."""
    jt_i, jt_j, jt_neq, jt_row0, jt_tf = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0, model.joints.tf
    jt_par, jt_rows, jt_drive, tf_kind, tf_par = model.joints.par, model.joints.rows, model.joints.drive, model.time_functions.kind, model.time_functions.par
    for k in range(jt_i.shape[0]):
        m = jt_neq[k]
        r0 = jt_row0[k]
        tf = jt_tf[k]
        joint_rows(x, q, jt_i[k], jt_j[k], jt_par[k], jt_rows[k], jt_drive[k], tf_kind[tf], tf_par[tf], t,
                   PHI[r0:r0 + m], Bj[k, :m], PHIt[r0:r0 + m], prim_phi, prim_B)


@inlined
def apply_inverse_mass(model, Bj, BMj):
    """Per-joint blocks of ``B M⁻¹`` with the lumped, block-diagonal M (fixed coordinates have M⁻¹ = 0)."""
    jt_i, jt_j, jt_neq = model.joints.i, model.joints.j, model.joints.neq
    free, mass, Jinv = model.nodes.free, model.nodes.mass, model.nodes.inertia_inv
    for k in range(Bj.shape[0]):
        for side in range(2):
            n = jt_i[k] if side == 0 else jt_j[k]
            c0 = 6 * side
            for r in range(jt_neq[k]):
                if n < 0:
                    for a in range(6):
                        BMj[k, r, c0 + a] = 0.0
                    continue
                for a in range(3):
                    BMj[k, r, c0 + a] = Bj[k, r, c0 + a] * free[n, a] / mass[n]
                for a in range(3):
                    acc = 0.0
                    for b in range(3):
                        acc += Bj[k, r, c0 + 3 + b] * free[n, 3 + b] * Jinv[n, b, a]
                    BMj[k, r, c0 + 3 + a] = acc * free[n, 3 + a]


@inlined
def assemble_w(model, Bj, BMj, Lx):
    """The lower triangle of ``W = B M⁻¹ Bᵀ`` into L's slots (fill slots zero), elimination order."""
    Lx[:] = 0.0
    wc_joints, wc_pos, jt_neq = model.joints.pattern.wc_joints, model.joints.pattern.wc_pos, model.joints.neq
    for t in range(wc_joints.shape[0]):
        a, b = wc_joints[t, 0], wc_joints[t, 1]
        ca, cb = 6 * wc_joints[t, 2], 6 * wc_joints[t, 3]
        for r in range(jt_neq[a]):
            for s in range(jt_neq[b]):
                p = wc_pos[t, r, s]
                if p < 0:
                    continue
                acc = 0.0
                for c in range(6):
                    acc += BMj[a, r, ca + c] * Bj[b, s, cb + c]
                Lx[p] += acc


@inlined
def sparse_cholesky(model, Lx, work, scale_tol, own_tol, dependent):
    """Factor the matrix held in L's slots in place, ``W = L Lᵀ``: left-looking, column by column.

    Column j gathers W's column, subtracts ``L[j, c] L[j:, c]`` for the columns
    c of row j's pattern (George & Liu 1981, §2.2), and is scaled by its pivot.
    A pivot ``d ≤ scale_tol · max W_ii`` or ``d ≤ own_tol · W_jj`` marks row j
    as dependent on the rows before it: with ``dependent`` of length 0 the
    factorisation stops and returns ``SINGULAR``; otherwise ``dependent[j] = 1``,
    column j is zeroed (the row is dropped, as Gram–Schmidt drops it) and the
    factorisation goes on.  Returns ``OK`` or ``SINGULAR``.
    """
    colptr, rowidx, rowptr, rowcol, rowpos = model.joints.pattern.L_colptr, model.joints.pattern.L_rowidx, model.joints.pattern.L_rowptr, model.joints.pattern.L_rowcol, model.joints.pattern.L_rowpos
    m = colptr.shape[0] - 1
    scale = 0.0
    for j in range(m):
        scale = max(scale, abs(Lx[colptr[j]]))
    for j in range(m):
        for p in range(colptr[j], colptr[j + 1]):
            work[rowidx[p]] = Lx[p]
        own = work[j]
        for e in range(rowptr[j], rowptr[j + 1]):
            c = rowcol[e]
            p0 = rowpos[e]
            ljc = Lx[p0]
            if ljc == 0.0:
                continue
            for p in range(p0, colptr[c + 1]):
                work[rowidx[p]] -= Lx[p] * ljc
        d = work[j]
        if d <= scale_tol * scale or d <= own_tol * own:
            if dependent.shape[0] == 0:
                return SINGULAR
            dependent[j] = 1
            for p in range(colptr[j], colptr[j + 1]):
                Lx[p] = 0.0
            continue
        d = math.sqrt(d)
        Lx[colptr[j]] = d
        for p in range(colptr[j] + 1, colptr[j + 1]):
            Lx[p] = work[rowidx[p]] / d
    return OK


@inlined
def sparse_solve(model, Lx, y):
    """Solve ``L Lᵀ y = rhs`` in place (elimination order); a dropped row (zero pivot) gets y = 0."""
    colptr, rowidx = model.joints.pattern.L_colptr, model.joints.pattern.L_rowidx
    m = colptr.shape[0] - 1
    for j in range(m):
        d = Lx[colptr[j]]
        if d == 0.0:
            y[j] = 0.0
            continue
        y[j] /= d
        for p in range(colptr[j] + 1, colptr[j + 1]):
            y[rowidx[p]] -= Lx[p] * y[j]
    for j in range(m - 1, -1, -1):
        d = Lx[colptr[j]]
        if d == 0.0:
            continue
        s = y[j]
        for p in range(colptr[j] + 1, colptr[j + 1]):
            s -= Lx[p] * y[rowidx[p]]
        y[j] = s / d


@inlined
def factor_constraints(model, Bj, BMj, Lx, work, h, hk):
    """``B M⁻¹`` blocks and the sparse Cholesky factor of ``B M⁻¹ Bᵀ + ε/(h h_k) I`` into ``Lx``.

    Returns ``OK``, or ``SINGULAR`` when a pivot falls below 1e-13 of the
    largest diagonal entry (dependent constraint rows).
    """
    apply_inverse_mass(model, Bj, BMj)
    assemble_w(model, Bj, BMj, Lx)
    m = work.shape[0]
    colptr, iperm, eps = model.joints.pattern.L_colptr, model.joints.pattern.row_iperm, model.joints.eps
    for r in range(m):
        Lx[colptr[iperm[r]]] += eps[r] / (h * hk)
    return sparse_cholesky(model, Lx, work, 1e-13, 0.0, model.joints.pattern.row_iperm[:0])


@inlined
def jacobian_times(model, Bj, v, w, out):
    """``out = B V`` (m,) from the joint blocks, ``V = [v | ω]`` per node."""
    jt_i, jt_j, jt_neq, jt_row0 = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0
    for k in range(Bj.shape[0]):
        r0 = jt_row0[k]
        for r in range(jt_neq[k]):
            acc = 0.0
            for side in range(2):
                n = jt_i[k] if side == 0 else jt_j[k]
                if n < 0:
                    continue
                for a in range(3):
                    acc += Bj[k, r, 6 * side + a] * v[n, a] + Bj[k, r, 6 * side + 3 + a] * w[n, a]
            out[r0 + r] = acc


@inlined
def subtract_transpose(model, Cj, lam, v, w):
    """``V −= Cᵀ λ`` for a block matrix ``C`` (``B`` or ``B M⁻¹``) given by its joint blocks ``Cj``."""
    jt_i, jt_j, jt_neq, jt_row0 = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0
    for k in range(Cj.shape[0]):
        r0 = jt_row0[k]
        for side in range(2):
            n = jt_i[k] if side == 0 else jt_j[k]
            if n < 0:
                continue
            for r in range(jt_neq[k]):
                lr = lam[r0 + r]
                for a in range(3):
                    v[n, a] -= Cj[k, r, 6 * side + a] * lr
                    w[n, a] -= Cj[k, r, 6 * side + 3 + a] * lr


@inlined
def constraint_impulse(model, Bj, BMj, Lx, work, PHI, PHIt, v, w, h, hk, lam):
    """Stabilised implicit stage with the factor ``Lx``: correct ``v, w`` (N,3) in place.

    ``lam`` receives λ = Λ/h_k.

    Takes 12 parameters: the Model, the stage's factor and B arrays, the violation, the velocities (in place), the
    step sizes and λ, locals of the explicit step that inlines it.
    """
    m = PHI.shape[0]
    iperm = model.joints.pattern.row_iperm
    jacobian_times(model, Bj, v, w, lam)
    for r in range(m):
        work[iperm[r]] = lam[r] + PHIt[r] + PHI[r] / h
    sparse_solve(model, Lx, work)
    for r in range(m):
        lam[r] = work[iperm[r]]
    subtract_transpose(model, BMj, lam, v, w)
    for r in range(m):
        lam[r] /= hk


@inlined
def iterated_impulse(model, Bj, BMj, Lx, work, PHI, PHIt, v, w, h, hk, lam):
    """:func:`constraint_impulse` iterated, for rows whose solves are regularised beyond their equation
    (ε ≠ c: the augmented Lagrangian, :mod:`reference.joints.augmented_lagrangian`); ``v, w`` in place.

    From no estimate (Λ = 0: each projection is solved afresh, as the direct one is), up to
    ``model.joints.iterations`` times, with the factor ``Lx`` of ``W + E``, ``E = ε/(h h_k)``::

        (W + E) ΔΛ = B V + Φ_t + Φ/h − c Λ/(h h_k),    Λ ← Λ + ΔΛ,    V ← V − M⁻¹ Bᵀ ΔΛ

    until ``max |ΔΛ| ≤ model.joints.tolerance · max |Λ|``.  Its fixed point is each row's equation
    ``B V + Φ_t + Φ/h = c Λ/(h h_k)`` (for c = ε the one solve of :func:`constraint_impulse`); the
    error contracts by ``(W + E)⁻¹ (E − C)`` per solve.  ``work`` holds the right-hand side and
    ΔΛ in the solve's elimination order (``row_iperm``: both loops below index it so, ``lam``
    keeping Λ in row order); ``lam`` receives λ = Λ/h_k.

    Takes 12 parameters: those of :func:`constraint_impulse`, whose place it takes in the same stage.
    """
    iperm, c = model.joints.pattern.row_iperm, model.joints.compliance
    jt_i, jt_j, jt_neq, jt_row0 = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0
    for r in range(PHI.shape[0]):
        lam[r] = 0.0
    for _ in range(model.joints.iterations):
        for k in range(Bj.shape[0]):  # the right-hand side: jacobian_times, row by row
            for r in range(jt_row0[k], jt_row0[k] + jt_neq[k]):
                acc = 0.0
                for side in range(2):
                    n = jt_i[k] if side == 0 else jt_j[k]
                    if n >= 0:
                        for a in range(3):
                            acc += Bj[k, r - jt_row0[k], 6 * side + a] * v[n, a]
                            acc += Bj[k, r - jt_row0[k], 6 * side + 3 + a] * w[n, a]
                work[iperm[r]] = acc + PHIt[r] + PHI[r] / h - c[r] * lam[r] / (h * hk)
        sparse_solve(model, Lx, work)
        change, big = 0.0, 0.0
        for k in range(Bj.shape[0]):  # Λ += ΔΛ and V −= M⁻¹ Bᵀ ΔΛ: subtract_transpose, row by row
            for r in range(jt_row0[k], jt_row0[k] + jt_neq[k]):
                d = work[iperm[r]]
                lam[r] += d
                change, big = max(change, abs(d)), max(big, abs(lam[r]))
                for side in range(2):
                    n = jt_i[k] if side == 0 else jt_j[k]
                    if n >= 0:
                        for a in range(3):
                            v[n, a] -= BMj[k, r - jt_row0[k], 6 * side + a] * d
                            w[n, a] -= BMj[k, r - jt_row0[k], 6 * side + 3 + a] * d
        if change <= model.joints.tolerance * big:
            break
    for r in range(PHI.shape[0]):
        lam[r] /= hk


@inlined
def constraint_power(model, Bj, lam, v_old, w_old, v_new, w_new):
    """``−λᵀ B V̄`` with ``V̄ = ½(V_old + V_new)``: the power of the constraint forces."""
    P = 0.0
    jt_i, jt_j, jt_neq, jt_row0 = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0
    for k in range(Bj.shape[0]):
        r0 = jt_row0[k]
        for r in range(jt_neq[k]):
            acc = 0.0
            for side in range(2):
                n = jt_i[k] if side == 0 else jt_j[k]
                if n < 0:
                    continue
                for a in range(3):
                    acc += Bj[k, r, 6 * side + a] * 0.5 * (v_old[n, a] + v_new[n, a])
                    acc += Bj[k, r, 6 * side + 3 + a] * 0.5 * (w_old[n, a] + w_new[n, a])
            P -= lam[r0 + r] * acc
    return P
