"""Compiled constraint assembly and the stabilised Lagrange-multiplier solve.

``assemble_constraints`` evaluates every joint's rows (the generated
primitives, combined for drives) into the global ``Φ`` (m,), ``Φ_t`` (m,) and
``B`` (m, 6N) with columns ``[v_n (inertial) | ω_n (body)]`` per node.

``constraint_impulse`` is the implicit stage of Park's staggered step with the
Park–Chiou stabilisation (FORMULATION.md, a reconstruction): with the predicted
velocities ``V*`` and the kick length ``h_k`` (``h``, or ``h/2`` at start-up),
the impulse ``Λ = h_k λ`` solves::

    (B M⁻¹ Bᵀ + ε/(h h_k) I) Λ = B V* + Φ_t + Φ/h

and ``V = V* − M⁻¹ Bᵀ Λ``.  For ``h_k = h`` this is
``(B M⁻¹ Bᵀ + ε/h² I) λ = (1/h) B V* + (1/h²) Φ + (1/h) Φ_t`` (backward
Euler on ``ε λ = Φ``): the drift of the next positions makes ``Φ`` vanish to
first order, so ``Φ`` stays bounded instead of drifting as it does under a pure
velocity projection.  ``ε = 0`` is a linearised position projection; ``ε > 0``
regularises redundant constraints.  The symmetric positive matrix is factored
in place (Cholesky): no allocation per step.
"""

from __future__ import annotations

import math

import numpy as np

from reference.generated import joints as generated
from reference.interactions import tf_derivative, tf_integral, tf_value
from reference.jit import kernel

OK, SINGULAR = 0, 2
GROUND_X = np.zeros(3)
GROUND_Q = np.array([1.0, 0.0, 0.0, 0.0])
"""The ground's position and Euler parameters (read-only constants)."""


@kernel
def joint_rows(x, q, i, j, par, rows, drive, tf_kind, tf_par, t, phi, B, phit, prim_phi, prim_B):
    """Rows of one joint: Φ (m,), local B (m, 12) = [v_i | ω_i | v_j | ω_j], Φ_t (m,).

    ``j = -1`` is the ground (x = 0, identity rotation; its columns are zero).
    ``drive`` 0 none; 1/2 rotation drive with θ = f(t) / θ = ∫f; 3/4 displacement
    drive with s = f(t) / s = ∫f.
    """
    if j >= 0:
        generated.joint_primitives(x[i], q[i], x[j], q[j], par[0:3], par[3:6], par[6:15], par[15:24], prim_phi, prim_B)
    else:
        generated.joint_primitives(x[i], q[i], GROUND_X, GROUND_Q, par[0:3], par[3:6], par[6:15], par[15:24],
                                   prim_phi, prim_B)
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
    else:
        if drive == 3:
            sv, sd = tf_value(tf_kind, tf_par, t), tf_derivative(tf_kind, tf_par, t)
        else:
            sv, sd = tf_integral(tf_kind, tf_par, t), tf_value(tf_kind, tf_par, t)
        phi[0] = prim_phi[8] - sv
        phit[0] = -sd
        for k in range(12):
            B[0, k] = prim_B[96 + k]
    if j < 0:
        for r in range(phi.shape[0]):
            for k in range(6, 12):
                B[r, k] = 0.0


@kernel
def assemble_constraints(model, x, q, t, PHI, PHIt, Bg, jphi, jB, jphit, prim_phi, prim_B):
    """Global Φ, Φ_t and B (m, 6N) of all joints at time t."""
    Bg[:, :] = 0.0
    for k in range(model.jt_i.shape[0]):
        m = model.jt_neq[k]
        r0 = model.jt_row0[k]
        i, j = model.jt_i[k], model.jt_j[k]
        tf = model.jt_tf[k]
        joint_rows(x, q, i, j, model.jt_par[k], model.jt_rows[k], model.jt_drive[k], model.tf_kind[tf],
                   model.tf_par[tf], t, jphi[:m], jB[:m], jphit[:m], prim_phi, prim_B)
        for r in range(m):
            PHI[r0 + r] = jphi[r]
            PHIt[r0 + r] = jphit[r]
            for c in range(6):
                Bg[r0 + r, 6 * i + c] += jB[r, c]
                if j >= 0:
                    Bg[r0 + r, 6 * j + c] += jB[r, 6 + c]


