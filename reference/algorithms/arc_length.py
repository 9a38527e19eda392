"""Arc-length path following through limit points and bifurcations (``algorithm = "arc_length"``).

The loads are those of the deck at ``t_end`` (time functions and drives evaluated there once),
multiplied by a load factor λ that is an unknown of the path (docs/formulation.md §12)::

    R(u, μ, λ) = S(u) − λ F(u) + Bᵀμ = 0,      Φ(u, t_end) − ε μ = 0

on the constrained saddle-point Newton system of :mod:`reference.algorithms.implicit` (coefficients
``c_m = c_c = 0``, ``c_k = 1``; the configuration-dependent load tangent, follower forces and dead
moments, scaled by λ like the loads; gravity and force-element actuators are loads too, their
actuator tangent is not scaled).  The deck's time is not a parameter of the path: every record's
``time`` is its load factor λ.

Constraint: **Riks' linearised (normal-plane) constraint** (Riks 1979; Crisfield 1991, §9.3.2) in the
scaled norm ``‖w‖² = Σ |Δx/L|² + Σ |Δθ|² + Δλ²`` (translations over the model size L, rotations in
rad, λ dimensionless).  Every corrector iterate lies in the hyperplane through the predicted point
normal to the predictor, so the load increment of a correction is the solution of one linear equation
(bordering: two back-substitutions with the one factorisation, no quadratic to solve and no root to
choose — Crisfield's spherical constraint has two roots and the wrong one turns the path back; on
a rotation manifold the accumulated increment is itself a first-order quantity, so the sphere's
exactness buys nothing).

Predictor: the tangent ``K δ_F = F`` with ``Δλ = ± ds / ‖(δ_F, 1)‖``, its sign that of the tangent's
projection on the previous converged increment (Feng, Perić & Owen 1996): the path goes on through
limit points and snap-backs, where the determinant's sign would also flip at every bifurcation.
Adaptive arc length: ``ds ← ds √(TARGET_ITERATIONS / iterations)`` (Ramm 1981), the change bounded
to ×[½, 2] per point; a corrector that does not converge in ``max_iterations`` (or goes singular or
non-finite), or that moves farther than :data:`WANDER` ds from the predicted point (it found the path
again on another branch; not after a branch switch, whose corrector goes back to the critical load), is undone and the arc halved, up to :data:`MAX_CUTS` times; the arc never
exceeds :data:`MAX_GROWTH` times the deck's, which so also sets the resolution of the path.

The path does not start when the loads at ``t_end`` are zero or a rotation drive converged π from its
angle; under ``control`` a point whose load factor's magnitude falls by more than
:data:`reference.algorithms.path_checks.JUMP` of its largest is refused and the step cut (a snap-back);
:mod:`reference.algorithms.path_checks` holds these checks and why the path ended (:func:`path_end`).

Stability along the path (docs/formulation.md §11): at every converged point the number of negative
eigenvalues of the tangent reduced to the constraints' null space
(:func:`reference.modal.negative_eigenvalues`).  Where it changes between two points, the eigenvalue
nearest zero (mass metric, :func:`reference.modal.nearest_zero`) is interpolated to its zero; the
event is a *bifurcation* when the critical mode is orthogonal to the load (``|φᵀF| ≤``
:data:`reference.algorithms.critical_points.BIFURCATION` ``‖φ‖_M ‖F‖_M⁻¹``), else a *limit point*.  Its load
factor: :data:`reference.algorithms.critical_points.REFINE` secant steps on that eigenvalue along the path from the point before (probe points
solved on its predictor's normal plane, not recorded); should a probe fail, the linear interpolation of
the eigenvalue (bifurcation) or the extremum of the cubic Hermite interpolant of λ(s) from the values and
path slopes at the two points (limit point).  ``branch_switch = true``: at the first bifurcation the next predictor goes along the
critical mode (Δλ = 0, length ds; Wriggers 2008, §7.4.3), onto the post-buckled branch.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from reference.algorithms.critical_points import CriticalPoints
from reference.algorithms.implicit import ImplicitAlgorithm, NewtonSystem, compose, relative_rotation
from reference.algorithms.newton_steps import NewtonArrays
from reference.algorithms.path_checks import (START_FIX, STILL, STOP_OPERATORS, load_factor_jump, path_end,
                                              row_forces, start_problem, unmoved)
from reference.interactions import tf_value
from reference.linalg import SingularMatrix
from reference.observables import ObservableError, _Names, parse
from reference.status import NO_CONVERGENCE, OK, SINGULAR, newton_failure
from reference.validation import ModelWarning

MAX_CUTS = 10
"""Halvings of the arc length before the run stops (smallest arc 1/1024 of the one that failed)."""
TARGET_ITERATIONS = 4
"""Corrector iterations the adaptive arc length aims at (quadratic Newton from a tangent predictor)."""
GROWTH = 2.0
"""Largest factor of change of the arc length from one point to the next (and its inverse the smallest)."""
MAX_GROWTH = 4.0
"""The arc length never exceeds this multiple of the deck's ``arc_length``."""
WANDER = 0.5
"""A corrector that moves farther than this fraction of the arc along its plane is refused and the arc cut:
on a long arc the normal plane may meet the path again on another branch (a jump across a snap-through)."""


