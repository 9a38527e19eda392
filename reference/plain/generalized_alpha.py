"""Lie-group generalized-α on the reference path: one Newton step on one screen (:func:`alpha_step`).

The scheme, its parameters and its convergence test are those of
:mod:`reference.algorithms.generalized_alpha` (Brüls, Cardona & Arnold 2012; stated there once), the
step that of :mod:`reference.algorithms.alpha_steps` written as a textbook loop over
:class:`reference.plain.newton.Newton`: predictor, modified Newton on the configuration correction δ
(``h Δq += δ``, ``V += γ' δ``, ``V̇ += β' δ``, ``λ += β' μ``) with the iteration matrix
``[M + (γ'/β') C + K T(hΔθ)/β', Bᵀ; B T(hΔθ), −β' ε]`` kept while every correction is below a tenth of the
previous one (refactored at the iterate otherwise), and the acceptance with the energy bookkeeping.

The steps are chosen as the compiled algorithm chooses them (:mod:`reference.plain.alpha_control`): fixed
steps of ``dt``, a step whose Newton iteration fails halved and grown back, and with ``error_tolerance`` every
step chosen from the local error estimate (:mod:`reference.algorithms.step_control`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from reference.algorithms.alpha_steps import ROUNDOFF
from reference.algorithms.generalized_alpha import GeneralizedAlpha
from reference.algorithms.step_control import SolverStatistics
from reference.plain.alpha_control import StepControl, to_output
from reference.plain.corrector import correction_size
from reference.plain.newton import Newton, compose
from reference.status import DIVERGED, NO_CONVERGENCE, OK, SINGULAR


@dataclass
class AlphaState:
    """What a generalized-α step carries besides the :class:`~reference.state.State`: the accelerations
    ``vd`` (N,6) V̇, the algorithmic accelerations ``a`` (N,6), the multipliers ``lam`` (m,), the constraint and
    dissipated powers ``powers`` of the last step, the kept factor ``lu`` and the step ``h_lu`` it was made for."""

    vd: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    powers: np.ndarray
    lu: object = None
    h_lu: float = 0.0

    def arrays(self) -> tuple:
        """The arrays a rejected step restores: ``vd``, ``a``, ``lam``, ``powers``."""
        return self.vd, self.a, self.lam, self.powers


class AlphaParameters(NamedTuple):
    """The settings a step reads: α_m, α_f, γ, β, the Newton tolerance, the corrections allowed, the
    modified-Newton contraction and the model size L [m]."""

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float
    tolerance: float
    max_iterations: int
    contraction: float
    L: float
    reuse: float


@dataclass
class PlainAlphaRun:
    """The run state of :class:`PlainGeneralizedAlpha` (the fields of
    :class:`reference.algorithms.generalized_alpha.GeneralizedAlphaRun` that its records and messages read):
    the Newton system, the model size L [m], the first step h [s], the time and step ``start`` the fixed steps
    count from, the accelerations and factor (:class:`AlphaState`) and the step size's state
    (:class:`reference.plain.alpha_control.StepControl`)."""

    newton: Newton
    L: float
    h: float
    start: tuple = (0.0, 0)
    alpha: AlphaState | None = None
    control: StepControl | None = None
    stats: SolverStatistics = field(default_factory=SolverStatistics)
    row: dict = field(default_factory=dict)
    stopped_at: float | None = None
    tried: str = ""
    history: list = field(default_factory=list)


def alpha_step(nw: Newton, st, al: AlphaState, h: float, p: AlphaParameters) -> tuple[int, int, int]:
    """One generalized-α step of h [s] from the state ``st`` (x, q, v, w, f_prev, clock, …) in place.  Returns
    ``(status, corrections, factorisations)``; a failed step leaves the state as it was.

    Newton on the configuration correction δ of ``h Δq``, with ``V += γ' δ``, ``V̇ += β' δ``, ``λ += β' μ``,
    on the iteration matrix ``[M + (γ'/β') C + K T(hΔθ)/β', Bᵀ; B T(hΔθ), −β' ε]``, kept while the
    corrections contract by :attr:`AlphaParameters.contraction` (module docstring)."""
    x, q, clock = st.x, st.q, st.clock[0]
    bp, gp = (1.0 - p.alpha_m) / (h * h * p.beta * (1.0 - p.alpha_f)), p.gamma / (h * p.beta)
    t1, floor = clock["t"] + h, ROUNDOFF * max(1.0, float(np.max(np.abs(x))) / p.L)
    an, dq, Vn, vdn, lamn = _predict(al, np.hstack([st.v, st.w]), h, p)
    if al.lu is not None and abs(h - al.h_lu) > p.reuse * al.h_lu:
        al.lu = None  # the matrix's coefficients depend on h
    previous, its, facts = -1.0, 0, 0
    while its < p.max_iterations:
        x1, q1 = x + h * dq[:, :3], compose(q, h * dq[:, 3:])  # the iterate: q_{n+1} = q_n ⊗ exp(h Δθ)
        res = nw.evaluate(x1, q1, Vn[:, :3], Vn[:, 3:], vdn, lamn, t1, True)
        if not np.all(np.isfinite(res.r)):
            return DIVERGED, its, facts
        if al.lu is None or previous == REFACTOR:  # no factor for h, or a slow contraction: factor here
            al.lu = nw.factor(nw.matrix(x1, q1, Vn[:, :3], Vn[:, 3:], t1, lamn, (1.0, gp / bp, 1.0 / bp, bp),
                                        h * dq[:, 3:]))
            al.h_lu, facts, previous = h, facts + 1, -1.0
            if al.lu is None:
                return SINGULAR, its, facts
        solved = nw.solve(al.lu, -res.r / bp, -(res.phi - nw.eps * lamn))
        if solved is None:
            return SINGULAR, its, facts
        delta, mu = solved
        size, imbalance = correction_size(delta, p.L), _imbalance(nw, res, vdn, lamn, p.L)
        theta = size / previous if previous > 0.0 else 1.0
        # converged: the imbalance left after this correction, θ/(1 − θ) of the one it corrected (Hairer &
        # Wanner 1996, §IV.8), below the tolerance, or a correction at the coordinates' round-off
        done = (imbalance <= p.tolerance or (theta < 1.0 and theta * imbalance <= p.tolerance * (1.0 - theta))
                or size <= floor)
        if previous >= 0.0 and size > p.contraction * previous and not done:
            previous = REFACTOR
            continue
        previous, its = size, its + 1
        dq += delta / h
        Vn += gp * delta
        vdn += bp * delta
        lamn += bp * mu
        if done:
            _accept(nw, st, al, h, (x, q, dq, Vn, vdn, an, lamn, res), p)
            return OK, its, facts
    return NO_CONVERGENCE, its, facts


REFACTOR = -2.0
""":func:`alpha_step`'s mark (in place of the previous correction's size) for a factor to make at the iterate."""


def _predict(al: AlphaState, V, h: float, p: AlphaParameters) -> tuple:
    """The step's predictor from the converged state (V (N,6) its velocities): ``(a_{n+1}, Δq, V_{n+1}, V̇_{n+1},
    λ_{n+1})`` at ``V̇_{n+1} = V̇_n``, ``λ_{n+1} = λ_n``."""
    an = (al.vd - p.alpha_m * al.a) / (1.0 - p.alpha_m)
    dq = V + h * (0.5 - p.beta) * al.a + h * p.beta * an
    Vn = V + h * (1.0 - p.gamma) * al.a + h * p.gamma * an
    return an, dq, Vn, al.vd.copy(), al.lam.copy()


def _imbalance(nw: Newton, res, vdn, lamn, L: float) -> float:
    """The evaluation's imbalance: the largest free residual force over the step's force scale — the largest
    free inertial force ``M V̇``, internal force S, external force F or ``r − S + F`` (the joints' and the
    inertia's forces together) — moments over the model size L, or ``max |Φ − ελ| / L`` if larger."""
    m, J = nw.ev.masses
    inertia = np.hstack([m[:, None] * vdn[:, :3], np.einsum("nab,nb->na", J, vdn[:, 3:])])
    big = np.max([np.abs(inertia), np.abs(res.S), np.abs(res.F), np.abs(res.r - res.S + res.F)], axis=0)
    unit = np.where(np.arange(6) < 3, 1.0, 1.0 / L)
    res_max = float(np.max((np.abs(res.r) * unit)[nw.free], initial=0.0))
    scale = float(np.max((big * unit)[nw.free], initial=0.0))
    phi = float(np.max(np.abs(res.phi - nw.eps * lamn), initial=0.0))
    return max(res_max / scale if res_max > 0.0 else 0.0, phi / L)


def _accept(nw: Newton, st, al: AlphaState, h: float, it, p) -> None:
    """The converged step into the state: the external work (trapezoidal on the increments, loads and
    constraint power) and the dissipation from the last evaluation, then ``x, q, V, V̇, a, λ``."""
    x, q, dq, Vn, vdn, an, lamn, res = it
    clock, f_prev = st.clock[0], st.f_prev
    P1, D1 = powers(nw, res, lamn, Vn)
    clock["work"] += float(np.sum(0.5 * (f_prev + res.F) * h * dq)) + 0.5 * h * (al.powers[0] + P1)
    clock["dissipated"] += 0.5 * h * (al.powers[1] + D1)
    al.powers[:] = P1, D1
    f_prev[:] = res.F
    al.a[:] = an + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * (vdn - al.vd)
    al.vd[:], al.lam[:] = vdn, lamn
    x1, q1 = x + h * dq[:, :3], compose(q, h * dq[:, 3:])
    x[:], q[:], st.v[:], st.w[:] = x1, q1, Vn[:, :3], Vn[:, 3:]


def powers(nw: Newton, res, lam, V) -> tuple[float, float]:
    """``(P, D)``: the constraint forces' power ``−λᵀ B V`` and the dissipated power ``c Vᵀ M V`` plus the
    force elements' dampers' (of the evaluation ``res``) [W], V (N,6)."""
    m, J = nw.ev.masses
    P = -float(lam @ (res.B @ V.ravel()))
    D = nw.ev.damping * (float(np.sum(m[:, None] * V[:, :3] ** 2))
                         + float(np.einsum("na,nab,nb->", V[:, 3:], J, V[:, 3:]))) + res.D
    return P, D


class PlainGeneralizedAlpha(GeneralizedAlpha):
    """:class:`reference.algorithms.generalized_alpha.GeneralizedAlpha` on the reference path: the same
    settings, deck keys, records and messages; the steps of :func:`alpha_step`, chosen as the compiled
    algorithm chooses them (:mod:`reference.plain.alpha_control`)."""

    def start(self, model, state, critical_step=None, guard=None) -> PlainAlphaRun:
        """A run from ``state``; the initial accelerations are computed by the first :meth:`advance`."""
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        h = self.dt if self.error_tolerance is None else min(max(self.first_step, self.dt_min), self.dt_max)
        run = PlainAlphaRun(Newton(model), self.length_scale(state.x), h, (state.t, state.n))
        run.control = StepControl(h, self.dt, varying=self.error_tolerance is not None or h != self.dt)
        run.stats.controlled = self.error_tolerance is not None
        return run

    def parameters(self, run) -> AlphaParameters:
        """What :func:`alpha_step` reads of this algorithm and run."""
        return AlphaParameters(self.alpha_m, self.alpha_f, self.gamma, self.beta, self.tolerance, self.max_iterations,
                               self.contraction, run.L, self.reuse)

    def step(self, state, run, h: float, count: bool = True) -> int:
        """One step of h (:func:`alpha_step`) with its statistics (the step counted when ``count``); a failed step
        leaves the state, the angles included, as it was."""
        nw, stats = run.newton, run.stats
        held = nw.angle.copy()
        code, its, facts = alpha_step(nw, state, run.alpha, h, self.parameters(run))
        stats.iterations += its
        stats.factorizations += facts
        if code != OK:
            nw.angle[:] = held
            run.alpha.lu = None
        elif count:
            stats.step(h)
        return code

    def _initial(self, run, state) -> int:
        """Consistent initial accelerations and multipliers (``τ = 10⁻³ h``, ``c_e = β'``), the first
        evaluation's loads and powers."""
        nw, h = run.newton, run.h
        x, q, v, w, f_prev = state[:5]
        clock = state.clock[0]
        nw.angle[:] = state.angle
        bp = (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
        solved = nw.consistent_accelerations(x, q, v, w, clock["t"], 1e-3 * h, ce=bp)
        if solved is None:
            run.tried = "at the initial accelerations"
            return SINGULAR
        vd, lam = solved
        res = nw.evaluate(x, q, v, w, vd, lam, clock["t"], True)
        f_prev[:] = res.F
        run.alpha = AlphaState(vd, vd.copy(), lam, np.array(powers(nw, res, lam, np.hstack([v, w]))))
        run.control.nominal = int(round(clock["t"] / self.dt))
        return OK

    def advance(self, model, state, run, n_steps, record) -> int:
        nw, clock = run.newton, state.clock[0]
        if run.alpha is None:
            run.stopped_at = None
            code = self._initial(run, state)
            if code != OK:
                run.stopped_at = clock["t"]
                return code
        if record is not None:
            al = run.alpha
            res = nw.evaluate(state.x, state.q, state.v, state.w, al.vd, al.lam, clock["t"], True)
            nw.write_record(record, state.x, state.q, state.v, state.w, state.clock, al.lam, res)
            run.row = run.stats.output(run.control.h, nw.free_norm(res.r))
        code = to_output(self, state, run, int(n_steps))
        state.angle[:] = nw.angle
        if code != OK:
            run.alpha.lu = None
            run.stopped_at = clock["t"]
        return code

    def summary(self, run) -> str:
        return run.stats.summary()
