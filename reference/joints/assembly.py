"""Compiled constraint assembly and the stabilised Lagrange-multiplier solve.

``assemble_constraints`` evaluates every joint's rows (the generated
primitives, combined for drives) into the global ``Φ`` (m,), ``Φ_t`` (m,) and
``B`` (m, 6N) with columns ``[v_n (inertial) | ω_n (body)]`` per node.

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
    """``BM = B M⁻¹`` with the lumped, block-diagonal M (fixed coordinates have M⁻¹ = 0).

    Only the (at most two) nodes of each row are visited (``model.row_nodes``).
    """
    BM[:, :] = 0.0
    for r in range(Bg.shape[0]):
        for side in range(2):
            n = model.row_nodes[r, side]
            if n < 0:
                continue
            for a in range(3):
                BM[r, 6 * n + a] = Bg[r, 6 * n + a] * model.free[n, a] / model.mass[n]
            for a in range(3):
                acc = 0.0
                for b in range(3):
                    acc += Bg[r, 6 * n + 3 + b] * model.free[n, 3 + b] * model.inertia_inv[n, b, a]
                BM[r, 6 * n + 3 + a] = acc * model.free[n, 3 + a]


@kernel
def _row_dot(model, r, s, X, Y):
    """``X[r] · Y[s]`` over the nodes of row r (the rows are zero elsewhere)."""
    acc = 0.0
    for side in range(2):
        n = model.row_nodes[r, side]
        if n < 0:
            continue
        for c in range(6 * n, 6 * n + 6):
            acc += X[r, c] * Y[s, c]
    return acc


@kernel
def cholesky_factor(W):
    """Factor the symmetric positive definite ``W`` in place (lower triangle).

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
    return OK


@kernel
def cholesky_solve(L, rhs):
    """Solve ``L Lᵀ y = rhs`` in place with the factor from :func:`cholesky_factor`."""
    m = L.shape[0]
    for k in range(m):
        s = rhs[k]
        for p in range(k):
            s -= L[k, p] * rhs[p]
        rhs[k] = s / L[k, k]
    for k in range(m - 1, -1, -1):
        s = rhs[k]
        for p in range(k + 1, m):
            s -= L[p, k] * rhs[p]
        rhs[k] = s / L[k, k]


@kernel
def factor_constraints(model, Bg, BM, W, h, hk):
    """``BM = B M⁻¹`` and the Cholesky factor of ``B M⁻¹ Bᵀ + ε/(h h_k) I`` into ``W``."""
    m = Bg.shape[0]
    apply_inverse_mass(model, Bg, BM)
    for r in range(m):
        for s in range(r + 1):
            W[r, s] = _row_dot(model, r, s, BM, Bg) if _shares_node(model, r, s) else 0.0
        W[r, r] += model.row_eps[r] / (h * hk)
    return cholesky_factor(W)


@kernel
def _shares_node(model, r, s):
    for a in range(2):
        n = model.row_nodes[r, a]
        if n >= 0 and (n == model.row_nodes[s, 0] or n == model.row_nodes[s, 1]):
            return True
    return False


@kernel
def constraint_impulse(model, Bg, BM, L, PHI, PHIt, v, w, h, hk, lam):
    """Stabilised implicit stage with the factor ``L``: correct ``v, w`` (N,3) in place.

    ``lam`` receives λ = Λ/h_k.
    """
    m = PHI.shape[0]
    for r in range(m):
        acc = PHIt[r] + PHI[r] / h
        for side in range(2):
            n = model.row_nodes[r, side]
            if n < 0:
                continue
            for a in range(3):
                acc += Bg[r, 6 * n + a] * v[n, a] + Bg[r, 6 * n + 3 + a] * w[n, a]
        lam[r] = acc
    cholesky_solve(L, lam)
    for r in range(m):
        for side in range(2):
            n = model.row_nodes[r, side]
            if n < 0:
                continue
            for a in range(3):
                v[n, a] -= BM[r, 6 * n + a] * lam[r]
                w[n, a] -= BM[r, 6 * n + 3 + a] * lam[r]
    for r in range(m):
        lam[r] /= hk


@kernel
def constraint_power(model, Bg, lam, v_old, w_old, v_new, w_new):
    """``−λᵀ B V̄`` with ``V̄ = ½(V_old + V_new)``: the power of the constraint forces."""
    P = 0.0
    for r in range(lam.shape[0]):
        acc = 0.0
        for side in range(2):
            n = model.row_nodes[r, side]
            if n < 0:
                continue
            for a in range(3):
                acc += Bg[r, 6 * n + a] * 0.5 * (v_old[n, a] + v_new[n, a])
                acc += Bg[r, 6 * n + 3 + a] * 0.5 * (w_old[n, a] + w_new[n, a])
        P -= lam[r] * acc
    return P
