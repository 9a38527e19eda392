"""Eigenvalue sensitivities of the modes and the buckling loads, from the eigenvectors.

For the symmetric generalised problem ``A φ = λ C φ`` with a simple eigenvalue λ, differentiating
``φᵀ(A − λ C)φ = 0`` along p (the terms in dφ vanish because ``(A − λ C)φ = 0`` and A, C are symmetric)
gives (Fox & Kapoor 1968, "Rates of change of eigenvalues and eigenvectors", AIAA J. 6) ::

    dλ/dp = φᵀ (dA/dp − λ dC/dp) φ / (φᵀ C φ).

- **Modes** about the reference state (``about = "reference"``), with or without joints: the modes algorithm's
  own pencil (:func:`reference.algorithms.linearization.linearize` at the consistent multipliers, reduced to
  the null space Z of the joints' Jacobian B, :func:`reference.algorithms.linearization.reduce`),
  ``K_r φ_r = ω² M_r φ_r`` with ``K_r = Zᵀ K Z``, ``M_r = Zᵀ M Z``, φ_r mass-normalised.  When p does not move
  the constraints (B, hence Z, the same at p + Δ), Z is constant along p and the formula holds on the reduced
  pencil: ``dω²/dp = φᵀ(∂K/∂p − ω² ∂M/∂p)φ`` with ``φ = Z φ_r`` the constrained, mass-normalised mode, and
  ``dω/dp = dω²/dp / (2ω)``.  K holds the joints' geometric stiffness ``∂(Bᵀλ)/∂q`` at the multipliers λ that
  carry the loads (a hanging pendulum's weight): ∂K/∂p includes its change with λ(p), each model's K being
  taken at its own consistent λ (affine in p at an equilibrium, so the difference stays exact).  A parameter
  that moves the constraints (B at p + Δ differs from B at p beyond :data:`CONSTRAINT_CHANGE`: a joint's
  point or axis) is refused in one line, as are damped or gyroscopic modes (the first-order pencil's
  formula needs the left eigenvectors, not built).
- **Modes about the static equilibrium** at ``t_end`` (``about = "static"``): the same formula with K the
  tangent at the equilibrium, which moves with p: its total derivative as for
  buckling below (:func:`total_stiffness_derivative`).
- **Buckling** (:class:`reference.algorithms.linear.Buckling`): ``(K_0 + μ K_g) φ = 0`` with
  ``K_g = K_T(t_end) − K_T(t_0)``, i.e. ``A = K_0``, ``C = −K_g``.  The tangents are taken at the static
  equilibria, which move with p: their total derivative is the direct one (affine,
  :class:`reference.sensitivity.derivatives.ResidualDerivatives`' models) plus the tangent's change along the
  equilibrium's sensitivity ``(dx, dθ, dλ)/dp`` (:func:`reference.sensitivity.static.solve_static`), the
  latter by a central difference of the tangent along that direction (the residual's second derivative is
  not generated).

A repeated eigenvalue (relative gap below :data:`REPEATED`) has no derivative: the formula gives one of
its branches' and a one-line warning says so.

With joints, buckling carries the equilibria's multiplier sensitivities dλ/dp
(:func:`multiplier_sensitivities`: the joints' geometric stiffness ``∂(Bᵀλ)/∂q`` is in K_T) and reduces the
pencil to the null space Z of B at ``t_end`` as the algorithm does; Z moves with the equilibrium, which adds
``−2 νᵀ (dB/dp) φ`` to the numerator (``(K_0 + μ K_g) φ = Bᵀν``; :func:`buckling_sensitivities`).  Modes about a
static equilibrium with joints take the same two terms (:func:`static_mode_sensitivities`).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from reference.algorithms import linearization
from reference.linalg import SingularMatrix, null_space
from reference.modal import is_symmetric, undamped
from reference.plain.newton import EngineFace, Newton, compose
from reference.plain.static import PlainStatic
from reference.sensitivity.derivatives import ResidualDerivatives
from reference.sensitivity.static import solve_static
from reference.status import OK
from reference.validation import ModelWarning

REPEATED = 1e-8
"""Relative gap ``|λ_k − λ_j| / |λ_k|`` under which two eigenvalues count as repeated."""
CONSTRAINT_CHANGE = 1e-12
"""Relative change ``max |B(p + Δ) − B(p)| / max |B(p)|`` of the joints' Jacobian at the reference state beyond
which a parameter moves the constraints (a joint's point or axis): round-off leaves none (B does not read the
parameters offered), so any change is the parameter's."""


