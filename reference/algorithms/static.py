"""Static equilibrium by load stepping and full Newton–Raphson (``algorithm = "static"``).

The load factor t (the deck's time) goes from 0 to ``t_end`` in ``load_steps``
equal steps; loads are scaled by their time functions at t and drives are
prescribed at t.  At every load level the equilibrium

    S(x, q) − F(x, q, t) + B(x, q)ᵀ λ = 0,      Φ(x, q, t) − ε λ = 0

is solved by Newton–Raphson (converged when every residual force is below
``tolerance`` times the largest force, and |Φ| below ``tolerance`` times the
model size, or when the correction is below ``tolerance``) on the sparse saddle-point system of
:mod:`reference.algorithms.implicit` (coefficients ``c_m = c_c = 0``,
``c_k = 1``), starting from the previous level.  The tangent is the exact
derivative under the update ``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (body-frame
δθ), so the convergence is quadratic (Wriggers 2008, *Nonlinear Finite Element
Methods*, §5.1); the iterations run in one compiled call per load level
(:func:`reference.algorithms.newton_steps.newton_loop`).  When Newton fails (no convergence in ``max_iterations``, a
non-finite or singular iterate) the step is halved, up to ``MAX_CUTS`` times;
the next steps grow back to the nominal step.  If the smallest step still
fails the run stops with the load level reached.  The solver statistics (load steps, Newton
iterations, factorisations, step cuts: :class:`reference.algorithms.step_control.SolverStatistics`)
go to ``/solver/…`` at every output and into the run's summary line, as generalized-α's.

A converged step is refused (and cut like a failed one) when its equilibrium is not the path's:
a rotation drive at the other root of ``sin(θ − θ(t)) = 0``, π from θ(t), or the reaction of a
displacement drive or prescribed displacement whose magnitude falls by more than
:data:`reference.algorithms.path_checks.JUMP` of its largest along the path (a jump across a snap-back:
:func:`reference.algorithms.path_checks.why_refused`).  Under load control a step whose displacement per
unit load exceeds :data:`reference.algorithms.path_checks.RATIO` times the previous step's is traced again
by arc length (:func:`reference.algorithms.limit_point.limit_point_trace`): a limit point passed without a
change of the stability count (both sides stable) becomes a warning line and a ``/stability`` event.

Records: velocities and kinetic energy 0; strain energy; external work by the
trapezoidal rule along the load path, ``½(F_old + F_new)·(Δx, Δθ)``, plus the
work of the prescribed drives, ``−½(λ_old B_old + λ_new B_new)·Δ``;
``‖Φ‖`` and (velocities being zero) ``‖Φ_t‖``.

**Stability along the path** (docs/formulation.md §11): at every equilibrium reached, the number of
negative eigenvalues of the tangent reduced to the constraints' null space (its inertia:
:func:`reference.modal.negative_eigenvalues` on ``Zᵀ K Z``, Z from :func:`reference.linalg.null_space`)
is recorded (``/stability/negative_eigenvalues``).  When it changes between two load levels, the
eigenvalue nearest zero at both (:func:`reference.modal.nearest_zero`, in the mass metric) is
interpolated linearly to its zero, the critical load factor; the event is a *bifurcation* when the
load increment is orthogonal to the critical mode (``|φᵀ ΔF| ≤``
:data:`reference.algorithms.critical_points.BIFURCATION` ``‖φ‖_M ‖ΔF‖_M⁻¹``), else a *limit point*, and is announced as one :class:`reference.validation.ModelWarning` line and
written to ``/stability/critical_load_factor`` and ``/stability/critical_kind`` at the end.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.algorithms.critical_points import BIFURCATION, eigenvalue_count
from reference.algorithms.implicit import ImplicitAlgorithm, NewtonSystem, relative_rotation
from reference.algorithms.newton_steps import NewtonArrays
from reference.algorithms.limit_point import limit_point_trace
from reference.algorithms.path_checks import PUSHED_FIX, RATIO, moved, row_forces, why_refused
from reference.algorithms.step_control import SolverStatistics
from reference.linalg import null_space
from reference.modal import SMALL, nearest_zero, negative_eigenvalues
from reference.state import RecordView
from reference.status import NO_CONVERGENCE, OK, newton_failure
from reference.validation import ModelWarning

MAX_CUTS = 8
"""Halvings of a load step before the run stops (smallest step 1/256 of the nominal)."""


@dataclass
class StaticRun:
    """The static algorithm's run state (:meth:`Static.start`), advanced only by :meth:`Static.advance`.

    ``system`` the model's Newton system; ``lam`` (m,) the multipliers of the last equilibrium;
    ``P`` (N, 6) its joint forces ``Bᵀλ`` and ``U`` its strain energy (for the work increments and
    records); ``started`` whether the equilibrium at the starting load level is solved;
    ``stopped_at`` the load factor where a failed step stopped; ``history`` the residual norms of
    the Newton iterations of the last load level solved (or tried); ``stats`` the solver statistics
    (a step is a converged load level, a factorisation a Newton iteration: full Newton); ``h`` the
    last converged load step; ``row`` the statistics' record of the last output.
    """

    system: NewtonSystem
    lam: np.ndarray
    L: float
    P: np.ndarray | None = None
    U: float = 0.0
    started: bool = False
    stopped_at: float | None = None
    history: list = field(default_factory=list)
    negative: int = -1
    sign: int = 0
    recorded: int = -1
    recorded_at: float | None = None
    previous: tuple | None = None
    events: list = field(default_factory=list)
    stats: SolverStatistics = field(default_factory=SolverStatistics)
    h: float = 0.0
    row: dict = field(default_factory=dict)
    newton: NewtonArrays | None = None
    dense: bool = False
    reactions: np.ndarray | None = None
    peaks: np.ndarray | None = None
    rate: float = 0.0
    refused: str = ""
    refused_fix: str = ""


class Static(ImplicitAlgorithm):
    """Load-stepped static equilibrium with full Newton–Raphson and step cutting.

    Parameters
    ----------
    dt : float
        Load-factor increment ``t_end / load_steps``.
    tolerance : float, default 1e-10
        Newton stops when the largest correction is below ``tolerance`` × model size
        (translations) and ``tolerance`` rad (rotations).
    max_iterations : int, default 25
    """

    name = "static"
    deck_required = ("t_end", "load_steps")
    deck_optional = ("tolerance", "max_iterations", "output_every", "max_steps")
    progress_name = "load factor"
    no_convergence_fix = ("The structure may have reached a limit (buckling) point or the load step is too large: "
                          "raise load_steps or max_iterations, or stop t_end below the limit load; past a limit "
                          "point, push the load point instead ([[prescribed_displacements]]) or use arc_length.")

    def __init__(self, dt: float, tolerance: float = 1e-10, max_iterations: int = 25):
        super().__init__(dt, tolerance, max_iterations)
        self.cut_note = f"even with the load step halved {MAX_CUTS} times"

    @classmethod
    def from_settings(cls, settings, dt=None):
        step = dt if dt is not None else settings.t_end / settings.load_steps
        return cls(step, settings.tolerance or 1e-10, settings.max_iterations or 25)

    def start(self, model, state, critical_step=None, guard=None) -> StaticRun:
        """A run from ``state`` (its load level ``state.t``): the Newton system, zero multipliers and the
        compiled Newton loop's arrays."""
        system = self.newton_system(model)
        run = StaticRun(system, np.zeros(model.n_constraints), self.length_scale(state.x))
        n = system.pattern.n
        run.dense = n == system.n_free and n <= SMALL  # the stability count's dense path (no constraints)
        run.newton = NewtonArrays(system, self.tolerance, run.L, self.max_iterations,
                                  np.zeros((n, n)) if run.dense else None)
        return run

    def _equilibrium(self, run, x, q, lam, t):
        """Newton at load level t from (x, q, λ), in place; returns a status code.

        The iterations run compiled (:func:`reference.algorithms.newton_steps.newton_loop`); Python
        makes only the SuperLU factorisations the kernel asks for (the first, and any after the kept
        pivots went bad) and resumes it."""
        nw = run.newton
        par = nw.fields
        # the stability count's tangent is assembled at the equilibrium, and the sign of its determinant
        # computed there when that is all the count needs (negative_eigenvalues' known-count path)
        par["tangent"], par["sign"] = (2.0 if run.dense and run.negative >= 0 else 1.0), 3.0
        code = nw.solve(x, q, lam, t)
        run.history = nw.history()
        run.stats.iterations += len(run.history) - 1
        if code == OK:
            run.U = par["U"]
        return code

    def advance(self, model, state, run, n_steps, record) -> int:
        x, q, v, w, f_prev = state[:5]
        clock = RecordView(state.clock)
        system, lam = run.system, run.lam
        if not run.started:
            # equilibrium at the starting load level (gravity or loads at t = 0, drives)
            v[:] = 0.0
            w[:] = 0.0
            system.work.angle[:] = state.angle  # the force elements' continuous angles
            run.stopped_at = None
            code = self._equilibrium(run, x, q, lam, clock["t"])
            if code != OK:
                run.stopped_at = clock["t"]
                return code
            run.refused = why_refused(run, self.joint_labels, x, q, lam, clock["t"], clock["t"])
            if run.refused:
                run.stopped_at = clock["t"]
                return NO_CONVERGENCE
            run.P = row_forces(system, lam)
            f_prev[:] = system.work.F
            run.started = True
            self._stability(run, x, q, lam, clock["t"])
        if record is not None:
            U = run.U = float(system.evaluate(x, q, x, x, x, lam, clock["t"], False))
            system.write_record(record, x, q, v, w, U, state.clock, lam)
            run.recorded, run.recorded_at = run.negative, float(clock["t"])
            r = system.work.r[system.free]
            run.stats.factorizations = run.stats.iterations  # full Newton: a factor every iteration
            run.row = run.stats.output(run.h, float(np.sqrt(r @ r)))
        for _ in range(n_steps):
            t0, target = clock["t"], clock["t"] + self.dt
            sub, t = self.dt, t0
            run.refused = ""
            while t < target - 1e-12 * self.dt:
                t_try = min(t + sub, target)
                saved = (x.copy(), q.copy(), lam.copy(), system.work.angle.copy())
                code = self._equilibrium(run, x, q, lam, t_try)
                refused = why_refused(run, self.joint_labels, x, q, lam, t, t_try) if code == OK else ""
                if refused:  # kept through the load step's cuts: it explains a shorter step's failure too
                    run.refused, code = refused, NO_CONVERGENCE
                if code == OK:
                    rate = moved(system, saved[0], saved[1], x, q, run.L) / (t_try - t)
                    if run.rate > 0.0 and rate > RATIO * run.rate:
                        limit_point_trace(self, model, state, run, saved, f_prev, (x, q, lam), t, t_try)
                    run.rate = rate
                    dW, run.P = _work_increment(system, saved[0], saved[1], f_prev, run.P, x, q, lam)
                    clock["work"] += dW
                    f_prev[:] = system.work.F
                    self._stability(run, x, q, lam, t_try)
                    run.h = t_try - t
                    run.stats.step(run.h)
                    t = t_try
                    sub = min(2.0 * sub, self.dt)
                    continue
                x[:], q[:], lam[:] = saved[:3]
                sub *= 0.5
                run.stats.cuts += 1
                if sub < self.dt / 2**MAX_CUTS:
                    state.angle[:] = system.work.angle
                    run.stopped_at = t
                    clock["t"] = t
                    return code
            state.angle[:] = system.work.angle
            clock["n"] += 1
            clock["t"] = clock["n"] * self.dt
        return OK

    def failure(self, code: int, state, run) -> tuple[str, str]:
        """``(status, message)`` of a failed load step: a refused one (:func:`reference.algorithms.path_checks.why_refused`) says why; a
        displacement-controlled path that stops is sent to the arc length, not to the displacement control
        it already has."""
        t = run.stopped_at if run.stopped_at is not None else state.t
        if run.refused:
            return (f"step refused at load factor {t:.6g}",
                    f"{run.refused}{'' if t == 0.0 else ', ' + self.cut_note}; results up to load factor {t:.6g} are "
                    f"kept. {run.refused_fix}")
        if code == NO_CONVERGENCE and run.reactions is not None and run.reactions.size:
            return newton_failure(code, f"{self.progress_name} {t:.6g}", self.max_iterations, self.cut_note,
                                  PUSHED_FIX)
        return super().failure(code, state, run)

    def record_last(self, model, state, run, record) -> bool:
        """After a failed step: the last converged load level (a sub-level of the cut step, or a whole
        step between outputs), when it is not recorded yet."""
        if not run.started or run.recorded_at == state.t:
            return False
        self.advance(model, state, run, 0, record)
        return True

    def recorded(self, run) -> dict:
        """The number of negative eigenvalues of the reduced tangent at the recorded equilibrium, and the
        solver statistics of the load steps up to it (:meth:`advance`)."""
        return {**run.row, "negative_eigenvalues": float(run.recorded)}

    def summary(self, run) -> str:
        return run.stats.summary(steps="load steps", dt="load step")

    def finish(self, model, state, run, completed: bool) -> dict:
        """The changes of stability along the path (none: empty datasets)."""
        events = run.events
        return {"stability/critical_load_factor": np.array([e[2] for e in events], dtype=float),
                "stability/critical_kind": np.array([e[3] for e in events], dtype=str),
                "stability/bracket": np.array([e[:2] for e in events], dtype=float).reshape(-1, 2)}

    def _stability(self, run, x, q, lam, t) -> None:
        """The inertia of the reduced tangent at the equilibrium just reached (the last evaluation, and the
        tangent the compiled Newton loop assembled, are at it); a change from the previous equilibrium
        becomes an event and a warning."""
        system = run.system
        sign = run.newton.fields["sign"]
        if sign in (-1.0, 0.0, 1.0) and int(sign) == run.sign:
            # a non-symmetric tangent whose determinant kept its sign: the count is the previous one
            # (negative_eigenvalues with known = (count, sign), its sign from the compiled loop)
            count, sign, K, Z = run.negative, run.sign, None, None
        else:
            (count, sign), K, Z, _ = reduced_tangent(system, x, q, lam, t, known=(run.negative, run.sign),
                                                     evaluate=False, assembled=True)
        F = system.work.F.copy()
        before, run.previous = run.previous, (x.copy(), q.copy(), lam.copy(), t, F)
        (old, run.negative), run.sign = (run.negative, count), sign
        if before is None:
            if count > 0:
                warnings.warn(f"the equilibrium at load factor {t:.6g} is unstable: {eigenvalue_count(count)} of the "
                              "tangent", ModelWarning, stacklevel=2)
            return
        if count == old or count < 0 or old < 0:
            return
        x0, q0, lam0, t0, F0 = before
        Z = sps.identity(system.n_free, format="csr") if Z is None else Z
        M = (Z.T @ system.mass(x, q) @ Z).tocsr()
        mu1, phi = nearest_zero(sps.csr_matrix(K), M)
        mu0 = nearest_zero(sps.csr_matrix(reduced_tangent(system, x0, q0, lam0, t0, Z)[1]), M)[0]
        system.evaluate(x, q, x, x, x, lam, t, False)  # the evaluation at the current equilibrium again
        t_cr = t0 + (t - t0) * min(max(mu0 / (mu0 - mu1), 0.0), 1.0) if mu0 != mu1 else t  # inside its bracket
        dF = Z.T @ (F - F0)[system.free]
        along = abs(phi @ dF)
        size = np.sqrt(max(dF @ spla.spsolve(M.tocsc(), dF), 0.0)) * np.sqrt(max(phi @ (M @ phi), 0.0))
        kind = "bifurcation" if along <= BIFURCATION * size else "limit point"
        run.events.append((t0, t, t_cr, kind, count))
        change = "stability lost" if count > old else "stability regained" if count == 0 else "stability changed"
        warnings.warn(f"{change} between load factor {t0:.6g} and {t:.6g}: {kind}, {eigenvalue_count(count)} "
                      f"(critical load factor {t_cr:.6g}, interpolated from the lowest eigenvalue)",
                      ModelWarning, stacklevel=2)