@dataclass
class ArcRun:
    """The arc-length algorithm's run state (:meth:`ArcLength.start`), advanced by :meth:`ArcLength.advance`.

    ``system`` the Newton system; ``mu`` (m,) the multipliers, ``lam`` the load factor and ``s`` the arc
    length [scaled norm] of the last converged point; ``ds`` the next arc; ``previous`` its scaled
    increment from the point before (predictor orientation); ``slope`` dλ/ds there; ``points`` the
    stability data ``(x, q, μ, λ, s, count, slope)`` of the last point; ``events`` the changes of
    stability ``(s0, s1, λ_cr, kind, count)``; ``switch`` the critical mode (N, 6) the next predictor
    follows; ``iterations`` the corrector iterations of the last point; ``done`` why the path ended;
    ``peak`` the largest |λ| along a displacement-controlled path (:data:`reference.algorithms.path_checks.JUMP`);
    ``problem`` ``(status, message)`` of a path that cannot go on for a reason of the model, not of the arc.
    """

    system: NewtonSystem
    mu: np.ndarray
    L: float
    ds: float
    lam: float = 0.0
    s: float = 0.0
    started: bool = False
    stopped_at: float | None = None
    history: list = field(default_factory=list)
    iterations: int = 0
    previous: np.ndarray | None = None
    slope: float = 0.0
    negative: int = -1
    sign: int = 0
    point: tuple | None = None
    events: list = field(default_factory=list)
    switch: np.ndarray | None = None
    switched: bool = False
    jumped: bool = False
    done: str = ""
    P: np.ndarray | None = None
    F: np.ndarray | None = None
    U: float = 0.0
    weights: np.ndarray | None = None
    follower: list = field(default_factory=list)
    recorded: tuple = (0.0, 0.0, 0, -1)
    controlled: int = -1
    newton: NewtonArrays | None = None
    peak: float = 0.0
    problem: tuple = ()