def stiffness(nw: Newton, x, q, lam, t):
    """The tangent K (dense, on the free coordinates) of the static residual at ``(x, q, λ, t)``."""
    zero = np.zeros_like(x)
    nw.evaluate(x, q, zero, zero, np.zeros((x.shape[0], 6)), lam, t, False)
    return nw.matrix(x, q, zero, zero, t, lam, (0.0, 0.0, 1.0, 0.0))[: nw.n_free, : nw.n_free].toarray()


def _warn_repeated(values, k: int, what: str) -> None:
    """One line when eigenvalue k of the sorted ``values`` is repeated (:data:`REPEATED`)."""
    gaps = [abs(values[k] - values[j]) for j in (k - 1, k + 1) if 0 <= j < len(values)]
    if gaps and min(gaps) <= REPEATED * abs(values[k]):
        warnings.warn(f"{what} {k + 1} is repeated (relative gap {min(gaps) / abs(values[k]):.1e}): its sensitivity "
                      "is that of one branch only, not a derivative", ModelWarning, stacklevel=3)


def linearised(model, state) -> linearization.Linearization:
    """M, D, K, B of ``model`` at the reference ``state`` with the multipliers consistent with it, as the modes
    algorithm takes them (:meth:`reference.algorithms.linear.LinearAnalysis.advance`), on the reference path."""
    face = EngineFace(Newton(model))
    face.work.angle[:] = state.angle
    lam = np.zeros(model.n_constraints)
    if model.n_constraints:
        try:
            _, lam = face.consistent_accelerations(state.x, state.q, state.v, state.w, state.t, 1e-6, ce=1.0)
        except SingularMatrix:
            raise ValueError("the constraint Jacobian at the reference state is singular (redundant, unregularised "
                             "joints): no mode sensitivity; regularise the joints (epsilon > 0)") from None
    return linearization.linearize(model, state.x, state.q, state.v, state.w, lam, state.t, state.angle, face)


def mode_sensitivities(base, moved, steps, n: int, names=None):
    """``(ω (n,) [rad/s], dω/dp (P, n))`` of the n lowest modes of the linearisation ``base``
    (:func:`linearised`), constrained to the null space of its B (module docstring).

    ``moved``/``steps``: per parameter the linearisation of the model with the parameter moved by Δ, and Δ
    (exact differences: K, M and the consistent λ are affine in every parameter offered); ``names`` the
    parameters' names for the messages.  ω as :func:`frequency_derivatives` gives it."""
    names = list(names) if names is not None else [f"number {i + 1}" for i in range(len(moved))]
    size = abs(base.B).max() if base.B.nnz else 0.0
    for lin, name in zip(moved, names):
        change = abs(lin.B - base.B).max() if (lin.B - base.B).nnz else 0.0
        if change > CONSTRAINT_CHANGE * size:
            raise ValueError(f"parameter {name} moves the joints' constraints (their Jacobian changes by "
                             f"{change / size:.1e} relative): its mode sensitivities are not built; name a "
                             "stiffness, mass or spring that the joints do not depend on")
    red = linearization.reduce(base)
    if red.D.nnz and abs(red.D).max() > 0.0:
        raise ValueError(DAMPED)
    w2, phi, kind = _lowest(red.M, red.K, n)
    phi = red.Z @ phi  # φ = Z φ_r, φᵀ M φ = 1
    return frequency_derivatives(w2, phi, kind, [((lin.K - base.K) / d, (lin.M - base.M) / d)
                                                 for lin, d in zip(moved, steps)])


DAMPED = ("mode sensitivities of damped or gyroscopic modes (dampers, a moving reference state, follower loads) "
          "are not built; take modes of the undamped model at rest")


def _lowest(M, K, n: int):
    """``(ω² (n,), φ (size, n) mass-normalised, kind (n,))``: the n lowest undamped modes of the symmetric pencil
    ``(K, M)`` (sparse) as the modes algorithm finds them (:func:`reference.modal.undamped`), a repeated one said
    in one line (one mode more is found for the last one's gap)."""
    if not is_symmetric(K):
        raise ValueError(DAMPED)
    size = M.shape[0]
    if n > size:
        raise ValueError(f"{n} modes asked of a model with {size} independent coordinates; ask at most {size}")
    found = undamped(M, K, min(n + 1, size))
    for k in np.flatnonzero(found.kind[:n] != "zero"):  # a zero mode's derivative is 0, repeated or not
        _warn_repeated(found.omega2, k, "mode")
    return found.omega2[:n], found.phi[:, :n], found.kind[:n]


