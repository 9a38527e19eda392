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
tenth of the previous one (modified Newton); otherwise, unless that correction
already meets the convergence test, the matrix is refactored at the current
iterate and the step goes on from there (full Newton if need be).  The convergence test is scaled to the problem (docs/formulation.md §10): Newton
stops when the iterate is balanced — every free residual force below ``tolerance`` times
the step's force scale (the largest free inertial force ``M V̇``, internal force S,
external force F or ``r − S + F``, the joints' and the inertia's forces together;
moments over the model size L) and ``|Φ − ελ|`` below ``tolerance × L`` — judged for the
iterate after the last correction: the imbalance that correction removed times
``θ/(1 − θ)`` for the observed contraction θ of the corrections (Hairer & Wanner 1996,
§IV.8), that imbalance itself while θ is not known.  A residual left at a fraction of
the forces is an error of the accelerations that does not grow as h shrinks; a
correction left below a fixed length δ would be one of ``β'δ ~ δ/h²`` (measured on
Andrews' squeezer, ``models/andrews_squeezer.toml``).  A correction at the round-off of
the coordinates (:data:`reference.algorithms.alpha_steps.ROUNDOFF`) ends it too.  The
initial accelerations and multipliers are consistent: ``M V̇_0 + Bᵀλ_0 = −r_0``,
``B V̇_0 = −d/dt(B V + Φ_t)`` (the last by a central difference along the motion).

Step size (:mod:`reference.algorithms.step_control`, docs/formulation.md §13): a step whose Newton
iteration fails is halved and grows back; with ``error_tolerance`` every step is chosen from the local
error estimate.  The compiled steps (predictor, modified Newton, acceptance, and between two outputs the
step control: estimate, controller, rejection, landing) are :mod:`reference.algorithms.alpha_steps`; this
module makes the factorisations, the step cuts after a Newton failure and the statistics.

Energies: external work by the trapezoidal rule on the step increments (loads,
actuators and drives), damping dissipation by the trapezoidal rule on
``c Vᵀ M V`` plus the force elements' damper power ``Σ c (B_e V)²``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from dataclasses import dataclass, field

from reference.algorithms import alpha_steps as ak
from reference.algorithms.alpha_python_control import controlled_python
from reference.algorithms.alpha_steps import NO_FACTOR, RECOVERABLE, dissipation, power, set_step, steps
from reference.algorithms.base import CallBudget
from reference.algorithms.implicit import ImplicitAlgorithm, NewtonSystem
from reference.linalg import SingularMatrix
from reference.state import Record, RecordView
from reference.algorithms.step_control import DEAD_BAND, MAX_CUTS, SolverStatistics
from reference.status import OK, REFACTOR, SINGULAR, newton_failure
from reference.validation import ModelWarning


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
    ``h`` the first step [s] (then ``par["h_next"]``); ``vd``, ``a`` (N, 6) the accelerations V̇ and the
    algorithmic accelerations; ``lam`` (m,) the multipliers; ``powers`` = [constraint power P, dissipated power D]
    of the last step; ``factors`` the kept LU factor (None: none yet); ``par`` the compiled steps'
    settings, counters and step control (:data:`reference.algorithms.alpha_steps.PAR`; ``fields`` its record as
    Python reads and writes it, :class:`~reference.state.RecordView`: the controller's
    next step, the converged steps since the last cut, the largest step a cut step grows back to — below the
    last that failed, doubled at every output up to ``dt`` —, …); ``arrays`` their work arrays; ``held`` the
    force elements' angles at the step's start (restored after a rejected or failed step); ``started`` whether the consistent initial accelerations
    are computed; ``varying`` whether the step is controlled step by
    step (error control, or a cut step growing back); ``nominal`` the steps of ``dt`` reached (the
    output grid); ``stats`` the
    :class:`~reference.algorithms.step_control.SolverStatistics`; ``row`` its record of the last
    output; ``stopped_at`` the time where a failed step stopped; ``tried`` what was tried then; ``budget`` the
    steps a compiled call may take (:class:`~reference.algorithms.base.CallBudget`: each returns to Python
    within a fraction of a second, so that a signal stops the run).
    """

    system: NewtonSystem
    L: float
    h: float
    vd: np.ndarray | None = None
    a: np.ndarray | None = None
    lam: np.ndarray | None = None
    powers: np.ndarray = field(default_factory=lambda: np.zeros(2))
    factors: tuple | None = None
    par: np.ndarray | None = None
    fields: RecordView | None = None
    arrays: tuple = ()
    held: np.ndarray | None = None
    started: bool = False
    varying: bool = False
    nominal: int = 0
    stats: SolverStatistics = field(default_factory=SolverStatistics)
    row: dict = field(default_factory=dict)
    stopped_at: float | None = None
    tried: str = ""
    history: list = field(default_factory=list)
    budget: CallBudget = field(default_factory=CallBudget)

    @property
    def iterations(self) -> int:
        return self.stats.iterations

    @property
    def factorizations(self) -> int:
        return self.stats.factorizations


TOLERANCE = 1e-9
"""The default Newton tolerance: the imbalance left, relative to the step's forces (module docstring)."""


