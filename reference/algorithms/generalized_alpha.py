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
with the iteration matrix ``M + (γ'/β') C + K/β'`` (the tangent operator of the
exponential taken as identity, as in Brüls et al. 2012, §4: the converged step
is unchanged and the convergence stays fast because ``|h ω| ≪ 1``).  The
initial accelerations and multipliers are consistent: ``M V̇_0 + Bᵀλ_0 = −r_0``,
``B V̇_0 = −d/dt(B V + Φ_t)`` (the last by a central difference along the motion).

Energies: external work by the trapezoidal rule on the step increments (loads
and drives), damping dissipation by the trapezoidal rule on ``c Vᵀ M V``.
"""

from __future__ import annotations

import numpy as np

from reference.algorithms.implicit import (
    DIVERGED, NO_CONVERGENCE, OK, SINGULAR, ImplicitAlgorithm, compose,
)
from reference.linalg import SingularMatrix


def parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """``(α_m, α_f, γ, β)`` of Chung & Hulbert (1993) for the spectral radius ρ∞."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 + af - am
    return am, af, gamma, 0.25 * (gamma + 0.5) ** 2


class GeneralizedAlpha(ImplicitAlgorithm):
    """Lie-group generalized-α (Brüls, Cardona & Arnold 2012) with Newton on the sparse tangent.

    Parameters
    ----------
    dt : float
        Time step h [s] (no stability limit).
    rho_inf : float, default 0.8
        Spectral radius at infinite frequency, 0 ≤ ρ∞ ≤ 1 (1: no numerical dissipation).
    tolerance : float, default 1e-8
        Newton stops when the largest correction is below ``tolerance`` × model size
        (translations) and ``tolerance`` rad (rotations).
    max_iterations : int, default 15
    """

    name = "generalized_alpha"

    def __init__(self, dt: float, rho_inf: float = 0.8, tolerance: float = 1e-8, max_iterations: int = 15):
        super().__init__(dt, tolerance, max_iterations)
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
        self.rho_inf = float(rho_inf)
        self.alpha_m, self.alpha_f, self.gamma, self.beta = parameters(self.rho_inf)
        self._run = None
        self.iterations = 0

    @classmethod
    def from_settings(cls, settings, dt=None):
        return cls(dt or settings.dt, settings.rho_inf, settings.tolerance or 1e-8, settings.max_iterations or 15)

    def _start(self, model, state):
        """Consistent initial accelerations and multipliers at the state's time."""
        x, q, v, w, f_prev, clock = state[:6]
        N, m = x.shape[0], model.n_constraints
        t = clock[0]
        self.L = self.length_scale(x)
        self.hx = 6e-6 * self.L
        vd = np.zeros((N, 6))
        lam = np.zeros(m)
        self.work.angle[:] = state.angle  # the force elements' continuous angles
        U = self.evaluate(model, x, q, v, w, vd, lam, t, True)
        r0 = self.work.r.copy()
        rate = np.zeros(m)
        if m:
            tau = 1e-3 * self.dt
            g = []
            for sgn in (1.0, -1.0):
                xs = x + sgn * tau * v
                qs = np.empty_like(q)
                compose(q, sgn * tau * w, qs, np.empty(4))
                self.evaluate(model, xs, qs, v, w, vd, lam, t + sgn * tau, True)
                g.append(self.work.PHIt + self.constraint_rate(model, v, w))
            rate = (g[0] - g[1]) / (2.0 * tau)
            U = self.evaluate(model, x, q, v, w, vd, lam, t, True)
        try:
            lu = self.factor(model, x, q, w, t, lam, 1.0, 0.0, 0.0, self.hx, ce=0.0)
            vd, lam = self.solve(lu, -r0, -rate)
        except SingularMatrix:
            return SINGULAR
        self.vd, self.a, self.lam = vd, vd.copy(), lam
        self.U = U
        self.evaluate(model, x, q, v, w, vd, lam, t, True)
        f_prev[:] = self.work.F
        self.P = self._power(model, v, w, lam)
        self.D = self._dissipation(model, v, w)
        self._run = (state, clock[1])
        return OK

    def _power(self, model, v, w, lam) -> float:
        """Power of the constraint forces on the system, ``−λᵀ B V`` (last evaluation)."""
        return -float(lam @ self.constraint_rate(model, v, w)) if lam.size else 0.0

    def _dissipation(self, model, v, w) -> float:
        """Power dissipated by the mass-proportional damping and the force elements' dampers
        (those at the last evaluation, the same state)."""
        c = model.damping
        fe = self.work.fe_power if model.fe_kind.shape[0] else 0.0
        if c == 0.0:
            return fe
        return fe + c * (float(np.sum(model.mass[:, None] * v * v))
                         + float(np.einsum("na,nab,nb->", w, model.inertia, w)))

    def advance(self, model, state, n_steps, record, scratch) -> int:
        self.prepare(model)
        x, q, v, w, f_prev, clock = state[:6]
        if self._run is None or self._run[0] is not state or self._run[1] != clock[1]:
            self.stopped_at = None
            code = self._start(model, state)
            if code != OK:
                self.stopped_at = clock[0]
                return code
        if record is not None:
            U = self.evaluate(model, x, q, v, w, self.vd, self.lam, clock[0], True)
            self.write_record(record, model, x, q, v, w, U, clock, self.lam)
        h = self.dt
        am, af, gamma, beta = self.alpha_m, self.alpha_f, self.gamma, self.beta
        bp = (1.0 - am) / (h * h * beta * (1.0 - af))
        gp = gamma / (h * beta)
        ck, cc = 1.0 / bp, gp / bp
        x1, q1 = np.empty_like(x), np.empty_like(q)
        tmp = np.empty(4)
        for _ in range(n_steps):
            t1 = clock[0] + h
            V = np.concatenate([v, w], axis=1)
            vd, a = self.vd, self.a
            a_new = (vd - am * a) / (1.0 - am)
            vd_new = vd.copy()
            dq = V + h * (0.5 - beta) * a + h * beta * a_new
            V_new = V + h * (1.0 - gamma) * a + h * gamma * a_new
            lam = self.lam.copy()
            done = False
            for it in range(self.max_iterations):
                x1[:] = x + h * dq[:, :3]
                compose(q, np.ascontiguousarray(h * dq[:, 3:]), q1, tmp)
                v1, w1 = np.ascontiguousarray(V_new[:, :3]), np.ascontiguousarray(V_new[:, 3:])
                self.evaluate(model, x1, q1, v1, w1, vd_new, lam, t1, True)
                if not np.all(np.isfinite(self.work.r)):
                    self.stopped_at = clock[0]
                    return DIVERGED
                try:
                    lu = self.factor(model, x1, q1, w1, t1, lam, 1.0, cc, ck, self.hx)
                    delta, mu = self.newton_correction(lu, model, ck, lam)
                except SingularMatrix:
                    self.stopped_at = clock[0]
                    return SINGULAR
                dq += delta / h
                V_new += gp * delta
                vd_new += bp * delta
                lam += bp * mu
                self.iterations += 1
                if self.converged(delta, self.L):
                    done = True
                    break
            if not done:
                self.stopped_at = clock[0]
                return NO_CONVERGENCE
            x1[:] = x + h * dq[:, :3]
            compose(q, np.ascontiguousarray(h * dq[:, 3:]), q1, tmp)
            v1, w1 = np.ascontiguousarray(V_new[:, :3]), np.ascontiguousarray(V_new[:, 3:])
            # energy bookkeeping with the last evaluation (within the Newton tolerance of the step's end)
            F1 = self.work.F
            P1 = self._power(model, v1, w1, lam)
            D1 = self._dissipation(model, v1, w1)
            clock[2] += 0.5 * float(np.sum((f_prev + F1) * h * dq)) + 0.5 * h * (self.P + P1)
            clock[3] += 0.5 * h * (self.D + D1)
            f_prev[:] = F1
            self.P, self.D = P1, D1
            self.a = a_new + (1.0 - af) / (1.0 - am) * (vd_new - vd)
            self.vd, self.lam = vd_new, lam
            x[:], q[:], v[:], w[:] = x1, q1, v1, w1
            state.angle[:] = self.work.angle
            clock[1] += 1
            clock[0] = clock[1] * h
            self._run = (state, clock[1])
        return OK
