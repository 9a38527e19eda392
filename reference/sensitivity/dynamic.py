"""Generalized-α sensitivities by direct differentiation: the tangent-linear step (docs/formulation.md §14).

Each accepted step of :func:`reference.plain.generalized_alpha.alpha_step` is differentiated along p with the
configuration's sensitivity in the Newton increments' coordinates (inertial ``x'``, body-frame ``θ'``) ::

    a'_{n+1} = a'_p + c β' δ',    a'_p = (V̇'_n − α_m a'_n)/(1 − α_m),   c = (1 − α_f)/(1 − α_m),
    Δq' = V'_n + h(½ − β) a'_n + hβ a'_{n+1},      V'_{n+1} = V'_n + h(1 − γ) a'_n + hγ a'_{n+1},
    x'_{n+1} = x'_n + h Δq'_x,      θ'_{n+1} = R(ψ)ᵀ θ'_n + J_r(ψ) h Δq'_θ    (ψ = h Δq_θ, the step's rotation),

and the residual and constraints linearised at the converged step,
``M V̇' + C V' + K (x', θ') + Bᵀλ' = −∂r/∂p``, ``B (x', θ') − ε λ' = −∂Φ/∂p``.  With ``V̇'_{n+1} = V̇'_n + β' δ'``,
``λ'_{n+1} = λ'_n + β' μ'`` the unknowns ``(δ', μ')`` solve the step's own Newton matrix
``[M + (γ'/β') C + K T(ψ)/β', Bᵀ; B T(ψ), −β' ε]`` (:meth:`reference.plain.newton.Newton.matrix`), factorised
once at the converged state of the step and back-substituted once per parameter.  The initial ``V̇'_0``, ``λ'_0``
differentiate the consistent accelerations (:meth:`reference.plain.newton.Newton.consistent_accelerations`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from reference.generated import rotation_maps as rm
from reference.plain.backend import twin
from reference.plain.generalized_alpha import PlainGeneralizedAlpha
from reference.plain.newton import relative_rotation
from reference.plain.vectorise import plain
from reference.observables import _Names
from reference.sensitivity.derivatives import Moved, ParameterDerivatives, output_derivatives
from reference.status import OK


@dataclass
class Tangent:
    """Per parameter the sensitivities of the state (P, N, 6) — configuration ``c`` (x', θ'), velocities ``V``,
    accelerations ``vd``, algorithmic accelerations ``a`` — and of the multipliers ``lam`` (P, m)."""

    c: np.ndarray
    V: np.ndarray
    vd: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    history: list = field(default_factory=list)


class SensitiveAlpha(PlainGeneralizedAlpha):
    """:class:`reference.plain.generalized_alpha.PlainGeneralizedAlpha` that carries the tangent-linear
    sensitivities of :attr:`derivatives`' parameters along every accepted step (module docstring)."""

    derivatives: ParameterDerivatives
    tangent: Tangent | None = None

    def _initial(self, run, state) -> int:
        code = super()._initial(run, state)
        if code == OK:
            self.tangent = initial_tangent(self, run, state)
        return code

    def step(self, state, run, h: float, count: bool = True) -> int:
        q0 = state.q.copy()
        code = super().step(state, run, h, count)
        if code == OK:
            tangent_step(self, run, state, relative_rotation(q0, state.q), h)
        return code


def _coefficients(algo, h):
    """``(β', γ')`` of the step h [s]."""
    bp = (1.0 - algo.alpha_m) / (h * h * algo.beta * (1.0 - algo.alpha_f))
    return bp, algo.gamma / (h * algo.beta)


