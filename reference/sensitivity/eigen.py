"""Eigenvalue sensitivities of the modes and the buckling loads, from the eigenvectors.

For the symmetric generalised problem ``A φ = λ C φ`` with a simple eigenvalue λ, differentiating
``φᵀ(A − λ C)φ = 0`` along p (the terms in dφ vanish because ``(A − λ C)φ = 0`` and A, C are symmetric)
gives (Fox & Kapoor 1968, "Rates of change of eigenvalues and eigenvectors", AIAA J. 6) ::

    dλ/dp = φᵀ (dA/dp − λ dC/dp) φ / (φᵀ C φ).

- **Modes** about the reference state (``about = "reference"``): ``K φ = ω² M φ`` on the free coordinates,
  φ mass-normalised, so ``dω²/dp = φᵀ(∂K/∂p − ω² ∂M/∂p)φ`` and ``dω/dp = dω²/dp / (2ω)``.
- **Buckling** (:class:`reference.algorithms.linear.Buckling`): ``(K_0 + μ K_g) φ = 0`` with
  ``K_g = K_T(t_end) − K_T(t_0)``, i.e. ``A = K_0``, ``C = −K_g``.  The tangents are taken at the static
  equilibria, which move with p: their total derivative is the direct one (affine,
  :class:`reference.sensitivity.derivatives.ResidualDerivatives`' models) plus the tangent's change along the
  equilibrium's sensitivity ``(dx, dθ, dλ)/dp`` (:func:`reference.sensitivity.static.solve_static`), the
  latter by a central difference of the tangent along that direction (the residual's second derivative is
  not generated).

A repeated eigenvalue (relative gap below :data:`REPEATED`) has no derivative: the formula gives one of
its branches' and a one-line warning says so.  Models with joints are refused (the reduction to the
constraints' null space moves with p; its derivative is not written here).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

from reference.plain.newton import Newton, compose
from reference.plain.static import PlainStatic
from reference.sensitivity.derivatives import ResidualDerivatives
from reference.sensitivity.static import solve_static
from reference.status import OK
from reference.validation import ModelWarning

REPEATED = 1e-8
"""Relative gap ``|λ_k − λ_j| / |λ_k|`` under which two eigenvalues count as repeated."""


def refusal(model) -> str:
    """Why the eigenvalue sensitivities of ``model`` are not built ("" when they are): joints."""
    if model.n_constraints > 0:
        return ("eigenvalue sensitivities of a model with joints are not built (the constraints' null space moves "
                "with the parameter); use a model with fixed coordinates (clamps) only")
    return ""


def stiffness(nw: Newton, x, q, lam, t):
    """The tangent K (dense, on the free coordinates) of the static residual at ``(x, q, λ, t)``."""
    zero = np.zeros_like(x)
    nw.evaluate(x, q, zero, zero, np.zeros((x.shape[0], 6)), lam, t, False)
    return nw.matrix(x, q, zero, zero, t, lam, 0.0, 0.0, 1.0, 0.0)[: nw.n_free, : nw.n_free].toarray()


def _warn_repeated(values, k: int, what: str) -> None:
    """One line when eigenvalue k of the sorted ``values`` is repeated (:data:`REPEATED`)."""
    gaps = [abs(values[k] - values[j]) for j in (k - 1, k + 1) if 0 <= j < len(values)]
    if gaps and min(gaps) <= REPEATED * abs(values[k]):
        warnings.warn(f"{what} {k + 1} is repeated (relative gap {min(gaps) / abs(values[k]):.1e}): its sensitivity "
                      "is that of one branch only, not a derivative", ModelWarning, stacklevel=3)


def mode_sensitivities(base: Newton, moved, steps, x, q, n: int):
    """``(ω (n,) [rad/s], dω/dp (P, n))`` of the n lowest modes about ``(x, q)`` (the reference state, t = 0).

    ``moved``/``steps``: per parameter the Newton system of the model with the parameter moved by Δ and Δ
    (exact differences: K and M are affine in every parameter offered)."""
    lam = np.zeros(0)
    K0, M0 = stiffness(base, x, q, lam, 0.0), _mass(base)
    w2, phi = sla.eigh(K0, M0)  # φᵀ M φ = I
    w2, phi = w2[:n], phi[:, :n]
    for k in range(n):
        _warn_repeated(w2, k, "mode")
    omega = np.sqrt(np.maximum(w2, 0.0))
    out = np.empty((len(moved), n))
    for i, (nw, d) in enumerate(zip(moved, steps)):
        dK = (stiffness(nw, x, q, lam, 0.0) - K0) / d
        dM = (_mass(nw) - M0) / d
        dw2 = np.einsum("ak,ab,bk->k", phi, dK, phi) - w2 * np.einsum("ak,ab,bk->k", phi, dM, phi)
        out[i] = dw2 / (2.0 * omega)
    return omega, out


def _mass(nw: Newton):
    return nw.M.tocsr()[nw.index][:, nw.index].toarray()


def total_stiffness_derivative(base: Newton, nw: Newton, d: float, equilibrium, sensitivity, length: float):
    """``dK_T/dp`` (dense, free coordinates) at a static equilibrium ``(x, q, λ, t)``: the direct part
    ``(K(p + Δ) − K(p)) / Δ`` and the part along the equilibrium's sensitivity ``(dδ (N,6), dλ (m,))``, a central
    difference of step h (``h |dx| = 1e-6 length``: truncation 1e-12, rounding 1e-10 relative)."""
    x, q, lam, t = equilibrium
    dd, dlam = sensitivity
    K = stiffness(base, x, q, lam, t)
    direct = (stiffness(nw, x, q, lam, t) - K) / d
    size = max(float(np.max(np.abs(dd[:, :3]))) / length, float(np.max(np.abs(dd[:, 3:]))), 1e-300)
    h = 1e-6 / size
    plus = stiffness(base, x + h * dd[:, :3], compose(q, h * dd[:, 3:]), lam + h * dlam, t)
    minus = stiffness(base, x - h * dd[:, :3], compose(q, -h * dd[:, 3:]), lam - h * dlam, t)
    return direct + (plus - minus) / (2.0 * h)


def buckling_sensitivities(K0, K1, dK0, dK1, n: int):
    """``(μ (n,), dμ/dp (P, n))`` of the n lowest positive buckling load factors of ``(K_0 + μ K_g) φ = 0``,
    ``K_g = K_1 − K_0`` (dense), from the total derivatives ``dK0``, ``dK1`` (lists over the parameters)."""
    Kg = K1 - K0
    symmetric = all(np.allclose(K, K.T, rtol=0.0, atol=1e-12 * np.max(np.abs(K))) for K in (K0, Kg))
    if symmetric:  # −K_g φ = (1/μ) K_0 φ with K_0 positive definite: the symmetric solver, to round-off
        inverse, phi = sla.eigh(-Kg, K0)
        keep = np.flatnonzero(inverse > 0.0)[::-1][:n]
        phi = np.linalg.solve(K0, -Kg @ phi[:, keep])  # one step of inverse iteration, then the Rayleigh
        mu = np.einsum("ak,ab,bk->k", phi, K0, phi) / -np.einsum("ak,ab,bk->k", phi, Kg, phi)  # quotient
    else:  # follower loads: the general solver; the formula then needs the left eigenvector (not built)
        raise ValueError("buckling sensitivities of a non-symmetric tangent (follower loads) are not built")
    for k in range(len(mu)):
        _warn_repeated(mu, k, "buckling load factor")
    norm = -np.einsum("ak,ab,bk->k", phi, Kg, phi)  # φᵀ C φ with C = −K_g
    out = np.empty((len(dK0), len(mu)))
    for i, (a, b) in enumerate(zip(dK0, dK1)):
        dC = -(b - a)
        out[i] = (np.einsum("ak,ab,bk->k", phi, a, phi) - mu * np.einsum("ak,ab,bk->k", phi, dC, phi)) / norm
    return mu, out


def run_modes(domain, moved, steps):
    """``(ω, dω/dp)`` (:func:`mode_sensitivities`) of the modes deck ``domain`` (about the reference state), on the
    reference path; ``moved``/``steps`` per parameter as :class:`reference.sensitivity.derivatives.ResidualDerivatives`'s."""
    if domain.solver.about != "reference":
        raise ValueError(f"mode sensitivities about = {domain.solver.about!r} are not built; use about = \"reference\"")
    model = domain.initialization()
    _refuse(model)
    state = domain.initial_conditions()
    return mode_sensitivities(Newton(model), [Newton(m) for m in moved], steps, state.x, state.q,
                              int(domain.solver.modes))