def frequency_derivatives(w2, phi, kind, derivatives, moving=0.0):
    """``(ω (n,), dω/dp (P, n))`` from the modes ``(ω², φ mass-normalised, kind)`` and per parameter the derivatives
    ``(dK/dp, dM/dp)`` (sparse or dense, on φ's coordinates): ``dω²/dp = φᵀ(dK/dp − ω² dM/dp)φ`` (plus ``moving``
    (P, n), a moving null space's share), ``dω = dω²/(2ω)``.
    ω is the modes algorithm's ``2π frequency``: for an unstable mode (ω² < 0) its growth rate ``sqrt(−ω²)``; a
    zero mode (rigid-body or mechanism) stays zero along p: 0."""
    omega = np.sqrt(np.abs(w2))
    rate = np.where(kind == "zero", 0.0, np.where(kind == "unstable", -0.5, 0.5) / np.where(omega > 0, omega, 1))
    out = np.empty((len(derivatives), len(w2)))
    for i, (dK, dM) in enumerate(derivatives):
        out[i] = np.einsum("ak,ak->k", phi, dK @ phi) - w2 * np.einsum("ak,ak->k", phi, dM @ phi)
    return omega, rate * (out + moving)


def total_stiffness_derivative(base: Newton, nw: Newton, d: float, equilibrium, sensitivity, length: float):
    """``dK_T/dp`` (dense, free coordinates) at a static equilibrium ``(x, q, λ, t)``: the direct part
    ``(K(p + Δ) − K(p)) / Δ`` and the part along the equilibrium's sensitivity ``(dδ (N,6), dλ (m,))``, a central
    difference of step h (``h |dx| = 1e-4 length``: truncation 1e-8 relative, rounding 1e-12 of the largest entries,
    the axial ones; a smaller step lets that rounding reach a bending mode's share: docs/benchmarks.md §13)."""
    x, q, lam, t = equilibrium
    dd, dlam = sensitivity
    K = stiffness(base, x, q, lam, t)
    direct = (stiffness(nw, x, q, lam, t) - K) / d
    size = max(float(np.max(np.abs(dd[:, :3]))) / length, float(np.max(np.abs(dd[:, 3:]))), 1e-300)
    h = 1e-4 / size
    plus = stiffness(base, x + h * dd[:, :3], compose(q, h * dd[:, 3:]), lam + h * dlam, t)
    minus = stiffness(base, x - h * dd[:, :3], compose(q, -h * dd[:, 3:]), lam - h * dlam, t)
    return direct + (plus - minus) / (2.0 * h)


def buckling_sensitivities(K0, K1, dK0, dK1, n: int, constraint=None):
    """``(μ (n,), dμ/dp (P, n))`` of the n lowest positive buckling load factors of ``(K_0 + μ K_g) φ = 0``,
    ``K_g = K_1 − K_0`` (dense, free coordinates), from the total derivatives ``dK0``, ``dK1`` (lists over the
    parameters).  ``constraint``: None, or ``(B, dB)`` the joints' Jacobian at the end equilibrium (m, n) and its
    total derivatives (list over the parameters): the pencil is then reduced to the null space Z of B, as the
    buckling algorithm reduces it, and Z moves with the equilibrium: with ``A = K_0 + μ K_g``, ``A φ = Bᵀν``
    (``Zᵀ A φ = 0``) and ``B dZ = −dB Z``, ``φᵀ d(ZᵀAZ)/dp φ_r = φᵀ dA φ − 2 νᵀ dB φ``."""
    Z = np.eye(K0.shape[0]) if constraint is None else null_space(sps.csr_matrix(constraint[0]))[0].toarray()
    K0r, Kgr = Z.T @ K0 @ Z, Z.T @ (K1 - K0) @ Z
    symmetric = all(np.allclose(K, K.T, rtol=0.0, atol=1e-12 * np.max(np.abs(K))) for K in (K0r, Kgr))
    if not symmetric:  # follower loads: the general solver; the formula then needs the left eigenvector
        raise ValueError("buckling sensitivities of a non-symmetric tangent (follower loads) are not built")
    inverse, phi = sla.eigh(-Kgr, K0r)  # −K_g φ = (1/μ) K_0 φ with K_0 positive definite: to round-off
    keep = np.flatnonzero(inverse > 0.0)[::-1][:n]
    phi = np.linalg.solve(K0r, -Kgr @ phi[:, keep])  # one step of inverse iteration, then the Rayleigh
    mu = np.einsum("ak,ab,bk->k", phi, K0r, phi) / -np.einsum("ak,ab,bk->k", phi, Kgr, phi)  # quotient
    for k in range(len(mu)):
        _warn_repeated(mu, k, "buckling load factor")
    phi = Z @ phi
    Kg = K1 - K0
    norm = -np.einsum("ak,ab,bk->k", phi, Kg, phi)  # φᵀ C φ with C = −K_g
    nu = 0.0 if constraint is None else np.linalg.lstsq(constraint[0].T, K0 @ phi + mu * (Kg @ phi), rcond=None)[0]
    out = np.empty((len(dK0), len(mu)))
    for i, (a, b) in enumerate(zip(dK0, dK1)):
        out[i] = np.einsum("ak,ab,bk->k", phi, a, phi) + mu * np.einsum("ak,ab,bk->k", phi, b - a, phi)
        if constraint is not None:
            out[i] -= 2.0 * np.einsum("ak,ak->k", nu, constraint[1][i] @ phi)
        out[i] /= norm
    return mu, out