def initial_tangent(algo, run, state) -> Tangent:
    """``V̇'_0``, ``λ'_0`` from the consistent accelerations ``A s = b``, ``A = [M, Bᵀ; B, −c_e ε]``, ``s = (V̇, λ)``.

    For a parameter that moves neither the constraints nor their acceleration level (all but a drive's time
    function and a spring's stiffness, :class:`reference.sensitivity.derivatives.Moved`), differentiating
    ``r(V̇, λ; p) = 0`` at the fixed state gives ``A s' = [−∂r/∂p; 0]``, with ∂r/∂p at the consistent ``(V̇, λ)``
    (it holds ``∂M/∂p V̇``).  For a moved one, ``A s' = b' − A' s`` with b affine in p and only M of A depending
    on it: ``s' = (s(p+Δ) − s(p))/Δ + A⁻¹ [ΔM (V̇(p+Δ) − V̇(p))/Δ; 0]`` (ΔM = M(p+Δ) − M(p)), from the two
    solutions (a central difference for a time function's value)."""
    nw, h, al = run.newton, run.h, run.alpha
    bp, _ = _coefficients(algo, h)
    x, q, v, w, t = state.x, state.q, state.v, state.w, state.t
    rd = algo.derivatives
    P, N = len(rd.kinds), x.shape[0]
    rhs = rd(x, q, v, w, al.vd, al.lam, t, True)  # leaves nw evaluated here: the matrix reads its B
    lu = nw.factor(nw.matrix(x, q, v, w, t, np.zeros(nw.m), (1.0, 0.0, 0.0, bp)))
    vd, lam = np.zeros((P, N, 6)), np.zeros((P, nw.m))
    for k, kind in enumerate(rd.kinds):
        if not isinstance(kind, Moved):
            vd[k], lam[k] = nw.solve(lu, -rhs[k][0], np.zeros(nw.m))
            continue
        moved, back = rd.moved(kind)
        moved.angle[:] = nw.angle
        vd_d, lam_d = moved.consistent_accelerations(x, q, v, w, t, 1e-3 * h, ce=bp)
        if back is None:
            dvd, dlam = (vd_d - al.vd) / kind.step, (lam_d - al.lam) / kind.step
        else:  # a central difference (M does not depend on such a parameter)
            back.angle[:] = nw.angle
            vd_m, lam_m = back.consistent_accelerations(x, q, v, w, t, 1e-3 * h, ce=bp)
            dvd, dlam = (vd_d - vd_m) / (2.0 * kind.step), (lam_d - lam_m) / (2.0 * kind.step)
        extra = ((moved.M - nw.M) @ dvd.ravel()).reshape(N, 6)
        fix = nw.solve(lu, extra, np.zeros(nw.m)) if np.any(extra) else (np.zeros((N, 6)), np.zeros(nw.m))
        vd[k], lam[k] = dvd + fix[0], dlam + fix[1]
    return Tangent(np.zeros((P, N, 6)), np.zeros((P, N, 6)), vd, vd.copy(), lam)


def tangent_step(algo, run, state, psi, h: float) -> None:
    """Carry :attr:`SensitiveAlpha.tangent` over the step of h [s] just accepted (``psi`` (N,3) its rotation
    ``log(q_n⁻¹ q_{n+1})``): one factorisation of the Newton matrix at the converged state, one back-substitution
    per parameter (module docstring)."""
    tg, nw, al = algo.tangent, run.newton, run.alpha
    bp, gp = _coefficients(algo, h)
    c = (1.0 - algo.alpha_f) / (1.0 - algo.alpha_m)
    x, q, t = state.x, state.q, state.t + h  # the caller advances the clock after the step
    rhs = algo.derivatives(x, q, state.v, state.w, al.vd, al.lam, t, True)  # leaves nw evaluated here (its B)
    K = nw.ev.tangent(x, q, state.v, state.w, t, al.lam if nw.m else None, nw.angle)
    C = nw.ev.damping_matrix(x, q, state.v, state.w)
    ev, nw.ev = nw.ev, _Known(nw.ev, K, C)  # the matrix from these K and C, not computed again
    try:
        lu = nw.factor(nw.matrix(x, q, state.v, state.w, t, al.lam, (1.0, gp / bp, 1.0 / bp, bp), psi))
    finally:
        nw.ev = ev
    Rt, Jr = _rotation_maps(psi)
    for k, (dr, dphi) in enumerate(rhs):
        a_p = (tg.vd[k] - algo.alpha_m * tg.a[k]) / (1.0 - algo.alpha_m)
        dq = tg.V[k] + h * (0.5 - algo.beta) * tg.a[k] + h * algo.beta * a_p
        V_p = tg.V[k] + h * (1.0 - algo.gamma) * tg.a[k] + h * algo.gamma * a_p
        cfg = np.hstack([tg.c[k, :, :3] + h * dq[:, :3],
                         np.einsum("nab,nb->na", Rt, tg.c[k, :, 3:]) + np.einsum("nab,nb->na", Jr, h * dq[:, 3:])])
        r = dr + (K @ cfg.ravel() + C @ V_p.ravel() + nw.M @ tg.vd[k].ravel()).reshape(-1, 6)
        if nw.m:
            r += (nw.last.B.T @ tg.lam[k]).reshape(-1, 6)
            g = dphi + nw.last.B @ cfg.ravel() - nw.eps * tg.lam[k]
        else:
            g = np.zeros(0)
        delta, mu = nw.solve(lu, -r / bp, -g)
        tg.c[k] = cfg + np.hstack([delta[:, :3], np.einsum("nab,nb->na", Jr, delta[:, 3:])])
        tg.V[k] = V_p + gp * delta
        tg.vd[k] = tg.vd[k] + bp * delta
        tg.a[k] = a_p + c * bp * delta
        tg.lam[k] = tg.lam[k] + bp * mu
    tg.history.append((t, x.copy(), q.copy(), tg.c.copy()))