def run_buckling(domain, moved, steps):
    """``(μ, dμ/dp)`` (:func:`buckling_sensitivities`) of the buckling deck ``domain``: the static path from t = 0
    to ``t_end`` on the reference path, the equilibria's sensitivities at both ends, and the total derivatives
    of their tangents (module docstring)."""
    model = domain.initialization()
    _refuse(model)
    state = domain.initial_conditions()
    static = PlainStatic.from_settings(domain.solver)
    run = static.start(model, state)
    derivatives = ResidualDerivatives(run.newton, moved, steps)
    ends = []
    for n_steps in (0, static.n_steps(domain.solver.t_end)):
        if static.advance(model, state, run, n_steps, None) != OK:
            raise ValueError(f"the static path stopped at load level {state.t:.6g}: no buckling sensitivity")
        equilibrium = (state.x.copy(), state.q.copy(), run.lam.copy(), state.t)
        d = solve_static(run.newton, derivatives, *equilibrium)
        K = stiffness(run.newton, *equilibrium)
        dK = [total_stiffness_derivative(run.newton, nw, s, equilibrium, (d[i], np.zeros(0)), run.L)
              for i, (nw, s) in enumerate(zip(derivatives.moved, steps))]
        ends.append((K, dK))
    (K0, dK0), (K1, dK1) = ends
    if not np.any(K1 != K0):
        raise ValueError("the loads at t_end equal those at t = 0: buckling sensitivities about the whole loads "
                         "(the unloaded reference) are not built; ramp the loads from zero")
    return buckling_sensitivities(K0, K1, dK0, dK1, int(domain.solver.modes))


def _refuse(model) -> None:
    problem = refusal(model)
    if problem:
        raise ValueError(problem)
