"""The implicit and linearised algorithms for a model with reduced bodies (reference path, issue 39).

All three work on the generalised coordinates of :class:`~reference.reduced.coupling.CoupledModel` (the other
nodes' ``[δx, δθ]``, each body's ``[δr, δθ, δη]``), updated as ``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (a node's
and a frame's rotation alike), ``r ← r + δr``, ``η ← η + δη``.  The residual is the coupled model's

    r = M V̇ + g(V) − Tᵀ (F − S) + (B T)ᵀ λ,        Φ − ε λ = 0,

(``g`` :meth:`~reference.reduced.coupling.CoupledModel.inertial`: gyroscopic, quadratic-velocity, modal
stiffness and damping), and the Newton matrix is a **quasi-Newton** one: the stripped model's tangent chain-ruled,
``Tᵀ K T``, plus each body's modal stiffness, ``β' M`` for the inertia and the rows ``B T``; the derivatives of
``T``, ``M(η)`` and ``Q_v`` and the joints' geometric stiffness are left out.  The iteration then converges
linearly instead of quadratically, to the same solution: the residual it drives to zero is the exact one.

- :class:`ReducedStatic`: load stepping, ``r = 0`` at each load level (velocities zero);
- :class:`ReducedGeneralizedAlpha`: the Lie-group generalized-α of Arnold & Brüls (Multibody Syst. Dyn. 18
  (2007) 185) at the fixed step ``dt`` (no error control), the configuration ``q_n ⊕ Δq`` with
  ``Δq = h V_n + h² (½ − β) a_n + h² β a_{n+1}``;
- :class:`ReducedModes`: modes about the reference state (``about = "reference"``), ``M`` and ``K`` at rest
  reduced to the null space of ``B T``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from reference.algorithms.linear import LinearRun
from reference.linalg import null_space
from reference.modal import modes
from reference.plain.generalized_alpha import PlainGeneralizedAlpha
from reference.plain.linear import PlainModes
from reference.plain.newton import compose
from reference.plain.static import PlainStatic
from reference.reduced.coupling import BodyState, CoupledModel
from reference.status import NO_CONVERGENCE, OK

QUASI_NEWTON_FACTOR = 4
"""The quasi-Newton iteration may take this many times the deck's ``max_iterations`` (linear convergence)."""


def update(cm: CoupledModel, state, bodies: list[BodyState], delta) -> None:
    """Apply the generalised increment ``delta`` (size,) in place (module docstring) and place the nodes."""
    k = 6 * cm.others.size
    own = np.where(cm.free[:k], delta[:k], 0.0).reshape(-1, 6)
    ids = cm.others
    state.x[ids] += own[:, :3]
    if ids.size:
        state.q[ids] = compose(state.q[ids], own[:, 3:])
    for b, start in zip(bodies, cm.offsets):
        d = delta[start:start + b.V.size]
        b.r += d[:3]
        b.p[:] = compose(b.p[None], d[None, 3:6])[0]
        b.eta += d[6:]
    cm.place(bodies, state, velocities=False)


def stiffness(cm: CoupledModel, state, bodies: list[BodyState], T) -> np.ndarray:
    """The quasi-Newton stiffness (size, size): ``Tᵀ K T`` of the stripped model's tangent plus each body's
    modal stiffness (module docstring)."""
    zero = np.zeros_like(state.v)
    K = (T.T @ cm.ev.tangent(state.x, state.q, zero, zero, state.t) @ T).toarray()
    for i, (b, start) in enumerate(zip(bodies, cm.offsets)):
        r = b.eta.size
        K[start + 6:start + 6 + r, start + 6:start + 6 + r] += cm.modal_stiffness(i, b)
    return K


