"""Lie-group generalized-α time integration (``algorithm = "generalized_alpha"``).

The scheme of Brüls, Cardona & Arnold (2012), "Lie group generalized-α time
integration of constrained flexible multibody systems", Mech. Mach. Theory 48,
121–137 (Arnold & Brüls 2007 for the Lie-group form; Chung & Hulbert 1993 for
the parameters), on the nodes' group SO(3)×R³ with velocities
``V = (v inertial, ω body)`` (left-trivialised), constraints at position level
(index 3) with the scaling of Bottasso, Bauchau & Cardona (2007)::

    x_{n+1} = x_n + h Δx,    q_{n+1} = q_n ⊗ exp(h Δθ),
    Δq      = V_n + h(½ − β) a_n + h β a_{n+1}
    V_{n+1} = V_n + h(1 − γ) a_n + h γ a_{n+1}
    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) V̇_{n+1} + α_f V̇_n
    r(q_{n+1}, V_{n+1}, V̇_{n+1}, λ_{n+1}, t_{n+1}) = 0,   Φ(q_{n+1}, t_{n+1}) − ε λ_{n+1} = 0

(residual r of :mod:`reference.algorithms.implicit`), with, from the spectral
radius at infinite frequency ρ∞ ∈ [0, 1],
``α_m = (2ρ∞ − 1)/(ρ∞ + 1)``, ``α_f = ρ∞/(ρ∞ + 1)``, ``γ = ½ + α_f − α_m``,
``β = ¼(γ + ½)²``: second order, unconditionally stable for linear problems,
ρ∞ = 1 without numerical dissipation (trapezoidal rule), ρ∞ = 0 annihilating
the highest frequencies in one step.

Newton iterates on the configuration correction δ (``h Δq += δ``,
``V += γ' δ``, ``V̇ += β' δ``, ``γ' = γ/(hβ)``, ``β' = (1 − α_m)/(h²β(1 − α_f))``)
with the iteration matrix ``M + (γ'/β') C + K T/β'``, T the tangent operator
``J_r(h Δθ)`` of the exponential at each node (Brüls et al. 2012, §4).  The
factor is kept over iterations and steps while every correction is below a
tenth of the previous one (modified Newton); otherwise the matrix is refactored
at the current iterate and the step goes on from there (full Newton if need
be).  Newton stops when the correction, or the error it leaves for an observed
contraction θ, ``θ/(1 − θ)·|δ|`` (Hairer & Wanner 1996, §IV.8), is below the
tolerance (translations over the model size, rotations in rad).  The
initial accelerations and multipliers are consistent: ``M V̇_0 + Bᵀλ_0 = −r_0``,
``B V̇_0 = −d/dt(B V + Φ_t)`` (the last by a central difference along the motion).

Energies: external work by the trapezoidal rule on the step increments (loads,
actuators and drives), damping dissipation by the trapezoidal rule on
``c Vᵀ M V`` plus the force elements' damper power ``Σ c (B_e V)²``.
"""

from __future__ import annotations

import math

import numpy as np

from dataclasses import dataclass, field

from reference.algorithms.implicit import ImplicitAlgorithm, NewtonSystem, compose, evaluate, write_record
from reference.jit import inlined, kernel, named
from reference.linalg import SingularMatrix, lu_solve
from reference.state import Model, Record
from reference.status import DIVERGED, NO_CONVERGENCE, OK, REFACTOR, SINGULAR


def parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """``(α_m, α_f, γ, β)`` of Chung & Hulbert (1993) for the spectral radius ρ∞."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 + af - am
    return am, af, gamma, 0.25 * (gamma + 0.5) ** 2


@dataclass
class GeneralizedAlphaRun:
    """Generalized-α's run state (:meth:`GeneralizedAlpha.start`), advanced only by
    :meth:`GeneralizedAlpha.advance`: everything carried from one step to the next besides the
    :class:`~reference.state.State`.

    ``system`` the model's Newton system; ``L`` the model size [m] of the convergence test;
    ``vd``, ``a`` (N, 6) the accelerations V̇ and the algorithmic accelerations; ``lam`` (m,)
    the multipliers; ``powers`` = [constraint power P, dissipated power D] of the last step;
    ``factors`` the kept LU factor (None: none yet); ``par`` the compiled steps' settings and
    counters (:func:`steps`); ``arrays`` their work arrays; ``started`` whether the consistent
    initial accelerations are computed; ``iterations``, ``factorizations`` counts;
    ``stopped_at`` the time where a failed step stopped.
    """

    system: NewtonSystem
    L: float
    vd: np.ndarray | None = None
    a: np.ndarray | None = None
    lam: np.ndarray | None = None
    powers: np.ndarray = field(default_factory=lambda: np.zeros(2))
    factors: tuple | None = None
    par: np.ndarray | None = None
    arrays: tuple = ()
    started: bool = False
    iterations: int = 0
    factorizations: int = 0
    stopped_at: float | None = None
    history: list = field(default_factory=list)


NO_FACTOR = (np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(1, np.int64),
             np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64))
"""Empty factor arrays, passed to the compiled steps before the first factorisation."""


class GeneralizedAlpha(ImplicitAlgorithm):
    """Lie-group generalized-α (Brüls, Cardona & Arnold 2012) with Newton on the sparse tangent.

    Parameters
    ----------
    dt : float
        Time step h [s] (no stability limit).
    rho_inf : float, default 0.8
        Spectral radius at infinite frequency, 0 ≤ ρ∞ ≤ 1 (1: no numerical dissipation).
    tolerance : float, default 1e-10
        Newton stops when the largest correction (or the error it leaves, see above) is
        below ``tolerance`` × model size (translations) and ``tolerance`` rad (rotations).
    max_iterations : int, default 15
        Newton corrections per step before the run stops.
    """

    name = "generalized_alpha"
    deck_required = ("dt", "t_end")
    deck_optional = ("rho_inf", "tolerance", "max_iterations", "damping", "output_every",
                     "consistent_initial_velocities", "max_steps")
    contraction = 0.1
    """Modified Newton: the factor is kept over iterations and steps while each correction is
    below this fraction of the previous one; otherwise the matrix is refactored at the iterate."""

    def __init__(self, dt: float, rho_inf: float = 0.8, tolerance: float = 1e-10, max_iterations: int = 15):
        super().__init__(dt, tolerance, max_iterations)
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
        self.rho_inf = float(rho_inf)
        self.alpha_m, self.alpha_f, self.gamma, self.beta = parameters(self.rho_inf)

    @classmethod
    def from_settings(cls, settings, dt=None):
        return cls(dt or settings.dt, settings.rho_inf, settings.tolerance or 1e-10, settings.max_iterations or 15)

    def start(self, model, state, critical_step=None, guard=None) -> GeneralizedAlphaRun:
        """A run from ``state``: the Newton system; the initial accelerations are computed by the first
        :meth:`advance`."""
        return GeneralizedAlphaRun(self.newton_system(model), self.length_scale(state.x))

    def _initial_accelerations(self, run, state) -> int:
        """Consistent initial accelerations and multipliers at the state's time."""
        system = run.system
        model = system.model
        x, q, v, w, f_prev, clock = state[:6]
        N, m = x.shape[0], model.n_constraints
        t = clock[0]
        system.work.angle[:] = state.angle  # the force elements' continuous angles
        try:
            vd, lam = system.consistent_accelerations(x, q, v, w, t, 1e-3 * self.dt)
        except SingularMatrix:
            return SINGULAR
        run.vd, run.a, run.lam = vd, vd.copy(), lam
        system.evaluate(x, q, v, w, vd, lam, t, True)
        f_prev[:] = system.work.F
        run.powers = np.array([_power(model, system.work.Bl, lam, v, w),
                               _dissipation(model, v, w) + system.work.fe_out[0]])
        n = system.pattern.n
        run.arrays = tuple(np.zeros((N, 6)) for _ in range(7)) + (
            np.zeros(m), np.zeros(m), np.zeros(n), np.zeros(n), np.zeros(n),
            np.zeros((N, 3)), np.zeros((N, 4)), np.zeros(4), np.zeros((N, 3)))
        run.par = np.array([self.dt, self.alpha_m, self.alpha_f, self.gamma, self.beta, self.tolerance, run.L,
                            self.contraction, self.max_iterations, 0.0, 0.0, np.nan, 0.0, 0.0, 0.0])
        run.started = True
        return OK

    def advance(self, model, state, run, n_steps, record) -> int:
        system = run.system
        x, q, v, w, f_prev, clock = state[:6]
        if not run.started:
            run.stopped_at = None
            code = self._initial_accelerations(run, state)
            if code != OK:
                run.stopped_at = clock[0]
                return code
        par, energy = run.par, run.powers
        left = int(n_steps)
        rec = Record.empty(x.shape[0], model.n_constraints) if record is None else record
        if record is not None:
            if left > 0 and math.isfinite(par[11]):
                # the last Newton evaluation of the previous step is this state within the
                # tolerance: the compiled steps write the record from it before stepping
                par[14] = 1.0
            else:
                U = par[11] if np.isfinite(par[11]) else system.evaluate(x, q, v, w, run.vd, run.lam, clock[0], True)
                system.write_record(record, x, q, v, w, U, clock, run.lam)
        par[10] = 0.0
        while left > 0:
            if run.factors is None:
                par[9] = -1.0  # only predict: the factor is made at the predictor
            code, done = steps(system.arg, x, q, v, w, run.vd, run.a, run.lam, clock, f_prev, energy, system.dof, par,
                               left, NO_FACTOR if run.factors is None else run.factors, system.wt, run.arrays,
                               system.record_arg(rec))
            left -= done
            if code == OK:
                continue
            if code == REFACTOR:
                arr, h = run.arrays, self.dt
                bp = (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
                ck, cc = 1.0 / bp, (self.gamma / (h * self.beta)) / bp
                try:
                    run.factors = system.factor(arr[12], arr[13], np.ascontiguousarray(arr[1][:, 3:]), clock[0] + h,
                                                arr[7], 1.0, cc, ck, psi=np.ascontiguousarray(h * arr[0][:, 3:]))
                except SingularMatrix:
                    run.stopped_at = clock[0]
                    return SINGULAR
                run.factorizations += 1
                par[9] = 1.0  # the interrupted step resumes with a fresh factor
                continue
            run.factors = None
            par[12] = 0.0
            run.stopped_at = clock[0]
            state.angle[:] = system.work.angle
            return code
        state.angle[:] = system.work.angle
        run.iterations += int(par[10])
        return OK


@kernel
def _power(model, Bl, lam, v, w):
    """``−λᵀ B V`` (power of the constraint forces) from the local rows ``Bl``."""
    P = 0.0
    jt_i, jt_j, jt_row0, jt_neq = model.joints.i, model.joints.j, model.joints.row0, model.joints.neq
    for k in range(jt_i.shape[0]):
        i, j = jt_i[k], jt_j[k]
        for r in range(jt_row0[k], jt_row0[k] + jt_neq[k]):
            acc = 0.0
            for a in range(3):
                acc += Bl[r, a] * v[i, a] + Bl[r, 3 + a] * w[i, a]
                if j >= 0:
                    acc += Bl[r, 6 + a] * v[j, a] + Bl[r, 9 + a] * w[j, a]
            P -= lam[r] * acc
    return P


@kernel
def _dissipation(model, v, w):
    """Power of the mass-proportional damping ``c Vᵀ M V`` [W] (the force elements' dampers are added
    from the evaluation)."""
    c = model.damping
    D = 0.0
    J, mass = model.nodes.inertia, model.nodes.mass
    for i in range(v.shape[0]):
        for a in range(3):
            D += mass[i] * v[i, a] * v[i, a]
            for b in range(3):
                D += w[i, a] * J[i, a, b] * w[i, b]
    return c * D


_evaluate = inlined(evaluate)
_write_record = inlined(write_record)
_power_inlined = inlined(_power)
_dissipation_inlined = inlined(_dissipation)
"""The model-taking kernels that :func:`steps` calls every iteration, inlined: a compiled call
with the Model costs an atomic reference-count update per array of it, twice."""


@inlined
def _predict(v, w, vd, a, lam, an, vdn, dq, Vn, lamn, h, am, gamma, beta):
    """The step's predictor from the converged state: algorithmic accelerations ``a_{n+1}`` at
    ``V̇_{n+1} = V̇_n``, the increment ``Δq`` and velocities ``V_{n+1}`` of the scheme, ``λ_{n+1} = λ_n``."""
    for i in range(v.shape[0]):
        for k in range(6):
            Vk = v[i, k] if k < 3 else w[i, k - 3]
            an[i, k] = (vd[i, k] - am * a[i, k]) / (1.0 - am)
            vdn[i, k] = vd[i, k]
            dq[i, k] = Vk + h * (0.5 - beta) * a[i, k] + h * beta * an[i, k]
            Vn[i, k] = Vk + h * (1.0 - gamma) * a[i, k] + h * gamma * an[i, k]
    for k in range(lam.shape[0]):
        lamn[k] = lam[k]


@inlined
def _accept(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, arr, Bl, F, fe_out, h, am, af):
    """The converged step: the energy bookkeeping with its last evaluation (within the Newton
    tolerance of the step's end) and the new state ``x, q, V, V̇, a, λ`` from the iterate in ``arr``."""
    dq, Vn, vdn, an, _, _, _, lamn, _, _, _, _, x1, q1, tmp, psi = arr
    N = x.shape[0]
    for i in range(N):
        for k in range(3):
            x1[i, k] = x[i, k] + h * dq[i, k]
            psi[i, k] = h * dq[i, 3 + k]
    compose(q, psi, q1, tmp)
    P1 = _power_inlined(model, Bl, lamn, Vn[:, :3], Vn[:, 3:])
    D1 = _dissipation_inlined(model, Vn[:, :3], Vn[:, 3:]) + fe_out[0]
    dW = 0.0
    for i in range(N):
        for k in range(6):
            dW += 0.5 * (f_prev[i, k] + F[i, k]) * h * dq[i, k]
            f_prev[i, k] = F[i, k]
    clock[2] += dW + 0.5 * h * (energy[0] + P1)
    clock[3] += 0.5 * h * (energy[1] + D1)
    energy[0], energy[1] = P1, D1
    for i in range(N):
        for k in range(6):
            a[i, k] = an[i, k] + (1.0 - af) / (1.0 - am) * (vdn[i, k] - vd[i, k])
            vd[i, k] = vdn[i, k]
        for k in range(3):
            x[i, k] = x1[i, k]
            v[i, k] = Vn[i, k]
            w[i, k] = Vn[i, 3 + k]
        for k in range(4):
            q[i, k] = q1[i, k]
    for k in range(lam.shape[0]):
        lam[k] = lamn[k]


@inlined
def _correction(r, PHI, row_eps, lamn, dof, ck, factors, rhs, lwork, sol, delta, L):
    """One Newton correction with the kept factor: the right-hand side ``−[c_k r; Φ − ελ]`` of the last
    evaluation, the solution ``sol`` and the node part ``delta`` (N, 6); returns its size
    (translations over the model size L, rotations in rad), NaN if the residual is not finite."""
    m = lamn.shape[0]
    n_free = rhs.shape[0] - m
    for i in range(r.shape[0]):
        for k in range(6):
            if not math.isfinite(r[i, k]):
                return math.nan
            if dof[i, k] >= 0:
                rhs[dof[i, k]] = -ck * r[i, k]
    for k in range(m):
        rhs[n_free + k] = -(PHI[k] - row_eps[k] * lamn[k])
    lu_solve(factors, rhs, lwork, sol)
    size = 0.0
    for i in range(r.shape[0]):
        for k in range(6):
            d = sol[dof[i, k]] if dof[i, k] >= 0 else 0.0
            delta[i, k] = d
            size = max(size, abs(d) / L if k < 3 else abs(d))
    return size


@kernel
def steps(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, dof, par, n_steps, factors, wt, arr, rec):
    """Up to ``n_steps`` generalized-α steps with the kept factor (compiled modified Newton).

    Returns ``(status, steps done)``; ``REFACTOR`` (a correction shrank by less than
    ``contraction``, or there is no factor yet) leaves the iterate of the unfinished step in
    ``arr`` (x1, q1, V, λ, h Δq): the caller factors the Newton matrix there and calls again,
    and the step resumes from that iterate.  At most ``max_iterations`` corrections per step
    (``NO_CONVERGENCE`` otherwise).
    ``par`` = [h, α_m, α_f, γ, β, tolerance, L, contraction, max_iterations, fresh, iterations, U,
    resume, corrections of this step, record] (fresh: 1 the factor is new, −1 there is none yet;
    iterations counted here; U the strain energy of the last evaluation; resume: 1 to continue
    the interrupted step's iterate; record: 1 to first write the output record ``rec`` of the
    current state from the last evaluation, :func:`reference.algorithms.implicit.write_record`).
    """
    model = named(model, Model)
    rec = named(rec, Record)
    dq, Vn, vdn, an, delta, _, _, lamn, mu, rhs, sol, lwork, x1, q1, tmp, psi = arr
    S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi, prim_B, fe, elements = wt
    h, am, af, gamma, beta, tol, L, contraction = par[0], par[1], par[2], par[3], par[4], par[5], par[6], par[7]
    max_it = int(par[8])
    bp = (1.0 - am) / (h * h * beta * (1.0 - af))
    gp = gamma / (h * beta)
    ck = 1.0 / bp
    N = x.shape[0]
    m = lam.shape[0]
    n_free = rhs.shape[0] - m
    row_eps = model.joints.eps
    if par[14] == 1.0:
        par[14] = 0.0
        _write_record(model, x, q, v, w, par[11], clock, lam, PHI, PHIt, Bl, rec)
    for step in range(n_steps):
        t1 = clock[0] + h
        if not (step == 0 and par[12] == 1.0):
            # predictor (unless resuming the iterate of an interrupted step with a new factor)
            par[13] = 0.0
            _predict(v, w, vd, a, lam, an, vdn, dq, Vn, lamn, h, am, gamma, beta)
        par[12] = 1.0  # an interruption from here on keeps the iterate
        previous = -1.0
        converged = False
        while par[13] < max_it:
            for i in range(N):
                for k in range(3):
                    x1[i, k] = x[i, k] + h * dq[i, k]
                    psi[i, k] = h * dq[i, 3 + k]
            compose(q, psi, q1, tmp)
            par[11] = _evaluate(model, x1, q1, Vn[:, :3], Vn[:, 3:], vdn, lamn, t1, True, wt)
            if par[9] < 0.0:
                return REFACTOR, step
            size = _correction(r, PHI, row_eps, lamn, dof, ck, factors, rhs, lwork, sol, delta, L)
            if not math.isfinite(size):
                return DIVERGED, step
            if previous >= 0.0 and size > contraction * previous:
                return REFACTOR, step  # a new factor at this iterate (full Newton when it keeps happening)
            theta = size / previous if previous > 0.0 else 1.0
            previous = size
            par[13] += 1.0
            for i in range(N):
                for k in range(6):
                    dq[i, k] += delta[i, k] / h
                    Vn[i, k] += gp * delta[i, k]
                    vdn[i, k] += bp * delta[i, k]
            for k in range(m):
                lamn[k] += bp * sol[n_free + k]
            par[10] += 1.0
            # the error left after this correction: about θ/(1 − θ) of it for a contraction θ
            # (Hairer & Wanner 1996, §IV.8); the correction itself when θ is not known yet
            if size <= tol or (theta < 1.0 and theta * size <= tol * (1.0 - theta)):
                converged = True
                break
        if not converged:
            par[12] = 0.0
            return NO_CONVERGENCE, step
        par[9] = 0.0
        par[12] = 0.0
        _accept(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, arr, Bl, F, fe[8], h, am, af)
        clock[1] += 1
        clock[0] = clock[1] * h
    return OK, n_steps
