"""Full Newton–Raphson on the static equilibrium, the reference path's corrector (:func:`static_newton`).

The load levels of :mod:`reference.plain.static` and the arc-length corrector of :mod:`reference.plain.arc_length`
(the load factor an unknown on a normal plane, by bordering) are this one loop over
:class:`reference.plain.newton.Newton`, the compiled :func:`reference.algorithms.newton_steps.newton_loop`'s
equations and convergence test written as a textbook loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from reference.plain.newton import Newton
from reference.status import DIVERGED, NO_CONVERGENCE, OK, SINGULAR


@dataclass
class LoadPath:
    """An arc-length corrector's load factor Λ (:mod:`reference.plain.arc_length`): the residual is
    ``S − Λ F + Bᵀλ``.  ``value`` Λ (in/out); ``normal`` (n_free + 1) the unit normal of the plane Λ moves on,
    in the scaled units (translations × ``weights``, then Λ), None for a fixed Λ; ``matrix(x, q, Λ)`` the
    Newton matrix with the configuration-dependent load blocks at Λ; ``moved`` (n_free + 1) the scaled
    corrections and ΔΛ, summed."""

    value: float
    normal: np.ndarray | None
    weights: np.ndarray
    matrix: Callable
    moved: np.ndarray


def static_newton(nw: Newton, x, q, lam, t, tolerance, L, max_iterations, path: LoadPath | None = None):
    """Full Newton at load level t from ``(x, q, λ)``, in place: ``(status, residual norms)``.

    Converged when the residual is balanced (every free residual force below ``tolerance`` times the
    largest internal, external (× |Λ|) or joint force, and ``|Φ − ελ| ≤ tolerance × L``) or, after a
    correction, when the correction is below ``tolerance`` (translations over L, rotations in rad).  With
    ``path`` the loads are scaled by its Λ and, on a normal plane, Λ is an unknown found by bordering
    (``K δ_F = F``, ``ΔΛ = −nᵀδ_R / (nᵀδ_F + n_Λ)``: two solves with one factor)."""
    N = x.shape[0]
    zero, history, delta = np.zeros((N, 3)), [], None
    load = 1.0 if path is None else path.value
    for it in range(max_iterations + 1):
        res = nw.evaluate(x, q, zero, zero, np.zeros((N, 6)), lam, t, False)
        r, gap = res.r + (1.0 - load) * res.F, res.phi - nw.eps * lam
        history.append(math.sqrt(nw.free_norm(r) ** 2 + float(gap @ gap)))
        if not math.isfinite(history[-1]):
            return DIVERGED, history
        scale = max(float(np.max(np.abs(res.S))), abs(load) * float(np.max(np.abs(res.F))), 1e-300)
        if nw.m:
            scale = max(scale, float(np.max(np.abs(nw.joint_forces(res, lam)))))
        balanced = (float(np.max(np.abs(r[nw.free]), initial=0.0)) <= tolerance * scale
                    and float(np.max(np.abs(gap), initial=0.0)) <= tolerance * L)
        if balanced or (delta is not None and correction_size(delta, L) <= tolerance):
            return OK, history
        if it == max_iterations:
            return NO_CONVERGENCE, history
        A = nw.matrix(x, q, zero, zero, t, lam, (0.0, 0.0, 1.0, 1.0)) if path is None else path.matrix(x, q, load)
        lu = nw.factor(A)
        solved = nw.solve(lu, -r, -gap) if lu is not None else None
        if solved is None:
            return SINGULAR, history
        delta, mu = solved
        if path is not None and path.normal is not None:
            bordered = _bordered(nw, lu, res.F, delta, mu, path)
            if bordered is None:
                return SINGULAR, history
            load += bordered
        nw.update(x, q, lam, delta, mu)
        if path is not None:
            path.value = load
            path.moved[:-1] += delta.ravel()[nw.index] * path.weights
    return NO_CONVERGENCE, history


def _bordered(nw: Newton, lu, F, delta, mu, path: LoadPath) -> float | None:
    """The load-factor correction ΔΛ on the normal plane (:func:`static_newton`), with ``δ ← δ_R + ΔΛ δ_F``,
    ``μ ← μ_R + ΔΛ μ_F`` in place; None when singular."""
    solved = nw.solve(lu, F, np.zeros(nw.m))
    if solved is None:
        return None
    dF, muF = solved
    n_u = path.normal[:-1]
    dload = -float(n_u @ (delta.ravel()[nw.index] * path.weights)) / (
        float(n_u @ (dF.ravel()[nw.index] * path.weights)) + path.normal[-1])
    if not math.isfinite(dload):
        return None
    delta += dload * dF
    mu += dload * muF
    path.moved[-1] += dload
    return dload


def correction_size(delta, L: float) -> float:
    """The largest correction: translations over the model size L, rotations in rad."""
    return max(float(np.max(np.abs(delta[:, :3]))) / L, float(np.max(np.abs(delta[:, 3:]))))