def residual(cm: CoupledModel, state, bodies, lam, Vdot=None, V=None) -> tuple:
    """``(r, Φ − ελ, B T, T, U, scale, Q)`` at ``state``/``bodies`` (static without ``Vdot``: velocities zero);
    ``scale`` the largest of the force terms, for the convergence test; ``Q = Tᵀ F`` the applied forces'
    generalised share (for :func:`power`)."""
    zero = np.zeros_like(state.v)
    if V is not None:
        cm.scatter(V, state, bodies)
        cm.place(bodies, state)
    v, w = (state.v, state.w) if V is not None else (zero, zero)
    S, F, U, _ = cm.ev.forces(state.x, state.q, v, w, state.t, state.angle.copy())
    T = cm.velocity_map(bodies)
    r = T.T @ (S - F).ravel()
    Q = T.T @ F.ravel()
    scale = np.abs(r).max(initial=0.0)
    if V is None:
        for i, (b, start) in enumerate(zip(bodies, cm.offsets)):
            r[start + 6:start + 6 + b.eta.size] += cm.elastic(i, b)
    else:
        inertia = cm.mass(bodies) @ Vdot + cm.inertial(bodies, V)
        scale = max(scale, np.abs(inertia).max(initial=0.0))
        r += inertia
    phi, BT, _, eps = cm.constraints(state, bodies, T)
    if phi.size:
        r += BT.T @ lam
    return r, phi - eps * lam, BT, T, U, scale, Q


def solve_saddle(A, BT, free, r, g, eps) -> tuple[np.ndarray, np.ndarray]:
    """The correction ``(δ, δλ)`` of ``[A, Bᵀ; B, −ε] [δ; δλ] = −[r; g]`` on the free coordinates, the matrix
    equilibrated first (each coordinate by ``1/√A_ii``, each row of B then by its largest entry): a stiff axial
    mode next to a slender blade's rotary inertia spans 1e15 otherwise, beyond what a dense LU keeps."""
    ids = np.flatnonzero(free)
    B = BT[:, ids].toarray()
    n, m = ids.size, B.shape[0]
    diag = np.abs(np.diag(A)[ids])
    sp_ = np.where(diag > 0.0, 1.0 / np.sqrt(np.where(diag > 0.0, diag, 1.0)), 1.0)
    Bs = B * sp_
    sc = 1.0 / np.where(np.abs(Bs).max(axis=1, initial=0.0) > 0.0, np.abs(Bs).max(axis=1, initial=0.0), 1.0)
    K = np.zeros((n + m, n + m))
    K[:n, :n] = sp_[:, None] * A[np.ix_(ids, ids)] * sp_[None, :]
    K[:n, n:], K[n:, :n] = (sc[:, None] * Bs).T, sc[:, None] * Bs
    K[n:, n:] = -np.diag(sc * eps * sc)
    scale = np.concatenate([sp_, sc])
    sol = scale * np.linalg.solve(K, -scale * np.concatenate([r[ids], g]))
    delta = np.zeros(free.size)
    delta[ids] = sol[:n]
    return delta, sol[n:]


def _eps(cm: CoupledModel, rows: int) -> np.ndarray:
    """ε of every row: the joints' own, zero for the clamps' rows."""
    return np.concatenate([cm.ev.eps, np.zeros(rows - cm.ev.eps.size)])


def _length(cm: CoupledModel) -> float:
    """The model size L [m] (the convergence test's length scale)."""
    return float(max(np.ptp(cm.x0, axis=0).max(), 1.0))


def newton_static(cm: CoupledModel, state, bodies, lam, tolerance: float, iterations: int) -> tuple[int, int]:
    """Equilibrium at ``state.t`` (module docstring), in place; ``(status, iterations)``."""
    L = _length(cm)
    for it in range(iterations):
        r, g, BT, T, _, scale, _ = residual(cm, state, bodies, lam)
        if np.abs(r[cm.free]).max(initial=0.0) <= tolerance * max(scale, 1e-300) and \
                np.abs(g).max(initial=0.0) <= tolerance * L:
            return OK, it
        delta, dlam = solve_saddle(stiffness(cm, state, bodies, T), BT, cm.free, r, g, _eps(cm, g.size))
        update(cm, state, bodies, delta)
        lam += dlam
    return NO_CONVERGENCE, iterations