def reduced_tangent(system, x, q, lam, t, Z=None, known=None, evaluate=True, assembled=False):
    """``((negative eigenvalues, sign of det), K_r, Z, rank B)`` of the static tangent at ``(x, q, λ, t)``
    reduced to the null space of B (Z given, or from :func:`reference.linalg.null_space`; None without
    constraints, K_r then dense up to :data:`reference.modal.SMALL` coordinates;
    :func:`reference.modal.negative_eigenvalues` with ``known``); evaluates the model there unless its
    last evaluation is at it (``evaluate`` false), and assembles the tangent unless the compiled Newton
    loop left it assembled there (``assembled``: :func:`reference.algorithms.newton_steps.static_newton`)."""
    zero = np.zeros_like(x)
    if evaluate:
        system.evaluate(x, q, zero, zero, zero, lam, t, False)
    A = system.pattern.assembled if assembled else system.matrix(x, q, zero, t, lam, 0.0, 0.0, 1.0, ce=0.0)
    n = system.n_free
    if A.shape[0] == n:  # no constraint: the free coordinates are independent (Z = None: the identity)
        K = A.toarray() if n <= SMALL else A.copy()
        return negative_eigenvalues(K, known), K, None, 0
    A = A.tocsr()
    rank = -1
    if Z is None:
        Z, rank = null_space(A[n:, :n])
    K = (Z.T @ A[:n, :n] @ Z).tocsr()
    return negative_eigenvalues(K, known), K, Z, rank


def _work_increment(system, x0, q0, F0, P0, x, q, lam):
    """Trapezoidal work of the loads and drives from (x0, q0) to (x, q) (the last evaluation at (x, q))."""
    dth = np.empty_like(x)
    relative_rotation(q0, q, dth, np.empty(4))
    d = np.concatenate([x - x0, dth], axis=1)
    F1 = system.work.F
    work = 0.5 * float(np.sum((F0 + F1) * d))
    P1 = row_forces(system, lam)
    return work - 0.5 * float(np.sum((P0 + P1) * d)), P1