def jacobian(nw: Newton, x, q, lam, t) -> np.ndarray:
    """The joints' Jacobian B (m, free coordinates, dense) at ``(x, q)``."""
    zero = np.zeros_like(x)
    return nw.evaluate(x, q, zero, zero, np.zeros((x.shape[0], 6)), lam, t, False).B.tocsc()[:, nw.index].toarray()


def multiplier_sensitivities(nw: Newton, derivatives, equilibrium, d) -> list:
    """``dλ/dp`` (per parameter, (m,)) at a static equilibrium with the state sensitivities ``d`` (P, N, 6)
    (:func:`reference.sensitivity.static.solve_static`): the first block row of its system,
    ``Bᵀ dλ = −(∂r/∂p + K dδ)`` on the free coordinates, solved by least squares (B of full row rank: exact)."""
    x, q, lam, t = equilibrium
    if nw.m == 0:
        return [np.zeros(0)] * len(d)
    zero = np.zeros_like(x)
    rhs = derivatives(x, q, zero, zero, np.zeros((x.shape[0], 6)), lam, t, False)  # evaluates nw here: its B
    BT = nw.last.B.tocsc()[:, nw.index].T.toarray()
    K = stiffness(nw, x, q, lam, t)
    return [np.linalg.lstsq(BT, -(dr.ravel()[nw.index] + K @ dd.ravel()[nw.index]), rcond=None)[0]
            for (dr, _), dd in zip(rhs, d)]


def jacobian_derivative(nw: Newton, equilibrium, dd, length: float) -> np.ndarray:
    """``dB/dp`` (dense, free coordinates) along the equilibrium's sensitivity ``dd`` (N,6): B reads no parameter
    offered, so its change is the configuration's; a central difference of the step of
    :func:`total_stiffness_derivative`."""
    x, q, lam, t = equilibrium
    size = max(float(np.max(np.abs(dd[:, :3]))) / length, float(np.max(np.abs(dd[:, 3:]))), 1e-300)
    h = 1e-4 / size
    plus = jacobian(nw, x + h * dd[:, :3], compose(q, h * dd[:, 3:]), lam, t)
    return (plus - jacobian(nw, x - h * dd[:, :3], compose(q, -h * dd[:, 3:]), lam, t)) / (2.0 * h)


def run_modes(domain, moved, steps, names=None):
    """``(ω, dω/dp)`` of the modes deck ``domain`` on the reference path: about the reference state
    (:func:`mode_sensitivities`, joints allowed) or about the static equilibrium at ``t_end``
    (:func:`static_mode_sensitivities`); ``moved``/``steps`` per parameter as
    :class:`reference.sensitivity.derivatives.ResidualDerivatives`'s, ``names`` the parameters' names for the
    messages."""
    if domain.solver.about not in ("reference", "static"):
        raise ValueError(f"mode sensitivities about = {domain.solver.about!r} are not built; use about = "
                         "\"reference\" or \"static\"")
    model = domain.initialization()
    state = domain.initial_conditions()
    if domain.solver.about == "static":
        return static_mode_sensitivities(domain, model, state, moved, steps)
    return mode_sensitivities(linearised(model, state), [linearised(m, state) for m in moved], steps,
                              int(domain.solver.modes), names)