def power(Q, BT, lam, V) -> float:
    """The power [W] of the applied forces and of the joints' and drives' reactions at generalised velocities
    ``V``, from a :func:`residual` at the same configuration (its ``Q = Tᵀ F`` and rows ``B T``):
    ``Q·V − λ·(B T V)`` (the residual's sign convention: the reactions are ``−(B T)ᵀ λ``; a scleronomic joint's
    term vanishes on its manifold, a drive's is its work rate).  The generalized-α run integrates it by the
    trapezoidal rule into the clock's ``work``, as the explicit step does."""
    return float(Q @ V) - (float(lam @ (BT @ V)) if lam.size else 0.0)


def _record(cm: CoupledModel, record, state, bodies, lam, U: float, V=None) -> None:
    """The output record of the current configuration (velocities ``V``, zero in a static run)."""
    V = np.zeros(cm.size) if V is None else V
    cm.scatter(V, state, bodies)
    cm.place(bodies, state)
    record.x[:], record.q[:], record.v[:], record.w[:] = state.x, state.q, state.v, state.w
    T = cm.velocity_map(bodies)
    phi, BT, phi_t, _ = cm.constraints(state, bodies, T)
    kinetic = 0.5 * float(V @ (cm.mass(bodies) @ V))
    clock = state.clock[0]
    record.energy[:] = (kinetic, U + cm.strain(bodies), clock["work"], clock["dissipated"])
    record.constraint[:] = (np.linalg.norm(phi), np.linalg.norm(BT @ V + phi_t) if phi.size else 0.0)
    record.lam[:] = lam[:record.lam.size]


@dataclass
class ReducedImplicitRun:
    """An implicit run's state: the coupled model, the bodies, the multipliers (joints' rows, then the
    clamps'), the generalised velocities and accelerations (generalized-α's ``V``, ``V̇``, ``a``)."""

    coupled: CoupledModel
    bodies: list
    lam: np.ndarray
    V: np.ndarray | None = None
    Vdot: np.ndarray | None = None
    a: np.ndarray | None = None
    started: bool = False
    iterations: int = 0
    stopped_at: float | None = None
    energy: float = math.nan
    power: float = 0.0
    events: list = field(default_factory=list)


def _start(cm: CoupledModel, state) -> ReducedImplicitRun:
    bodies = cm.initial(state)
    cm.place(bodies, state)
    rows = cm.ev.n_constraints + len(cm.supports)
    return ReducedImplicitRun(cm, bodies, np.zeros(rows), cm.gather(state, bodies))


class _ReducedIterations:
    """What the static and generalized-α runs of a reduced model record besides the states: the reduced bodies'
    datasets (:meth:`~reference.reduced.coupling.CoupledModel.recorded`) and the quasi-Newton iterations."""

    def recorded(self, run) -> dict:
        return {**run.coupled.recorded(run.bodies), "newton_iterations": float(run.iterations)}

    def finish(self, model, state, run, completed: bool) -> dict:
        return {}


class ReducedStatic(_ReducedIterations, PlainStatic):
    """Static load stepping with reduced bodies (module docstring); the records of the configuration, energies,
    ``‖Φ‖`` and multipliers, and each body's ``reduced/<label>/…``."""

    coupled_model: CoupledModel | None = None
    """Set by :func:`reference.reduced.algorithms.reduced_twin`."""

    def start(self, model, state, critical_step=None, guard=None) -> ReducedImplicitRun:
        return _start(self.coupled_model, state)

    def _solve(self, state, run) -> int:
        code, its = newton_static(run.coupled, state, run.bodies, run.lam, self.tolerance,
                                  QUASI_NEWTON_FACTOR * self.max_iterations)
        run.iterations += its
        if code != OK:
            run.stopped_at = state.t
        return code

    def advance(self, model, state, run, n_steps, record) -> int:
        if not run.started:
            code = self._solve(state, run)
            if code != OK:
                return code
            run.started = True
        if record is not None:
            _record(run.coupled, record, state, run.bodies, run.lam, self._strain(state, run))
        for _ in range(int(n_steps)):
            state.clock[0]["n"] += 1
            state.clock[0]["t"] = state.clock[0]["n"] * self.dt
            code = self._solve(state, run)
            if code != OK:
                return code
        return OK

    @staticmethod
    def _strain(state, run) -> float:
        zero = np.zeros_like(state.v)
        return run.coupled.ev.forces(state.x, state.q, zero, zero, state.t, state.angle.copy())[2]

    def failure(self, code, state, run):
        return ("failed: no convergence", f"the quasi-Newton iteration of the reduced model did not converge at "
                f"load factor {state.t:.6g}; use more load_steps")


