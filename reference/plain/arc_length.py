"""Arc-length path following on the reference path (:meth:`PlainArcLength._point`).

The path, its scaled norm, Riks' normal-plane corrector, the predictor's orientation, the adaptive arc and
its cuts, the records and the stability count are those of :mod:`reference.algorithms.arc_length` (stated
there once), on :class:`reference.plain.newton.Newton`: the corrector is
:func:`reference.plain.corrector.static_newton` with the load factor an unknown on the predictor's normal plane.
The compiled algorithm's critical points are kept (:class:`reference.algorithms.critical_points.CriticalPoints`:
the count, the events, their kind and load factor, refined by secant steps along the path, :meth:`_locate`).
Displacement control (``control``) and the branch switch (``branch_switch``) as there.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from reference.algorithms.arc_length import GROWTH, MAX_CUTS, MAX_GROWTH, TARGET_ITERATIONS, WANDER, ArcLength, ArcRun
from reference.algorithms.critical_points import REFINE
from reference.algorithms.path_checks import STILL, TRACE_POINTS, drives, load_factor_jump, unmoved, vertex
from reference.linalg import SingularMatrix
from reference.modal import nearest_zero
from reference.interactions import tf_integral, tf_value
from reference.plain.loads import load_tangent
from reference.plain.newton import EngineFace, Newton, compose, relative_rotation
from reference.plain.corrector import LoadPath, static_newton
from reference.scalar import scalar_twin
from reference.state import new_clock
from reference.status import NO_CONVERGENCE, OK, SINGULAR
from reference.validation import ModelWarning


@dataclass
class PlainArcRun(ArcRun):
    """:class:`reference.algorithms.arc_length.ArcRun` with the reference path's Newton system ``plain``
    (``system`` is its :class:`reference.plain.newton.EngineFace`)."""

    plain: Newton | None = None


class PlainArcLength(ArcLength):
    """:class:`reference.algorithms.arc_length.ArcLength` on the reference path: the same settings, records,
    stability events and messages; the points of :meth:`_point`."""

    def start(self, model, state, critical_step=None, guard=None) -> PlainArcRun:
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        nw = Newton(model)
        run = PlainArcRun(EngineFace(nw), np.zeros(model.n_constraints), self.length_scale(state.x),
                          self.arc_length, plain=nw)
        scale = np.ones((model.nodes.mass.shape[0], 6))
        scale[:, :3] = 1.0 / run.L
        run.weights = scale[nw.free]
        if self.control is not None:
            problem = self.setting_problem(model)
            if problem:
                raise ValueError(f"{problem[0]}: {problem[1]}; {problem[2]}")
            node, comp = self.control[:2]
            run.controlled = int(np.sum(nw.free.ravel()[:6 * node + comp]))
        return run

    def _matrix(self, run, x, q, lam, ce=None):
        """The Newton matrix at ``t_end`` at the last evaluation's configuration, its configuration-dependent
        load blocks (follower forces, dead moments: :func:`reference.plain.loads.load_tangent`) scaled to λ."""
        nw = run.plain
        zero = np.zeros_like(x)
        A = nw.matrix(x, q, zero, zero, self.t_end, run.mu, (0.0, 0.0, 1.0, 1.0 if ce is None else ce))
        if lam == 1.0 or not np.any(np.isin(nw.model.loads.code, (1, 2))):
            return A
        blocks = sps.block_diag(list(load_tangent(nw.model, q, self.t_end)), format="csr")[nw.index][:, nw.index]
        return (A + sps.block_diag([(lam - 1.0) * blocks, sps.csr_matrix((nw.m, nw.m))])).tocsc()

    def _correct(self, run, x, q, lam, normal):
        """:func:`reference.plain.corrector.static_newton` at ``t_end`` from ``(x, q, μ)`` with the loads × λ,
        λ an unknown on the plane of ``normal`` (None: fixed); ``(status, λ, Σ scaled corrections and Δλ)``."""
        nw = run.plain
        path = LoadPath(lam, normal, run.weights, lambda xx, qq, value: self._matrix(run, xx, qq, value),
                        np.zeros(nw.n_free + 1))
        code, run.history = static_newton(nw, x, q, run.mu, self.t_end, self.tolerance, run.L, self.max_iterations,
                                          path)
        run.U = nw.last.U
        if code == OK:
            run.iterations = len(run.history) - 1
        return code, path.value, path.moved

    def _tangent(self, run, x, q, lam):
        """``(δ_F (N,6), μ_F)``: ``K δ_F = F`` at the point (raises :class:`reference.linalg.SingularMatrix`)."""
        nw = run.plain
        _, F = self._evaluate(run, x, q, lam)
        lu = nw.factor(self._matrix(run, x, q, lam))
        solved = nw.solve(lu, F.copy(), np.zeros(nw.m)) if lu is not None else None
        if solved is None:
            raise SingularMatrix("singular tangent")
        return solved

    def _predictor(self, run, x, q, ds, lam=None, sgn=None):
        """The tangent predictor of arc ds at ``(x, q)`` and load factor λ (default the last point's):
        ``(step (N,6), step of μ, Δλ, unit normal)``, Δλ's sign ``sgn`` or, by default, that of the tangent's
        projection on the previous increment (Feng, Perić & Owen 1996); under displacement control (from the last
        point) :meth:`_controlled`'s."""
        dF, muF = self._tangent(run, x, q, run.lam if lam is None else lam)
        t_u = self._scaled(run, dF)
        if self.control is not None and lam is None:
            return self._controlled(run, dF, muF, t_u, ds)
        norm = math.sqrt(float(t_u @ t_u) + 1.0)
        if sgn is None:
            sgn = -1.0 if run.previous is not None and (t_u @ run.previous[:-1] + run.previous[-1]) < 0.0 else 1.0
        dlam = sgn * ds / norm
        return dlam * dF, dlam * muF, dlam, np.append(t_u, 1.0) * (sgn / norm)

    def _controlled(self, run, dF, muF, t_u, ds):
        """The predictor under displacement control (Batoz & Dhatt 1979): the controlled coordinate moves by ds
        (scaled), its direction kept from point to point, on the plane that holds it there; None, with
        ``run.problem`` saying so, when the load does not move it."""
        c = run.controlled
        t_c = t_u[c]
        if abs(t_c) <= STILL * float(np.linalg.norm(t_u)):
            run.problem = unmoved(self.control[-1], run.lam)
            return None
        sgn = math.copysign(1.0, run.previous[c] if run.previous is not None else t_c)
        dlam = sgn * ds / t_c
        normal = np.zeros(run.plain.n_free + 1)
        normal[c] = sgn
        return dlam * dF, dlam * muF, dlam, normal

    def _along_mode(self, run, ds):
        """The predictor of a branch switch: a step of length ds along the critical mode ``run.switch``, Δλ = 0
        (Wriggers 2008, §7.4.3), on the plane normal to it."""
        dir_u = self._scaled(run, run.switch)
        norm = float(np.linalg.norm(dir_u))
        return run.switch * (ds / norm), np.zeros_like(run.mu), 0.0, np.append(dir_u / norm, 0.0)

    def _point(self, run, x, q, clock) -> int:
        """The next converged point: predictor, corrector on its normal plane, the arc halved after a failure
        or a corrector that wandered off (up to ``MAX_CUTS`` times), the next arc adapted to the iterations."""
        nw = run.plain
        saved = (x.copy(), q.copy(), run.mu.copy(), nw.angle.copy())
        ds, code = run.ds, NO_CONVERGENCE
        run.problem = ()  # kept through the cuts: a jump refused on a longer step explains a failed shorter one
        for _ in range(MAX_CUTS + 1):
            try:
                predicted = self._along_mode(run, ds) if run.switch is not None else self._predictor(run, x, q, ds)
                if predicted is None:
                    return SINGULAR
                step_u, step_mu, dlam, normal = predicted
                x += step_u[:, :3]
                q[:] = compose(q, step_u[:, 3:])
                run.mu += step_mu
                code, lam, moved = self._correct(run, x, q, run.lam + dlam, normal)
            except SingularMatrix:
                code = SINGULAR
            wander = run.switch is None and self.control is None  # a switch's corrector goes back to the critical load
            if code == OK and wander and float(np.linalg.norm(moved)) > WANDER * ds:
                code = NO_CONVERGENCE  # the corrector wandered off along the plane: another branch
            if code == OK and self.control is not None:
                code = load_factor_jump(run, lam, self.control[-1], self.cut_note)
            if code == OK:
                increment = moved + np.append(self._scaled(run, step_u), dlam)
                run.s += float(np.linalg.norm(increment))
                run.previous = increment
                dW, run.P = self._work(run, saved[0], saved[1], x, q, lam)
                clock["work"] += dW
                run.lam, run.jumped, run.switch = lam, run.switch is not None, None
                run.peak = max(run.peak, abs(lam))
                run.problem = ()
                if self.control is None:
                    factor = math.sqrt(TARGET_ITERATIONS / max(run.iterations, 1))
                    run.ds = min(ds * min(max(factor, 1.0 / GROWTH), GROWTH), MAX_GROWTH * self.arc_length)
                return OK
            x[:], q[:], run.mu[:], nw.angle[:] = saved
            ds *= 0.5
        return code

    def _work(self, run, x0, q0, x, q, lam):
        """Trapezoidal work of the loads λF and the drives from the last point (the last evaluation at the new
        one), as the compiled ``_work``."""
        nw = run.plain
        d = np.hstack([x - x0, relative_rotation(q0, q)])
        F1 = nw.last.F
        work = 0.5 * float(np.sum((run.lam * run.F + lam * F1) * d))
        run.F = F1.copy()
        P1 = nw.joint_forces(nw.last, run.mu)
        return work - 0.5 * float(np.sum((run.P + P1) * d)), P1

    def _locate(self, run, before, span, mu0, mu1, M, Z):
        """:meth:`reference.algorithms.critical_points.CriticalPoints._locate` on this path: :data:`REFINE` secant
        steps on the eigenvalue nearest zero along the path from the point ``before``, each a probe point solved
        on its predictor's normal plane (not recorded; the run state restored); None when a probe fails."""
        x0, q0, m0, lam0, _, _, slope0 = before
        nw = run.plain
        saved = (run.mu, run.history, run.iterations, nw.angle.copy())
        a, fa, b, fb = 0.0, mu0, span, mu1
        found, sgn = None, 1.0 if slope0 >= 0.0 else -1.0
        try:
            for _ in range(REFINE):
                sigma = a + (b - a) * fa / (fa - fb) if fa != fb else 0.5 * (a + b)
                run.mu = m0.copy()
                step_u, step_mu, dlam, normal = self._predictor(run, x0, q0, sigma, lam0, sgn)
                x, q = x0 + step_u[:, :3], compose(q0, step_u[:, 3:])
                run.mu += step_mu
                code, lam, _ = self._correct(run, x, q, lam0 + dlam, normal)
                if code != OK:
                    return None
                f = nearest_zero(sps.csr_matrix(self._reduced(run, x, q, lam, Z)[0]), M)[0]
                found = lam
                if (f > 0.0) == (fa > 0.0):
                    a, fa = sigma, f
                else:
                    b, fb = sigma, f
        except SingularMatrix:
            return None
        finally:
            run.mu, run.history, run.iterations = saved[:3]
            nw.angle[:] = saved[3]
        return found


def limit_point_trace(static, model, state, run, saved, F0, t0, t1) -> None:
    """:func:`reference.algorithms.limit_point.limit_point_trace` on the reference path: the load interval
    ``[t0, t1]`` of a static step (:class:`reference.plain.static.PlainStatic`) whose displacement per unit
    load jumped, traced again by :class:`PlainArcLength` from the equilibrium before it (``saved``: x, q, λ,
    the angles; ``F0`` its loads; the step's equilibrium the state's, its loads ``run.F``).  When the load
    factor along that path reaches a maximum below ``t1`` and falls, the step passed a limit point: one warning
    line and an event of ``/stability``.  Only for proportional loads and drives that do not move over the
    step; the run's state is left as it is."""
    free = run.newton.free
    F1, F_0 = run.F[free], F0[free]
    top = float(F1 @ F1)
    c = float(F_0 @ F1) / top if top > 0.0 else -1.0
    if not (0.0 <= c < 1.0) or np.max(np.abs(F_0 - c * F1), initial=0.0) > 1e-12 * math.sqrt(top):
        return
    if _drives_move(model, t0, t1):
        return
    x0, q0, lam0, angle0 = saved
    step = np.hstack([(state.x - x0) / run.L, relative_rotation(q0, state.q)])[free]
    arc = PlainArcLength(math.sqrt(float(step @ step) + (1.0 - c) ** 2) / 8.0, TRACE_POINTS, math.inf, t1,
                         static.tolerance, static.max_iterations)
    trace = arc.start(model, state)
    trace.L = run.L
    x, q = x0.copy(), q0.copy()
    trace.mu[:], trace.plain.angle[:] = lam0, angle0
    if arc._correct(trace, x, q, c, None)[0] != OK:
        return
    trace.lam, trace.F, trace.P = c, trace.plain.last.F.copy(), trace.plain.joint_forces(trace.plain.last, trace.mu)
    path, clock = [(0.0, c)], new_clock()[0]
    for _ in range(TRACE_POINTS):
        if arc._point(trace, x, q, clock) != OK or trace.lam >= 1.0:
            return
        path.append((trace.s, trace.lam))
        if trace.lam < path[-2][1]:
            break
    else:
        return
    (s0, l0), (s1, l1), (s2, l2) = path[-3:] if len(path) >= 3 else [path[0]] + path[-2:]
    t_lim = t0 + (vertex(s0, l0, s1, l1, s2, l2) - c) / (1.0 - c) * (t1 - t0)
    run.events.append((t0, t1, t_lim, "limit point", run.negative))
    warnings.warn(f"the load step from load factor {t0:.6g} to {t1:.6g} passed a limit point at load factor "
                  f"{t_lim:.6g} (traced by arc length) and jumped to another branch of the path: use algorithm = "
                  "\"arc_length\" to follow it, or push the structure ([[prescribed_displacements]])",
                  ModelWarning, stacklevel=3)


def _drives_move(model, t0: float, t1: float) -> bool:
    """Whether a drive's prescribed value (:func:`reference.algorithms.path_checks.drive_value`: its time function,
    or the integral for a drive given by its rate) changes from t0 to t1, the time functions run as plain Python."""
    kinds, pars = model.time_functions.kind, model.time_functions.par
    for k, code in drives(model):
        f, tf = scalar_twin(tf_integral if code in (2, 4) else tf_value), int(model.joints.tf[k])
        if f(kinds[tf], pars[tf], float(t0)) != f(kinds[tf], pars[tf], float(t1)):
            return True
    return False