class ArcLength(CriticalPoints, ImplicitAlgorithm):
    """Arc-length continuation of the static equilibrium path (Riks' normal-plane constraint).

    Parameters
    ----------
    arc_length : float
        Initial arc length in the scaled norm ``√(Σ|Δx/L|² + Σ|Δθ|² + Δλ²)`` (L the model's size).
    max_points : int
        Converged points after the starting equilibrium before the run ends.
    max_load_factor : float
        The run ends at the first point with ``|λ| ≥ max_load_factor``.
    t_end : float
        The deck time at which the loads (and drives) are taken: λ = 1 is the load at ``t_end``.
    tolerance, max_iterations : float, int
        Newton settings, as for the static algorithm.
    branch_switch : bool
        Leave the primary path at its first bifurcation along the critical mode.
    stop_when : tuple or None
        ``(node index, component, comparison, value)``: the run ends at the first point where the
        node's coordinate compares true (parsed from ``"position.z:NODE < -1.5"``).
    control : tuple or None
        ``(node index, component)``: displacement control (Batoz & Dhatt 1979) in place of the arc: each
        point moves that coordinate by ``arc_length × L`` (fixed steps, halved only for a point whose
        corrector fails; the direction kept from point to point), the load factor is the unknown that
        holds it there (parsed from ``"position.z:NODE"``).
    """

    name = "arc_length"
    deck_required = ("arc_length", "max_points", "max_load_factor")
    deck_optional = ("t_end", "stop_when", "branch_switch", "control", "tolerance", "max_iterations", "output_every")
    progress_name = "load factor"
    no_convergence_fix = ("Lower arc_length or raise max_iterations; a path that turns sharply needs a short arc.")

    def __init__(self, arc_length: float, max_points: int, max_load_factor: float, t_end: float = 1.0,
                 tolerance: float = 1e-10, max_iterations: int = 25, branch_switch: bool = False,
                 stop_when: tuple | None = None, control: tuple | None = None):
        super().__init__(1.0, tolerance, max_iterations)
        if not arc_length > 0.0:
            raise ValueError(f"arc_length must be positive, got {arc_length!r}")
        if int(max_points) < 1:
            raise ValueError(f"max_points must be a positive integer, got {max_points!r}")
        self.arc_length, self.max_points = float(arc_length), int(max_points)
        self.max_load_factor, self.t_end = float(max_load_factor), float(t_end)
        self.branch_switch, self.stop_when, self.control = bool(branch_switch), stop_when, control
        self.cut_note = f"even with the arc length halved {MAX_CUTS} times"

    @classmethod
    def from_settings(cls, settings, dt=None):
        return cls(settings.arc_length, settings.max_points, settings.max_load_factor, settings.t_end,
                   settings.tolerance or 1e-10, settings.max_iterations or 25, settings.branch_switch,
                   settings.stop_when, settings.control)

    @classmethod
    def deck_settings(cls, rd, solver: dict, domain) -> dict:
        """``arc_length`` (> 0), ``max_points`` (≥ 1), ``max_load_factor`` (> 0), ``branch_switch`` and
        ``stop_when = "position.C:NODE OP VALUE"`` (C one of x, y, z; OP one of <, <=, >, >=)."""
        out = {"arc_length": rd.number(solver["arc_length"], "solver.arc_length", positive=True),
               "max_points": rd.integer(solver["max_points"], "solver.max_points", maximum=10**6,
                                        fix="a path of more points is a path of too short an arc: raise arc_length"),
               "max_load_factor": rd.number(solver["max_load_factor"], "solver.max_load_factor", positive=True),
               "branch_switch": rd.boolean(solver.get("branch_switch", False), "solver.branch_switch")}
        if "stop_when" in solver:
            out["stop_when"] = _stop_when(rd, solver["stop_when"], domain)
        if "control" in solver:
            out["control"] = _coordinate(rd, solver["control"], "solver.control", domain,
                                         "e.g. control = \"position.z:beam:end\" (a node coordinate)")
        return out

    def n_steps(self, t_end: float) -> int:
        """One step per converged point: ``max_points``."""
        return self.max_points

    def done(self, run) -> bool:
        return bool(run.done)

    def start(self, model, state, critical_step=None, guard=None) -> ArcRun:
        system = self.newton_system(model)
        run = ArcRun(system, np.zeros(model.n_constraints), self.length_scale(state.x), self.arc_length)
        scale = np.ones((model.nodes.mass.shape[0], 6))
        scale[:, :3] = 1.0 / run.L
        run.weights = scale[system.free]
        loads = model.loads
        if self.control is not None:
            node, comp = self.control[:2]
            problem = self.setting_problem(model)
            if problem:
                raise ValueError(f"{problem[0]}: {problem[1]}; {problem[2]}")
            run.controlled = int(np.sum(system.free.ravel()[:6 * node + comp]))
        run.follower = [(int(loads.node[k]), int(loads.code[k]), int(loads.tf[k]), np.array(loads.vec[k]))
                        for k in range(loads.node.shape[0]) if loads.code[k] in (1, 2)]
        self._compiled_arrays(run)
        return run

    def setting_problem(self, model) -> tuple[str, str, str] | None:
        """``(deck entry, problem, fix)`` when the model makes a setting impossible: control of a fixed
        coordinate (the deck reader's one-line error, :func:`reference.io.deck.load_deck`)."""
        if self.control is None or model.nodes.free[self.control[0], self.control[1]] != 0.0:
            return None
        return ("solver.control", f"{self.control[-1]!r} is a fixed coordinate ([[fixed]] or [[clamps]]): nothing "
                "can move it", "control a free coordinate that the load moves")

    def failure(self, code: int, state, run) -> tuple[str, str]:
        """``(status, message)`` of a path that stopped: the model's reason when there is one (``run.problem``),
        else the corrector's failure at the last load factor (:func:`reference.status.newton_failure`)."""
        if run.problem:
            return run.problem
        t = run.stopped_at if run.stopped_at is not None else state.t
        if not run.started:
            return newton_failure(code, "load factor 0", self.max_iterations, "", START_FIX)
        fix = self.no_convergence_fix if self.control is None else (
            f"Under control of {self.control[-1]!r} the path may turn back in that coordinate here (a snap-back), "
            "which displacement control cannot pass: remove `control` (the arc length passes snap-backs), or lower "
            "arc_length.")
        return newton_failure(code, f"load factor {t:.6g}", self.max_iterations, self.cut_note, fix)

    def summary(self, run) -> str:
        """Why the path ended (its last point's load factor): ``stop_when``, ``max_load_factor`` or ``max_points``."""
        if run is None or not run.started:
            return ""
        why = run.done or f"max_points = {self.max_points} points reached at load factor {run.lam:.6g}"
        return f"path ended: {why}"

    def _compiled_arrays(self, run) -> None:
        """The compiled corrector's arrays (:func:`reference.algorithms.newton_steps.newton_loop`), with the
        follower loads' values at ``t_end``."""
        system = run.system
        tf = system.model.time_functions
        follower = (np.array([f[0] for f in run.follower], dtype=np.int64),
                    np.array([f[1] for f in run.follower], dtype=np.int64),
                    np.array([tf_value(tf.kind[f[2]], tf.par[f[2]], self.t_end) for f in run.follower], dtype=float),
                    np.array([f[3] for f in run.follower], dtype=float).reshape(-1, 3))
        run.newton = NewtonArrays(system, self.tolerance, run.L, self.max_iterations, weights=run.weights,
                                  follower=follower)

    def _scaled(self, run, delta):
        """The free coordinates of an (N, 6) increment in the scaled norm's units."""
        return delta[run.system.free] * run.weights

    def _matrix(self, run, x, q, lam, ce=None):
        """The Newton matrix at load factor λ: :meth:`NewtonSystem.matrix` at ``t_end`` with its
        configuration-dependent load blocks (taken at λ = 1) scaled by λ."""
        system = run.system
        A = system.matrix(x, q, x, self.t_end, run.mu, 0.0, 0.0, 1.0, ce=ce)
        if not run.follower or lam == 1.0:
            return A
        values = system.work.values
        tf = system.model.time_functions
        for node, code, k, vec in run.follower:
            f = tf_value(tf.kind[k], tf.par[k], self.t_end)
            R = _rotation(q[node])
            if code == 1:  # follower force F = R f: ∂F/∂δθ = −R [f×]
                block, r0 = -R @ _skew(vec), 0
            else:  # dead moment F_θ = Rᵀ M: ∂F/∂δθ = [(RᵀM)×]
                block, r0 = _skew(R.T @ vec), 3
            for a in range(3):
                for b in range(3):
                    values[36 * node + 6 * (r0 + a) + 3 + b] -= (lam - 1.0) * f * block[a, b]
        return system.pattern.matrix(values)

    def _evaluate(self, run, x, q, lam):
        """Evaluate at ``t_end``; returns the residual at λ (N, 6) and the loads F (N, 6) at λ = 1."""
        system = run.system
        run.U = float(system.evaluate(x, q, x, x, x, run.mu, self.t_end, False))
        F = system.work.F
        return system.work.r + (1.0 - lam) * F, F

    def _correct(self, run, x, q, lam, normal):
        """Newton from ``(x, q, run.mu, λ)`` in place; with ``normal`` (scaled, unit: the predictor's
        direction, its last entry the λ part) the load factor is an unknown on the normal plane, else λ is
        fixed.  Returns ``(status, λ, Σ scaled corrections incl. Δλ)``.  The iterations run compiled
        (:func:`reference.algorithms.newton_steps.newton_loop`); Python makes only the SuperLU factorisations
        it asks for (the first, and after the kept pivots went bad) and resumes it."""
        nw = run.newton
        par = nw.fields
        moved = np.zeros(run.system.n_free + 1)
        par["load"] = lam
        code = nw.solve(x, q, run.mu, self.t_end, normal, moved)
        run.history = nw.history()
        run.U = par["U"]
        if code == OK:
            run.iterations = len(run.history) - 1
        return code, par["load"], moved

    def _tangent(self, run, x, q, lam):
        """The tangent ``(δ_F (N,6), μ_F)``: ``K δ_F = F`` at the converged point (raises SingularMatrix)."""
        system = run.system
        _, F = self._evaluate(run, x, q, lam)
        lu = system.slu.factor(self._matrix(run, x, q, lam))
        return system.solve(lu, F.copy(), np.zeros(system.model.n_constraints))

    def advance(self, model, state, run, n_steps, record) -> int:
        x, q, v, w, _ = state[:5]
        clock = state.clock[0]
        system = run.system
        if not run.started:
            v[:] = 0.0
            w[:] = 0.0
            system.work.angle[:] = state.angle
            code, _, _ = self._correct(run, x, q, 0.0, None)
            if code != OK:
                run.stopped_at = 0.0
                return code
            run.problem = start_problem(system, x, q, self.t_end, self.joint_labels)
            if run.problem:
                return SINGULAR
            run.started, clock["t"] = True, 0.0
            run.F = system.work.F.copy()
            run.P = row_forces(system, run.mu)
            self._stability(run, x, q)
        if record is not None:
            U = float(system.evaluate(x, q, x, x, x, run.mu, self.t_end, False))
            system.write_record(record, x, q, v, w, U, state.clock, run.mu)
            run.recorded = (run.lam, run.s, run.iterations, run.negative)
        for _ in range(n_steps):
            if run.done:
                return OK
            code = self._point(run, x, q, clock)
            if code != OK:
                state.angle[:] = system.work.angle
                run.stopped_at = run.lam
                return code
            clock["n"] += 1
            clock["t"] = run.lam
            self._stability(run, x, q)
            run.done = path_end(x, run.lam, self.max_load_factor, self.stop_when)
        state.angle[:] = system.work.angle
        return OK

    def _point(self, run, x, q, clock) -> int:
        """The next converged point (predictor, corrector, arc cuts); updates the run and the work clock."""
        system = run.system
        saved = (x.copy(), q.copy(), run.mu.copy(), system.work.angle.copy())
        ds = run.ds
        run.problem = ()  # kept through the cuts: a jump refused on a longer step explains a failed shorter one
        for _ in range(MAX_CUTS + 1):
            try:
                if run.switch is not None:  # along the critical mode at a bifurcation, Δλ = 0
                    dir_u = self._scaled(run, run.switch)
                    norm = float(np.linalg.norm(dir_u))
                    step_u, step_mu, dlam = run.switch * (ds / norm), np.zeros_like(run.mu), 0.0
                    normal = np.append(dir_u / norm, 0.0)
                elif self.control is not None:  # the controlled coordinate moves by ds, λ follows
                    dF, muF = self._tangent(run, x, q, run.lam)
                    c = run.controlled
                    t_all = self._scaled(run, dF)
                    t_c = t_all[c]
                    if abs(t_c) <= STILL * float(np.linalg.norm(t_all)):
                        run.problem = unmoved(self.control[-1], run.lam)
                        return SINGULAR
                    sgn = math.copysign(1.0, run.previous[c]) if run.previous is not None else math.copysign(1.0, t_c)
                    dlam = sgn * ds / t_c
                    step_u, step_mu = dlam * dF, dlam * muF
                    normal = np.zeros(system.n_free + 1)
                    normal[c] = sgn
                else:
                    dF, muF = self._tangent(run, x, q, run.lam)
                    t_u = self._scaled(run, dF)
                    norm = math.sqrt(float(t_u @ t_u) + 1.0)
                    sgn = 1.0
                    if run.previous is not None and (t_u @ run.previous[:-1] + run.previous[-1]) < 0.0:
                        sgn = -1.0
                    dlam = sgn * ds / norm
                    step_u, step_mu = dlam * dF, dlam * muF
                    normal = np.append(t_u, 1.0) * (sgn / norm)
                code = OK
            except SingularMatrix:
                code = SINGULAR
            if code == OK:
                x += step_u[:, :3]
                qn = np.empty_like(q)
                compose(q, np.ascontiguousarray(step_u[:, 3:]), qn, np.empty(4))
                q[:] = qn
                run.mu += step_mu
                code, lam, moved = self._correct(run, x, q, run.lam + dlam, normal)
                if code == OK and run.switch is None and self.control is None and \
                        float(np.linalg.norm(moved)) > WANDER * ds:
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
                run.peak, run.problem = max(run.peak, abs(lam)), ()
                if self.control is None:
                    factor = math.sqrt(TARGET_ITERATIONS / max(run.iterations, 1))
                    run.ds = min(ds * min(max(factor, 1.0 / GROWTH), GROWTH), MAX_GROWTH * self.arc_length)
                return OK
            x[:], q[:], run.mu[:], system.work.angle[:] = saved
            ds *= 0.5
        return code

    def _work(self, run, x0, q0, x, q, lam):
        """Trapezoidal work of the loads λF and the drives from the last point (last evaluation at the new one)."""
        system = run.system
        dth = np.empty_like(x)
        relative_rotation(q0, q, dth, np.empty(4))
        d = np.concatenate([x - x0, dth], axis=1)
        F1 = lam * system.work.F
        work = 0.5 * float(np.sum((run.lam * run.F + F1) * d))
        run.F = system.work.F.copy()
        P1 = row_forces(system, run.mu)
        return work - 0.5 * float(np.sum((run.P + P1) * d)), P1

    def recorded(self, run) -> dict:
        """The path's datasets at the recorded point (docs/results.md ``/path``)."""
        lam, s, its, count = run.recorded
        return {"path/load_factor": lam, "path/arc_length": s, "path/iterations": float(its),
                "path/negative_eigenvalues": float(count)}

    def finish(self, model, state, run, completed: bool) -> dict:
        """The critical points along the path (none: empty datasets); one warning line when ``branch_switch``
        found no bifurcation to switch at."""
        events = run.events
        if completed and self.branch_switch and not any(e[3] == "bifurcation" for e in events):
            warnings.warn(f"branch_switch = true, but the path met no bifurcation up to load factor {run.lam:.6g}: "
                          "nothing was switched (the path is the primary one)", ModelWarning, stacklevel=2)
        return {"path/critical_load_factor": np.array([e[2] for e in events], dtype=float),
                "path/critical_kind": np.array([e[3] for e in events], dtype=str),
                "path/critical_bracket": np.array([e[:2] for e in events], dtype=float).reshape(-1, 2)}

    def record_last(self, model, state, run, record) -> bool:
        """After a failure: the last converged point, when it is not recorded yet."""
        if not run.started or run.recorded[:2] == (run.lam, run.s):
            return False
        U = float(run.system.evaluate(state.x, state.q, state.x, state.x, state.x, run.mu, self.t_end, False))
        run.system.write_record(record, state.x, state.q, state.v, state.w, U, state.clock, run.mu)
        run.recorded = (run.lam, run.s, run.iterations, run.negative)
        return True