class ReducedGeneralizedAlpha(_ReducedIterations, PlainGeneralizedAlpha):
    """Generalized-α with reduced bodies at the fixed step ``dt`` (module docstring)."""

    coupled_model: CoupledModel | None = None
    """Set by :func:`reference.reduced.algorithms.reduced_twin`."""

    def start(self, model, state, critical_step=None, guard=None) -> ReducedImplicitRun:
        run = _start(self.coupled_model, state)
        cm = run.coupled
        r, g, BT, _, _, _, Q = residual(cm, state, run.bodies, run.lam, np.zeros(cm.size), run.V)
        Vdot, lam = solve_saddle(cm.mass(run.bodies).toarray(), BT, cm.free, r, np.zeros(g.size),
                                 np.zeros(g.size))
        run.Vdot, run.a, run.lam = Vdot, Vdot.copy(), lam
        run.power = power(Q, BT, lam, run.V)
        return run

    def advance(self, model, state, run, n_steps, record) -> int:
        if record is not None:
            zero = np.zeros_like(state.v)
            U = run.coupled.ev.forces(state.x, state.q, zero, zero, state.t, state.angle.copy())[2]
            _record(run.coupled, record, state, run.bodies, run.lam, U, run.V)
        for _ in range(int(n_steps)):
            code = self._step(state, run)
            if code != OK:
                run.stopped_at = state.t
                return code
        return OK

    def _step(self, state, run) -> int:
        """One step of the Lie-group generalized-α (module docstring)."""
        cm, h = run.coupled, self.dt
        am, af, gamma, beta = self.alpha_m, self.alpha_f, self.gamma, self.beta
        base = (state.x.copy(), state.q.copy(), [b.copy() for b in run.bodies])
        Vn, Vdn, an = run.V.copy(), run.Vdot.copy(), run.a.copy()
        a = (af * Vdn - am * an) / (1.0 - am)
        dq = h * Vn + h * h * (0.5 - beta) * an + h * h * beta * a
        V, Vdot = Vn + h * (1.0 - gamma) * an + h * gamma * a, np.zeros_like(Vdn)
        bp, gp = (1.0 - am) / (h * h * beta * (1.0 - af)), gamma / (h * beta)
        state.clock[0]["t"] = state.t + h
        L, lam = _length(cm), run.lam.copy()
        for it in range(QUASI_NEWTON_FACTOR * self.max_iterations):
            _configure(cm, state, run.bodies, base, dq)
            r, g, BT, T, _, scale, Q = residual(cm, state, run.bodies, lam, Vdot, V)
            if it > 0 and np.abs(r[cm.free]).max(initial=0.0) <= self.tolerance * max(scale, 1e-300) and \
                    np.abs(g).max(initial=0.0) <= self.tolerance * L:
                break
            A = bp * cm.mass(run.bodies).toarray() + stiffness(cm, state, run.bodies, T)
            delta, dlam = solve_saddle(A, BT, cm.free, r, g, _eps(cm, g.size))
            dq, V, Vdot, lam = dq + delta, V + gp * delta, Vdot + bp * delta, lam + dlam
        else:
            return NO_CONVERGENCE
        run.V, run.Vdot, run.lam = V, Vdot, lam
        run.a = ((1.0 - af) * Vdot + af * Vdn - am * an) / (1.0 - am)
        run.iterations += it
        state.clock[0]["n"] += 1  # the last residual left the state at the converged configuration and V
        rate = power(Q, BT, lam, V)
        state.clock[0]["work"] += 0.5 * h * (run.power + rate)
        run.power = rate
        return OK

    def failure(self, code, state, run):
        return ("failed: no convergence", f"the quasi-Newton iteration of the reduced model did not converge at "
                f"t = {state.t:.6g}; use a smaller dt")

    def summary(self, run) -> str:
        return f"{run.iterations} quasi-Newton iterations"