def static_mode_sensitivities(domain, model, state, moved, steps):
    """``(ω, dω/dp)`` of the modes about the static equilibrium at ``t_end`` (``about = "static"``): the static
    path on the reference path, the equilibrium's sensitivity (state and multipliers), K_T's total derivative
    (:func:`total_stiffness_derivative`) and M's direct one; with joints the pencil on the null space Z of B there,
    and Z's change along the equilibrium: ``−2 νᵀ (dB/dp) φ`` with ``(K − ω² M) φ = Bᵀν`` (as for buckling)."""
    *_, (equilibrium, derivatives, length) = _equilibria(domain, model, state, moved, steps)
    base = derivatives.base
    K, M = stiffness(base, *equilibrium), _mass(base).toarray()
    d = solve_static(base, derivatives, *equilibrium)
    dlam = multiplier_sensitivities(base, derivatives, equilibrium, d)
    B = jacobian(base, *equilibrium) if model.n_constraints else np.zeros((0, K.shape[0]))
    Z = null_space(sps.csr_matrix(B))[0].toarray() if model.n_constraints else np.eye(K.shape[0])
    w2, phi, kind = _lowest(sps.csr_matrix(Z.T @ M @ Z), sps.csr_matrix(Z.T @ K @ Z), int(domain.solver.modes))
    phi = Z @ phi
    moving = np.zeros((len(steps), len(w2)))
    if model.n_constraints:
        nu = np.linalg.lstsq(B.T, K @ phi - w2 * (M @ phi), rcond=None)[0]
        moving = np.array([-2.0 * np.einsum("ak,ak->k", nu, jacobian_derivative(base, equilibrium, dd, length) @ phi)
                           for dd in d]).reshape(len(steps), len(w2))
    return frequency_derivatives(w2, phi, kind, [
        (total_stiffness_derivative(base, nw, s, equilibrium, (d[i], dlam[i]), length), (_mass(nw) - M) / s)
        for i, (nw, s) in enumerate(zip(derivatives.moved, steps))], moving)


def _mass(nw: Newton) -> sps.csr_matrix:
    """The mass matrix of ``nw`` on the free coordinates."""
    return sps.csr_matrix(nw.M)[nw.index][:, nw.index]


def _equilibria(domain, model, state, moved, steps):
    """The static path of ``domain`` on the reference path, yielding ``(equilibrium (x, q, λ, t), derivatives,
    length)`` at t = 0 and then at ``t_end`` (each to be used before the next: the Newton system's state moves
    on), ``derivatives`` the parameters' :class:`ResidualDerivatives` over the run's Newton system, ``length``
    the run's length scale."""
    static = PlainStatic.from_settings(domain.solver)
    run = static.start(model, state)
    derivatives = ResidualDerivatives(run.newton, moved, steps)
    for n_steps in (0, static.n_steps(domain.solver.t_end)):
        if static.advance(model, state, run, n_steps, None) != OK:
            raise ValueError(f"the static path stopped at load level {state.t:.6g}: no eigenvalue sensitivity")
        yield (state.x.copy(), state.q.copy(), run.lam.copy(), state.t), derivatives, run.L


def run_buckling(domain, moved, steps):
    """``(μ, dμ/dp)`` (:func:`buckling_sensitivities`) of the buckling deck ``domain``: the static path from t = 0
    to ``t_end`` on the reference path, the equilibria's sensitivities (state and multipliers) at both ends, the
    total derivatives of their tangents and, with joints, of the Jacobian at ``t_end`` (module docstring)."""
    model = domain.initialization()
    state = domain.initial_conditions()
    ends = []
    for equilibrium, derivatives, length in _equilibria(domain, model, state, moved, steps):
        base = derivatives.base
        d = solve_static(base, derivatives, *equilibrium)
        dlam = multiplier_sensitivities(base, derivatives, equilibrium, d)
        K = stiffness(base, *equilibrium)
        dK = [total_stiffness_derivative(base, nw, s, equilibrium, (d[i], dlam[i]), length)
              for i, (nw, s) in enumerate(zip(derivatives.moved, steps))]
        constraint = None
        if model.n_constraints:
            constraint = (jacobian(base, *equilibrium), [jacobian_derivative(base, equilibrium, dd, length) for dd in d])
        ends.append((K, dK, constraint))
    (K0, dK0, _), (K1, dK1, constraint) = ends
    if not np.any(K1 != K0):
        raise ValueError("the loads at t_end equal those at t = 0: buckling sensitivities about the whole loads "
                         "(the unloaded reference) are not built; ramp the loads from zero")
    return buckling_sensitivities(K0, K1, dK0, dK1, int(domain.solver.modes), constraint)