def _stop_when(rd, text, domain) -> tuple:
    """``(node id, component, comparison, value, text)`` of ``solver.stop_when``: one-line DeckError otherwise."""
    example = "e.g. stop_when = \"position.z:beam:end < -1.5\" (a node coordinate, <, <=, > or >=, a number)"
    words = text.split() if isinstance(text, str) else []
    if len(words) != 3 or words[1] not in STOP_OPERATORS:
        raise rd.fail("solver.stop_when", f"expected 'OBSERVABLE OP VALUE', got {text!r}", example)
    try:
        value = float(words[2])
    except ValueError as exc:
        raise rd.fail("solver.stop_when", f"{text!r}: {exc}", example) from None
    node, comp, _ = _coordinate(rd, words[0], "solver.stop_when", domain, example)
    return node, comp, words[1], value, text


def _coordinate(rd, text, entry, domain, example) -> tuple:
    """``(node id, component, text)`` of a node coordinate ``position.C:NODE``: one-line DeckError otherwise."""
    head = text.partition(":")[0] if isinstance(text, str) else ""
    if head not in ("position.x", "position.y", "position.z"):
        raise rd.fail(entry, f"{text!r}: only a node coordinate position.x|y|z:NODE is allowed here", example)
    try:
        label = parse(text, domain).args[0]
    except ObservableError as exc:
        raise rd.fail(entry, f"{text!r}: {exc}", example) from None
    return domain.node(_Names(domain).node(label)).id, "xyz".index(head[-1]), text


def _skew(v) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation(q) -> np.ndarray:
    """The rotation matrix of Euler parameters ``(q0, q1, q2, q3)`` (scalar first)."""
    w, a, b, c = q
    return np.array([[1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b)],
                     [2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a)],
                     [2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)]])