def _configure(cm: CoupledModel, state, bodies, base, dq) -> None:
    """The configuration ``base ⊕ dq`` (the step's start, moved by the step's increment ``dq``), in place."""
    x, q, start = base
    state.x[:], state.q[:] = x, q
    for b, b0 in zip(bodies, start):
        b.r[:], b.p[:], b.eta[:] = b0.r, b0.p, b0.eta
    update(cm, state, bodies, dq)


@dataclass
class ReducedLinearRun(LinearRun):
    """:class:`~reference.algorithms.linear.LinearRun` with the coupled model and its bodies at rest."""

    coupled: CoupledModel | None = None
    bodies: list | None = None


class ReducedModes(PlainModes):
    """Modes about the reference state of a model with reduced bodies (module docstring): ``M`` and the
    quasi-Newton stiffness at rest (exact there: ``T`` is constant to first order about a state at rest with
    no load), reduced to the null space of ``B T``; the datasets of :class:`reference.algorithms.linear.Modes`
    (the mobility is the number of zero modes found)."""

    coupled_model: CoupledModel | None = None
    """Set by :func:`reference.reduced.algorithms.reduced_twin`."""

    def start(self, model, state, critical_step=None, guard=None) -> ReducedLinearRun:
        if self.path is not None or self.spin is not None:
            raise ValueError("modes of a model with reduced bodies are taken about the reference state only; "
                             "remove about (or set about = \"reference\")")
        cm = self.coupled_model
        bodies = cm.initial(state)
        cm.place(bodies, state)
        return ReducedLinearRun(None, None, lam=np.zeros(model.n_constraints), coupled=cm, bodies=bodies)

    def advance(self, model, state, run, n_steps, record) -> int:
        if record is not None:
            _record(run.coupled, record, state, run.bodies, run.lam, 0.0)
        return self._analysis(model, state, run) if n_steps == 0 else OK

    def analyse(self, model, state, run) -> dict:
        cm, bodies = run.coupled, run.bodies
        T = cm.velocity_map(bodies)
        ids = np.flatnonzero(cm.free)
        K = stiffness(cm, state, bodies, T)[np.ix_(ids, ids)]
        M = cm.mass(bodies).toarray()[np.ix_(ids, ids)]
        _, BT, _, _ = cm.constraints(state, bodies, T)
        Z, rank = null_space(BT[:, ids].tocsr())
        Zd = Z.toarray()
        size = Zd.shape[1]
        if self.n_modes > size:
            raise ValueError(f"{self.n_modes} modes asked of a model with {size} independent coordinates; ask at "
                             f"most {size}")
        found = modes(sp.csr_matrix(Zd.T @ M @ Zd), sp.csr_matrix((size, size)), sp.csr_matrix(Zd.T @ K @ Zd),
                      self.n_modes)
        k = self.n_modes
        shapes = (T[:, ids] @ (Zd @ found.phi[:, :k])).T.reshape(k, -1, 6)
        zero = int(np.sum(found.kind == "zero"))
        return {"modes/frequency": found.frequency[:k], "modes/damping_ratio": found.damping_ratio[:k],
                "modes/omega_squared": found.omega2[:k], "modes/root": np.stack([found.s.real, found.s.imag], 1)[:k],
                "modes/kind": found.kind[:k].astype(str), "modes/shape": np.real(shapes),
                "modes/zero_modes": np.int64(zero), "modes/mobility": np.int64(zero),
                "modes/constraint_rank": np.int64(rank), "modes/coordinates": np.int64(size),
                "modes/time": np.float64(state.t)}

    def recorded(self, run) -> dict:
        return run.coupled.recorded(run.bodies)