class GeneralizedAlpha(ImplicitAlgorithm):
    """Lie-group generalized-α (Brüls, Cardona & Arnold 2012) with Newton on the sparse tangent.

    Parameters
    ----------
    dt : float
        Time step h [s] (no stability limit); with ``error_tolerance`` the output grid and, unless
        ``first_step`` is given, the first step.
    rho_inf : float, default 0.8
        Spectral radius at infinite frequency, 0 ≤ ρ∞ ≤ 1 (1: no numerical dissipation).
    tolerance : float, default 1e-9
        Newton stops when the imbalance left after the last correction (estimated, see above)
        is below ``tolerance``: every free residual force below ``tolerance`` × the step's
        largest force [N] (moments [N m] over the model size L) and ``|Φ − ελ|`` below
        ``tolerance`` × L [m]; the same on a cut or error-controlled step.
    max_iterations : int, default 15
        Newton corrections per step before the step is cut.
    error_tolerance : float, optional
        The local error estimate's bound (:mod:`reference.algorithms.step_control`): the step is
        chosen to keep it; None: fixed steps of ``dt``, cut only when Newton fails.
    dt_min, dt_max : float, optional
        Bounds of the controlled step [s] (default ``dt · 2⁻¹⁰`` and the output interval).
    first_step : float, optional
        The first step [s] with ``error_tolerance`` (default ``dt``).
    """

    name = "generalized_alpha"
    deck_required = ("t_end",)
    deck_optional = ("dt", "rho_inf", "tolerance", "max_iterations", "damping", "output_every",
                     "consistent_initial_velocities", "max_steps", "error_tolerance", "dt_min", "dt_max")
    contraction = 0.1
    """Modified Newton: the factor is kept over iterations and steps while each correction is
    below this fraction of the previous one; otherwise the matrix is refactored at the iterate."""
    dead_band = DEAD_BAND
    """The controller's dead band (:func:`reference.algorithms.step_control.kept_step`); 1: none."""
    reuse = 1e-9
    """A new step within this relative change of the factor's step keeps the factor (modified Newton with the
    old coefficients; the contraction test refactors when it converges too slowly): the equal steps landing on
    an output differ by rounding only.  Wider bands save few factorisations and, at tight tolerances, let the
    Newton error left by the slower iteration into the error estimate (docs/formulation.md §13)."""
    python_control = False
    """True: the step control runs in Python around one compiled step per call
    (:func:`reference.algorithms.alpha_python_control.controlled_python`), the oracle the tests compare the
    compiled control with."""

    def __init__(self, dt: float, rho_inf: float = 0.8, tolerance: float = TOLERANCE, max_iterations: int = 15,
                 error_tolerance: float | None = None, dt_min: float | None = None, dt_max: float | None = None,
                 first_step: float | None = None):
        super().__init__(dt, tolerance, max_iterations)
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
        self.rho_inf = float(rho_inf)
        self.alpha_m, self.alpha_f, self.gamma, self.beta = parameters(self.rho_inf)
        self.error_tolerance = None if error_tolerance is None else float(error_tolerance)
        self.dt_min = float(dt_min) if dt_min else self.dt * 0.5**MAX_CUTS
        self.dt_max = float(dt_max) if dt_max else math.inf
        self.first_step = float(first_step) if first_step else self.dt
        if self.dt_min > self.dt_max:
            raise ValueError(f"dt_min = {self.dt_min:g} is above dt_max = {self.dt_max:g}")

    @classmethod
    def deck_keys(cls, solver: dict) -> tuple[tuple, tuple]:
        """``dt`` is required, unless ``error_tolerance`` is given (the algorithm then chooses the step)."""
        return ("t_end",) if "error_tolerance" in solver else ("dt", "t_end"), cls.deck_optional

    @classmethod
    def deck_settings(cls, rd, solver: dict, domain) -> dict:
        """``error_tolerance`` (> 0), ``dt_min`` and ``dt_max`` (> 0, ``dt_min ≤ dt_max``) [s]."""
        settings = {key: rd.number(solver[key], f"solver.{key}", positive=True)
                    for key in ("error_tolerance", "dt_min", "dt_max") if key in solver}
        if settings.get("dt_min", 0.0) > settings.get("dt_max", math.inf):
            raise rd.fail("solver.dt_min", f"dt_min = {settings['dt_min']:g} is above dt_max = {settings['dt_max']:g}",
                          "give dt_min ≤ dt_max")
        return settings

    @staticmethod
    def step_bounds(settings, dt_max: bool) -> tuple[str, str, str] | None:
        """``(entry, problem, fix)`` when the step bounds of ``settings`` would be ignored, else None: ``dt_max``
        (``dt_max`` True: given) only bounds the step ``error_tolerance`` chooses; with it, ``dt_min`` above the
        output interval (every output is landed on, so no step can reach it), and without it, ``dt_min`` not below
        ``dt`` (the step cuts halve ``dt`` down to it)."""
        interval = settings.dt * settings.output_every
        if settings.error_tolerance is None:
            if dt_max:
                return ("solver.dt_max", "dt_max bounds the step that error_tolerance chooses; without "
                        f"error_tolerance every step is dt = {settings.dt:g}", "give error_tolerance, or leave dt_max out")
            if settings.dt_min is not None and settings.dt_min >= settings.dt:
                return ("solver.dt_min", f"dt_min = {settings.dt_min:g} is not below dt = {settings.dt:g}: without "
                        "error_tolerance it bounds the step cuts, which halve dt",
                        f"give dt_min < dt (default dt/1024 = {settings.dt / 1024:g}), or leave it out")
        elif settings.dt_min is not None and settings.dt_min > interval * (1.0 + 1e-12):
            return ("solver.dt_min", f"dt_min = {settings.dt_min:g} is above the output interval output_every × dt = "
                    f"{interval:g} s (the steps land on every output)",
                    f"give dt_min ≤ {interval:g} (default {interval / 1024:g}), or a coarser output grid")
        return None

    @classmethod
    def deck_check(cls, rd, solver: dict, settings) -> None:
        """:meth:`step_bounds` as a one-line error; ``dt`` with ``error_tolerance`` and ``output_every = 1`` is warned
        of (the step never exceeds the output interval ``dt``: the control can only shorten it)."""
        problem = cls.step_bounds(settings, "dt_max" in solver)
        if problem:
            raise rd.fail(*problem)
        interval = settings.dt * settings.output_every
        if settings.error_tolerance is not None and "dt" in solver and settings.output_every == 1 and \
                (settings.dt_max is None or settings.dt_max > interval):
            warnings.warn(f"solver.error_tolerance: with dt = {settings.dt:g} and output_every = 1 no step exceeds "
                          f"the output interval {interval:g} s (the steps land on every output), so the control "
                          "can only shorten dt; leave dt out, or raise output_every, to let the step grow",
                          ModelWarning, stacklevel=2)

    @classmethod
    def from_settings(cls, settings, dt=None):
        """The algorithm of ``settings`` (Python API and deck); ValueError of :meth:`step_bounds`'s line when the
        step bounds would be ignored."""
        problem = cls.step_bounds(settings, settings.dt_max is not None) if dt is None else None
        if problem:
            raise ValueError(f"{problem[0]}: {problem[1]}; {problem[2]}")
        return cls(dt or settings.dt, settings.rho_inf, settings.tolerance or TOLERANCE, settings.max_iterations or 15,
                   settings.error_tolerance, settings.dt_min, settings.dt_max, settings.first_step)

    def start(self, model, state, critical_step=None, guard=None) -> GeneralizedAlphaRun:
        """A run from ``state``: the Newton system; the initial accelerations are computed by the first
        :meth:`advance`."""
        h = self.dt if self.error_tolerance is None else min(max(self.first_step, self.dt_min), self.dt_max)
        run = GeneralizedAlphaRun(self.newton_system(model), self.length_scale(state.x), h)
        run.stats.controlled = self.error_tolerance is not None
        return run

    def _initial_accelerations(self, run, state) -> int:
        """Consistent initial accelerations and multipliers at the state's time."""
        system = run.system
        model = system.model
        x, q, v, w, f_prev = state[:5]
        clock = state.clock[0]
        N, m = x.shape[0], model.n_constraints
        t = clock["t"]
        system.work.angle[:] = state.angle  # the force elements' continuous angles
        h = run.h
        bp = (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
        try:
            vd, lam = system.consistent_accelerations(x, q, v, w, t, 1e-3 * h, ce=bp)
        except SingularMatrix:
            run.tried = "at the initial accelerations"
            return SINGULAR
        run.vd, run.a, run.lam = vd, vd.copy(), lam
        system.evaluate(x, q, v, w, vd, lam, t, True)
        f_prev[:] = system.work.F
        run.powers = np.array([power(model, system.work.Bl, lam, v, w),
                               dissipation(model, v, w) + system.work.fe_out[0]])
        n = system.pattern.n
        run.arrays = tuple(np.zeros((N, 6)) for _ in range(7)) + (
            np.zeros(m), np.zeros(m), np.zeros(n), np.zeros(n), np.zeros(n),
            np.zeros((N, 3)), np.zeros((N, 4)), np.zeros(4), np.zeros((N, 3)))
        run.held = np.zeros_like(system.work.angle)
        run.par = ak.new_par(h=run.h, alpha_m=self.alpha_m, alpha_f=self.alpha_f, gamma=self.gamma, beta=self.beta,
                             tolerance=self.tolerance, L=run.L, contraction=self.contraction,
                             max_iterations=self.max_iterations, U=np.nan, t0=t, n0=clock["n"], dt=self.dt,
                             h_next=run.h, dt_min=self.dt_min, dt_max=self.dt_max,
                             error_tolerance=self.error_tolerance or 0.0, ceiling=math.inf, dead_band=self.dead_band,
                             reuse=self.reuse, h_factor=run.h)
        run.fields = RecordView(run.par)
        run.varying = self.error_tolerance is not None or run.h != self.dt
        run.nominal = int(round(t / self.dt))
        run.started = True
        return OK

    def advance(self, model, state, run, n_steps, record) -> int:
        system = run.system
        x, q, v, w, f_prev = state[:5]
        clock = state.clock[0]
        if not run.started:
            run.stopped_at = None
            code = self._initial_accelerations(run, state)
            if code != OK:
                run.stopped_at = clock["t"]
                return code
        par = run.fields
        left = int(n_steps)
        rec = Record.empty(x.shape[0], model.n_constraints) if record is None else record
        if record is not None:
            r = system.work.r[system.free]
            run.row = run.stats.output(par["h"], math.sqrt(r @ r))
            if left > 0 and math.isfinite(par["U"]):
                # the last Newton evaluation of the previous step is this state within the
                # tolerance: the compiled steps write the record from it before stepping
                par["record"] = 1.0
            else:
                U = par["U"] if np.isfinite(par["U"]) else system.evaluate(x, q, v, w, run.vd, run.lam, clock["t"], True)
                system.write_record(record, x, q, v, w, U, state.clock, run.lam)
        par["iterations"] = 0.0
        if run.varying:
            code = self._controlled(state, run, left, rec)
        else:
            code, done = self._steps(state, run, left, rec)
            run.nominal += done
            run.stats.steps += done
            if done:
                h = par["h"]
                run.stats.h_min, run.stats.h_max = min(run.stats.h_min, h), max(run.stats.h_max, h)
            if code in RECOVERABLE:
                code = self._cut(state, run, code)
                if code == OK:
                    code = self._controlled(state, run, left - done, rec)
        state.angle[:] = system.work.angle
        run.stats.iterations += int(par["iterations"])
        if code != OK:
            run.factors = None
            par["resume"] = 0.0
            run.stopped_at = clock["t"]
        return code

    def _steps(self, state, run, n_steps, rec) -> tuple[int, int]:
        """Up to ``n_steps`` compiled steps (in a controlled mode: tries to the output time ``par["target"]``), the
        Newton matrix factored when they ask, in calls of at most ``run.budget`` steps (each returns to Python
        within a fraction of a second: a signal stops the run between two); returns (status, steps done)."""
        system, par, budget = run.system, run.fields, run.budget
        x, q, v, w, f_prev = state[:5]
        clock = state.clock[0]
        control = par["control"] != ak.FIXED
        # the kernel's arguments before and after the two that change between its calls
        first = (system.arg, x, q, v, w, run.vd, run.a, run.lam, state.clock, f_prev, run.powers, system.dof, run.par)
        last = (system.wt, run.arrays, system.record_arg(rec), run.held)
        left, done = n_steps, 0
        while left > 0:
            if run.factors is None:
                par["fresh"] = -1.0  # only predict: the factor is made at the predictor
            size = min(left, budget.start())
            code, n = steps(*first, size, NO_FACTOR if run.factors is None else run.factors, *last)
            budget.took(n)
            left -= n
            done += n
            if code == OK:
                if control and clock["t"] == par["target"]:
                    return OK, done  # landed on the output time
                continue
            if code != REFACTOR:
                return code, done
            arr, h = run.arrays, par["h"]
            bp = (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
            ck, cc = 1.0 / bp, (self.gamma / (h * self.beta)) / bp
            try:
                run.factors = system.factor(arr[12], arr[13], np.ascontiguousarray(arr[1][:, 3:]), clock["t"] + h,
                                            arr[7], 1.0, cc, ck, psi=np.ascontiguousarray(h * arr[0][:, 3:]))
            except SingularMatrix:
                return SINGULAR, done
            run.stats.factorizations += 1
            par["fresh"] = 1.0  # the interrupted step resumes with a fresh factor
            par["h_factor"] = h
        return OK, done

    def _cut(self, state, run, code) -> int:
        """Halve the step after a failed one (its iterate is dropped; the state is the last converged);
        the failure's code when the step would fall below ``dt_min``."""
        par, stats = run.fields, run.stats
        run.factors = None
        par["resume"] = 0.0
        h = par["h"] * 0.5
        if h < self.dt_min * (1.0 - 1e-12):
            run.tried = (f"with the step cut from {self.dt:g} to {par['h']:g} s"
                         if self.error_tolerance is None else f"with the step at dt_min = {self.dt_min:g} s")
            return code
        stats.cuts += 1
        par["good"] = 0.0
        par["ceiling"] = h  # the step grows back to below the one that failed, until the next output
        run.varying = True
        par["h_next"] = h
        return OK

    def _controlled(self, state, run, n_steps, rec) -> int:
        """Steps to the output time ``n_steps`` steps of ``dt`` ahead, each chosen by the error control
        or growing back after a cut (:mod:`reference.algorithms.step_control`), the last landing on it: many
        compiled steps per call (:func:`steps`), the factorisations and the step cuts here."""
        if self.python_control:
            return controlled_python(self, state, run, n_steps, rec)
        par, angle = run.fields, run.system.work.angle
        par["control"] = ak.GROWING if self.error_tolerance is None else ak.ERROR_CONTROL
        par["target"] = (run.nominal + n_steps) * self.dt
        par["after_rejection"] = 0.0
        while True:
            code, _ = self._steps(state, run, 1 << 62, rec)
            self._collect(run)
            if code == OK:
                break
            angle[:] = run.held  # as at the failed step's start
            if code not in RECOVERABLE:
                return code
            code = self._cut(state, run, code)
            if code != OK:
                return code
        self._landed(state, run, n_steps)
        return OK

    def _collect(self, run) -> None:
        """The compiled steps' statistics (:data:`reference.algorithms.alpha_steps.PAR`) into ``run.stats``."""
        par, stats = run.fields, run.stats
        stats.steps += int(par["accepted"])
        stats.rejected += int(par["rejected"])
        stats.over += int(par["over"])
        stats.h_min, stats.h_max = min(stats.h_min, par["h_min"]), max(stats.h_max, par["h_max"])
        err = par["error"]
        if err == err:
            stats.error = err if stats.error != stats.error else max(stats.error, err)
            stats.worst = max(stats.worst, err)
        ak.clear_statistics(par)

    def _landed(self, state, run, n_steps) -> None:
        """The output time ``n_steps`` steps of ``dt`` ahead is reached: the cut step's ceiling doubles, and a
        step grown back to ``dt`` returns to the fixed steps."""
        par, clock = run.fields, state.clock[0]
        run.nominal += n_steps
        par["ceiling"] = min(2.0 * par["ceiling"], self.dt)
        if self.error_tolerance is None and par["h_next"] == self.dt:
            set_step(par, self.dt, clock["t"], clock["n"])  # back to the fixed steps
            par["control"] = ak.FIXED
            run.varying = False

    def recorded(self, run) -> dict:
        """The solver statistics of the steps up to each output (:mod:`reference.algorithms.step_control`)."""
        return run.row

    def summary(self, run) -> str:
        return run.stats.summary()

    def finish(self, model, state, run, completed: bool) -> dict:
        """No datasets; one warning when steps at ``dt_min`` were accepted over the error tolerance
        (:func:`reference.algorithms.step_control.rejected`)."""
        stats = getattr(run, "stats", None)
        if stats is not None and stats.over:
            warnings.warn(f"{stats.over:,} step{'s' * (stats.over != 1)} at dt_min = {self.dt_min:g} s "
                          f"{'were' if stats.over != 1 else 'was'} accepted over error_tolerance = "
                          f"{self.error_tolerance:g} (error estimate up to {stats.worst:.3g} × the tolerance; "
                          "/solver/steps_over_tolerance counts them per output): lower dt_min, or raise "
                          "error_tolerance", ModelWarning, stacklevel=2)
        return {}

    def failure(self, code: int, state, run) -> tuple[str, str]:
        """``(status, message)``, saying what was tried (step cuts, dt_min) and what to change."""
        t = run.stopped_at if run.stopped_at is not None else state.t
        if code == SINGULAR and run.tried:
            status, message = super().failure(code, state, run)
            return status, message.replace(f"at t = {t:.6g}", f"at t = {t:.6g} {run.tried}", 1)
        fix = ("Lower dt_min or raise max_iterations; if the step shrinks at one instant, look for an impact, "
               "a lock-up or a load jump there." if self.error_tolerance is not None else
               "The motion may need a smaller dt from the start, or raise max_iterations; error_tolerance lets "
               "the step follow the motion.")
        return newton_failure(code, f"t = {t:.6g}", self.max_iterations, run.tried, fix)