class _Known:
    """An :class:`reference.plain.model.Evaluation` whose tangent and damping matrix at the state at hand are
    known (``K``, ``C``): :meth:`reference.plain.newton.Newton.matrix` reads them through it instead of
    assembling them a second time (the step's residual needs ``K (x', θ')`` and ``C V'`` too)."""

    def __init__(self, ev, K, C):
        self._ev, self._K, self._C = ev, K, C

    def tangent(self, *state, **keywords):
        return self._K

    def damping_matrix(self, *state):
        return self._C

    def __getattr__(self, name):
        return getattr(self._ev, name)


def _rotation_maps(psi):
    """Per node ``A(exp ψ)ᵀ`` and the right Jacobian ``J_r(ψ)`` (N,3,3) (the generated maps)."""
    N = psi.shape[0]
    e, A, J = np.empty((4, N)), np.empty((9, N)), np.empty((9, N))
    plain(rm.exp_quaternion)(psi.T, e)
    plain(rm.rotation_matrix)(e, A)
    plain(rm.right_jacobian)(psi.T, J)
    return np.transpose(A.T.reshape(N, 3, 3), (0, 2, 1)), J.T.reshape(N, 3, 3)


def run_dynamic(domain, names, kinds, observables):
    """Solve the generalized-α problem of ``domain`` (fixed steps) on the reference path with the tangent-linear
    sensitivities; ``(t (n,), {output: {name: (n, …)}})`` at the deck's outputs (as
    :func:`reference.sensitivity.static.run_static`; ``kinds`` as
    :class:`reference.sensitivity.derivatives.ParameterDerivatives`')."""
    base = twin(domain.algorithm())
    if getattr(base, "error_tolerance", None) is not None:
        raise ValueError("generalized-α sensitivities with error_tolerance (varying steps) are not built; "
                         "use fixed steps (drop error_tolerance)")
    algo = object.__new__(SensitiveAlpha)
    algo.__dict__.update(vars(base))
    model, state = domain.initialization(), domain.initial_conditions()
    run = algo.start(model, state)
    algo.derivatives = ParameterDerivatives(run.newton, kinds)
    labels = _Names(domain)
    n_total, every = algo.n_steps(domain.solver.t_end), int(domain.solver.output_every)
    times, outputs = [], {o.text: {n: [] for n in names} for o in observables}
    done, chunk = 0, 0  # the first call starts the run (the initial accelerations and their sensitivities)
    while True:
        code = algo.advance(model, state, run, chunk, None)
        if code != OK:
            raise ValueError(f"the run stopped at t = {state.t:.6g}: no sensitivity beyond")
        done += chunk
        times.append(state.t)
        for o in observables:
            for n, value in zip(names, output_derivatives(o, labels, state.x, state.q, algo.tangent.c, run.L)):
                outputs[o.text][n].append(value)
        if done >= n_total:
            return np.asarray(times), outputs
        chunk = min(every, n_total - done)