@kernel
def apply_inverse_mass(model, Bg, BM):
    """``BM = B M⁻¹`` with the lumped, block-diagonal M (fixed coordinates have M⁻¹ = 0)."""
    for r in range(Bg.shape[0]):
        for n in range(model.mass.shape[0]):
            for a in range(3):
                BM[r, 6 * n + a] = Bg[r, 6 * n + a] * model.free[n, a] / model.mass[n]
            for a in range(3):
                acc = 0.0
                for b in range(3):
                    acc += Bg[r, 6 * n + 3 + b] * model.free[n, 3 + b] * model.inertia_inv[n, b, a]
                BM[r, 6 * n + 3 + a] = acc * model.free[n, 3 + a]


@kernel
def cholesky_solve(W, rhs):
    """Solve ``W y = rhs`` in place (W symmetric positive definite, overwritten by its factor).

    Returns ``OK``, or ``SINGULAR`` when a pivot falls below 1e-13 of the
    largest diagonal entry (dependent constraint rows).
    """
    m = W.shape[0]
    scale = 0.0
    for k in range(m):
        scale = max(scale, abs(W[k, k]))
    for k in range(m):
        d = W[k, k]
        for p in range(k):
            d -= W[k, p] * W[k, p]
        if d <= 1e-13 * scale:
            return SINGULAR
        d = math.sqrt(d)
        W[k, k] = d
        for r in range(k + 1, m):
            s = W[r, k]
            for p in range(k):
                s -= W[r, p] * W[k, p]
            W[r, k] = s / d
    for k in range(m):
        s = rhs[k]
        for p in range(k):
            s -= W[k, p] * rhs[p]
        rhs[k] = s / W[k, k]
    for k in range(m - 1, -1, -1):
        s = rhs[k]
        for p in range(k + 1, m):
            s -= W[p, k] * rhs[p]
        rhs[k] = s / W[k, k]
    return OK


@kernel
def constraint_impulse(model, Bg, BM, PHI, PHIt, v, w, h, hk, W, lam):
    """Stabilised implicit stage: correct ``v, w`` (N,3) in place; ``lam`` gets λ = Λ/h_k.

    Returns ``OK`` or ``SINGULAR``.
    """
    m = PHI.shape[0]
    N = v.shape[0]
    apply_inverse_mass(model, Bg, BM)
    for r in range(m):
        for s in range(r + 1):
            acc = 0.0
            for c in range(6 * N):
                acc += BM[r, c] * Bg[s, c]
            W[r, s] = acc
            W[s, r] = acc
        W[r, r] += model.row_eps[r] / (h * hk)
        acc = PHIt[r] + PHI[r] / h
        for n in range(N):
            for a in range(3):
                acc += Bg[r, 6 * n + a] * v[n, a] + Bg[r, 6 * n + 3 + a] * w[n, a]
        lam[r] = acc
    status = cholesky_solve(W, lam)
    if status != OK:
        return status
    for n in range(N):
        for a in range(3):
            dv = 0.0
            dw = 0.0
            for r in range(m):
                dv += BM[r, 6 * n + a] * lam[r]
                dw += BM[r, 6 * n + 3 + a] * lam[r]
            v[n, a] -= dv
            w[n, a] -= dw
    for r in range(m):
        lam[r] /= hk
    return OK


@kernel
def constraint_power(Bg, lam, v_old, w_old, v_new, w_new):
    """``−λᵀ B V̄`` with ``V̄ = ½(V_old + V_new)``: the power of the constraint forces."""
    P = 0.0
    for r in range(lam.shape[0]):
        acc = 0.0
        for n in range(v_new.shape[0]):
            for a in range(3):
                acc += Bg[r, 6 * n + a] * 0.5 * (v_old[n, a] + v_new[n, a])
                acc += Bg[r, 6 * n + 3 + a] * 0.5 * (w_old[n, a] + w_new[n, a])
        P -= lam[r] * acc
    return P
