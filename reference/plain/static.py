"""Static load stepping with full Newton–Raphson on the reference path (:class:`PlainStatic`).

The equations, the convergence test and the step cuts are those of :mod:`reference.algorithms.static`
and its compiled loop :func:`reference.algorithms.newton_steps.newton_loop` (stated there once),
written as a textbook loop over :class:`reference.plain.newton.Newton`: at every load level t,
``S − F + Bᵀλ = 0``, ``Φ − ελ = 0`` is solved from the previous level on the matrix
``[K, Bᵀ; B, −ε]``; a level that fails is halved (up to ``MAX_CUTS`` times) and the next grow back.

The records are the compiled algorithm's: the configuration, strain energy, the trapezoidal work of the
loads and drives, ``‖Φ‖``, λ, the solver statistics and the number of negative eigenvalues of the
tangent reduced to the constraints' null space, with its events (:meth:`PlainStatic._stability`); an
equilibrium that is not the path's is refused as there (:func:`reference.algorithms.path_checks.why_refused`),
and a load step whose displacement per unit load jumps is traced again by arc length
(:func:`reference.plain.arc_length.limit_point_trace`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.algorithms.critical_points import BIFURCATION, eigenvalue_count
from reference.algorithms.path_checks import RATIO, why_refused
from reference.algorithms.static import MAX_CUTS, Static, reduced_tangent
from reference.algorithms.step_control import SolverStatistics
from reference.modal import nearest_zero
from reference.validation import ModelWarning
from reference.plain.arc_length import limit_point_trace
from reference.plain.corrector import static_newton
from reference.plain.newton import EngineFace, Newton, relative_rotation
from reference.status import NO_CONVERGENCE, OK


@dataclass
class PlainStaticRun:
    """The run state of :class:`PlainStatic` (the fields of
    :class:`reference.algorithms.static.StaticRun` that its records and messages read; ``system`` the Newton
    system's engine face, for the linearised analyses that follow a static path)."""

    newton: Newton
    lam: np.ndarray
    L: float
    system: EngineFace | None = None
    P: np.ndarray | None = None
    F: np.ndarray | None = None
    U: float = 0.0
    started: bool = False
    stopped_at: float | None = None
    history: list = field(default_factory=list)
    negative: int = -1
    sign: int = 0
    previous: tuple | None = None
    recorded: int = -1
    recorded_at: float | None = None
    events: list = field(default_factory=list)
    stats: SolverStatistics = field(default_factory=SolverStatistics)
    h: float = 0.0
    row: dict = field(default_factory=dict)
    reactions: np.ndarray | None = None
    peaks: np.ndarray | None = None
    rate: float = 0.0
    refused: str = ""
    refused_fix: str = ""


class PlainStatic(Static):
    """:class:`reference.algorithms.static.Static` on the reference path: the same settings, records and
    messages; the load levels solved by :func:`static_newton`."""

    def start(self, model, state, critical_step=None, guard=None) -> PlainStaticRun:
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        nw = Newton(model)
        return PlainStaticRun(nw, np.zeros(model.n_constraints), self.length_scale(state.x), EngineFace(nw))

    def _level(self, run, x, q, lam, t0, t) -> int:
        """Newton at load level t from the level t0 (in place); on success the level's loads and joint forces,
        and a refusal of an equilibrium that is not the path's (:func:`reference.algorithms.path_checks.why_refused`:
        ``run.refused`` says why, the status is then NO_CONVERGENCE)."""
        nw = run.newton
        code, run.history = static_newton(nw, x, q, lam, t, self.tolerance, run.L, self.max_iterations)
        run.stats.iterations += len(run.history) - 1
        if code == OK:
            res = nw.last
            run.U, run.F, run.P = res.U, res.F.copy(), nw.joint_forces(res, lam)
            refused = why_refused(run, self.joint_labels, x, q, lam, t0, t)
            if refused:  # kept through the load step's cuts: it explains a shorter step's failure too
                run.refused, code = refused, NO_CONVERGENCE
        return code

    def _stability(self, run, x, q, lam, t) -> None:
        """The inertia of the tangent reduced to the constraints' null space at the equilibrium just reached
        (:func:`reference.algorithms.static.reduced_tangent` over the engine face); a change from the previous
        equilibrium is an event and a warning, as in the compiled algorithm: its critical load factor
        interpolated from the eigenvalue nearest zero at both, a bifurcation when the load increment is
        orthogonal to the critical mode, else a limit point."""
        system = run.system
        (count, run.sign), K, Z, _ = reduced_tangent(system, x, q, lam, t, known=(run.negative, run.sign))
        before, run.previous = run.previous, (x.copy(), q.copy(), lam.copy(), t, run.F.copy())
        old, run.negative = run.negative, count
        if before is None or count == old or count < 0 or old < 0:
            if before is None and count > 0:
                warnings.warn(f"the equilibrium at load factor {t:.6g} is unstable: {eigenvalue_count(count)} of the "
                              "tangent", ModelWarning, stacklevel=3)
            return
        x0, q0, lam0, t0, F0 = before
        Z = sps.identity(system.n_free, format="csr") if Z is None else Z
        M = (Z.T @ system.mass() @ Z).tocsr()
        mu1, phi = nearest_zero(sps.csr_matrix(K), M)
        mu0 = nearest_zero(sps.csr_matrix(reduced_tangent(system, x0, q0, lam0, t0, Z)[1]), M)[0]
        system.evaluate(x, q, x, x, x, lam, t, False)  # the evaluation at the current equilibrium again
        t_cr = t0 + (t - t0) * min(max(mu0 / (mu0 - mu1), 0.0), 1.0) if mu0 != mu1 else t
        dF = Z.T @ (run.F - F0)[system.free]
        size = math.sqrt(max(dF @ spla.spsolve(M.tocsc(), dF), 0.0) * max(phi @ (M @ phi), 0.0))
        kind = "bifurcation" if abs(phi @ dF) <= BIFURCATION * size else "limit point"
        run.events.append((t0, t, t_cr, kind, count))
        change = "stability lost" if count > old else "stability regained" if count == 0 else "stability changed"
        warnings.warn(f"{change} between load factor {t0:.6g} and {t:.6g}: {kind}, {eigenvalue_count(count)} "
                      f"(critical load factor {t_cr:.6g}, interpolated from the lowest eigenvalue)",
                      ModelWarning, stacklevel=3)

    def advance(self, model, state, run, n_steps, record) -> int:
        x, q, v, w, f_prev = state[:5]
        clock = state.clock[0]
        nw, lam = run.newton, run.lam
        if not run.started:
            v[:], w[:] = 0.0, 0.0
            nw.angle[:] = state.angle
            run.stopped_at = None
            code = self._level(run, x, q, lam, clock["t"], clock["t"])
            if code != OK:
                run.stopped_at = clock["t"]
                return code
            f_prev[:] = run.F
            run.started = True
            self._stability(run, x, q, lam, clock["t"])
        if record is not None:
            N = x.shape[0]
            res = nw.evaluate(x, q, v, w, np.zeros((N, 6)), lam, clock["t"], False)
            nw.write_record(record, x, q, v, w, state.clock, lam, res)
            run.U, run.recorded, run.recorded_at = res.U, run.negative, float(clock["t"])
            run.stats.factorizations = run.stats.iterations  # full Newton: a factor every iteration
            run.row = run.stats.output(run.h, nw.free_norm(res.r))
        for _ in range(int(n_steps)):
            code = self._load_step(state, run)
            if code != OK:
                state.angle[:] = nw.angle
                return code
            clock["n"] += 1
            clock["t"] = clock["n"] * self.dt
        state.angle[:] = nw.angle
        return OK

    def _load_step(self, state, run) -> int:
        """One load step of ``dt`` from ``clock["t"]``, in sub-levels halved after a failure and doubled after a
        success; the work of the loads and drives over each (trapezoidal)."""
        x, q, f_prev, clock = state.x, state.q, state.f_prev, state.clock[0]
        nw, lam = run.newton, run.lam
        target, sub, t = clock["t"] + self.dt, self.dt, clock["t"]
        run.refused = ""
        while t < target - 1e-12 * self.dt:
            t_try = min(t + sub, target)
            saved = (x.copy(), q.copy(), lam.copy(), nw.angle.copy(), run.P)
            code = self._level(run, x, q, lam, t, t_try)
            if code == OK:
                d = np.hstack([x - saved[0], relative_rotation(saved[1], q)])
                scaled = np.hstack([d[:, :3] / run.L, d[:, 3:]])[nw.free]
                rate = math.sqrt(float(scaled @ scaled)) / (t_try - t)  # the move per unit load (scaled norm)
                if run.rate > 0.0 and rate > RATIO * run.rate:
                    limit_point_trace(self, nw.model, state, run, saved[:4], f_prev, t, t_try)
                run.rate = rate
                clock["work"] += 0.5 * float(np.sum((f_prev + run.F) * d)) - 0.5 * float(np.sum((saved[4] + run.P) * d))
                f_prev[:] = run.F
                self._stability(run, x, q, lam, t_try)
                run.h = t_try - t
                run.stats.step(run.h)
                t, sub = t_try, min(2.0 * sub, self.dt)
                continue
            x[:], q[:], lam[:], nw.angle[:] = saved[:4]
            run.P = saved[4]
            sub *= 0.5
            run.stats.cuts += 1
            if sub < self.dt / 2**MAX_CUTS:
                run.stopped_at = clock["t"] = t
                return code
        return OK
