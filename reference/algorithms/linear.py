"""Linearised analyses: vibration modes and linear buckling (``algorithm = "modes"``, ``"buckling"``).

They take no time step.  Each reaches the configuration it linearises about — the initial state
(``about = "reference"``), the end of the static algorithm's load path (``about = "static"`` and
buckling: :class:`~reference.algorithms.static.Static` with the deck's ``t_end`` and ``load_steps``,
its stability indicator included), or the relative equilibrium of the whole model spinning at
``spin_rate`` about ``spin_axis`` through ``spin_point`` (``about = "rotation"``:
:func:`reference.algorithms.linearization.at_steady_rotation`, the modes in the spinning frame) — and then, in
:meth:`LinearAnalysis.finish`, linearises there (:mod:`reference.algorithms.linearization`) and solves the
eigenproblem (:mod:`reference.modal`).  The solution loop (:func:`reference.solution.run`) treats them
like any algorithm: the records of the path (one record for the reference or spinning state) and, at the end, the analysis's datasets (docs/results.md):

- modes: ``/modes/frequency`` [Hz], ``/modes/damping_ratio``, ``/modes/omega_squared`` [rad²/s²],
  ``/modes/root`` (k, 2) the roots s (real, imaginary) [1/s], ``/modes/kind`` (``elastic``, ``zero``,
  ``unstable``), ``/modes/shape`` (k, N, 6) mass-normalised, ``/modes/shape_imaginary`` (damped or
  gyroscopic), ``/modes/zero_modes``, ``/modes/mobility``, ``/modes/constraint_rank``,
  ``/modes/coordinates``, ``/modes/time``;
- buckling: ``/buckling/load_factor``, ``/buckling/shape`` (k, N, 6) with ``max |φ| = 1``,
  ``/buckling/time``, ``/buckling/reference``.

Load factor of buckling: the loads ``F(0) + μ (F(t_end) − F(0))``, ``K_g = K_T(t_end) − K_T(0)``
(docs/formulation.md §11: why the secant from the two equilibria, and what it misses).  When neither the
loads nor the drives change from t = 0 to ``t_end`` (constant loads: that increment is zero, and its
secant round-off), the loads at ``t_end`` are the reference: ``μ F(t_end)``, ``K_g = K_T(t_end) − K_T``
of the unloaded equilibrium (:meth:`Buckling.unloaded`).

A user error found only once the configuration is known (more modes than independent coordinates, a
buckling analysis of an unrestrained model or of one that nothing loads) ends the run with a one-line
status and message (:meth:`LinearAnalysis.failure`), the records of the path kept; more modes than
independent coordinates is found before the path, at the initial configuration.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from reference.algorithms.base import Algorithm
from reference.algorithms.implicit import ImplicitAlgorithm, NewtonSystem
from reference.algorithms.static import Static, StaticRun
from reference.algorithms import linearization
from reference.linalg import SingularMatrix, null_space
from reference.modal import buckling, modes
from reference.state import State
from reference.status import NO_CONVERGENCE, OK, SINGULAR
from reference.validation import ModelWarning

EQUILIBRIUM = 1e-6
"""Modes about the reference state: the state is an equilibrium of the loads at t = 0 when the largest
unbalanced generalised force ``|S − F + Bᵀλ|`` (free coordinates, λ consistent with the accelerations) is
below this fraction of the largest internal or external one; round-off leaves about 1e-12 of it at a
hanging pendulum's equilibrium, a load the structure does not yet carry leaves 1 (the whole load)."""


@dataclass
class LinearRun:
    """A linearised analysis's run state: the Newton system, the static path's run (None about the
    reference), the multipliers of the configuration, the equilibrium ``(x, q, λ, t)`` at the start of a
    path (``initial``), and ``started``; ``problem`` and ``failed`` the message and status of a refused
    analysis, ``analysis`` its datasets once computed, ``unloaded`` the deck's initial state (a path's)."""

    system: NewtonSystem
    path: StaticRun | None
    lam: np.ndarray | None = None
    initial: tuple | None = None
    started: bool = False
    stopped_at: float | None = None
    spinning: linearization.Linearization | None = None
    problem: str = ""
    failed: str = ""
    analysis: dict | None = None
    unloaded: State | None = None


class LinearAnalysis(Algorithm):
    """Base of the linearised analyses: the path to the configuration, the records, the refusal.

    Parameters
    ----------
    n_modes : int
        How many modes (or buckling factors) to compute, the lowest.
    path : Static or None
        The static algorithm whose end state is linearised (None: the initial state).
    """

    explicit = False
    linearised = True
    spin = None
    """``(spin_rate, spin_axis, spin_point, Newton settings)`` of modes about a steady rotation (:class:`Modes`),
    else None."""

    def __init__(self, n_modes: int, path: Static | None = None):
        if int(n_modes) < 1:
            raise ValueError(f"modes must be a positive integer, got {n_modes!r}")
        self.n_modes = int(n_modes)
        self.path = path
        self.dt = path.dt if path is not None else math.inf

    def refusal(self, model) -> str | None:
        """Master/slave joints (as the implicit algorithms), no free coordinate, more modes than free
        coordinates (more than independent ones, free less the rank of B, is refused when the
        configuration is known, by :meth:`analyse`)."""
        problem = ImplicitAlgorithm.refusal(model)
        if problem:
            return problem
        free = int(np.sum(model.nodes.free > 0.5))
        if free == 0:
            return "the model has no free coordinates (every node is fixed): there is nothing to linearise"
        if self.n_modes > free:
            return f"{self.n_modes} modes asked of a model with {free} free coordinates; ask at most {free}"
        return None

    def n_steps(self, t_end: float) -> int:
        return self.path.n_steps(t_end) if self.path is not None else 0

    def start(self, model, state, critical_step=math.inf, guard=None) -> LinearRun:
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        if self.path is not None:
            path = self.path.start(model, state)
            return LinearRun(path.system, path)
        return LinearRun(NewtonSystem(model), None)

    def advance(self, model, state, run, n_steps, record) -> int:
        """The path's steps (its first call checks the number of modes and keeps the equilibrium at t = 0);
        about the reference, the consistent multipliers and the one record.  A call without steps after
        the path (the solution loop's last), or about the reference, also makes the analysis (:meth:`analyse`):
        a refusal there ends the run with :meth:`failure`'s one line."""
        if run.path is not None:
            if not run.path.started:
                if self._too_many(model, state, run):
                    return NO_CONVERGENCE
                run.unloaded = state.copy()
                code = self.path.advance(model, state, run.path, 0, record)
                if code != OK:
                    return code
                run.initial = (state.x.copy(), state.q.copy(), run.path.lam.copy(), state.t)
                if n_steps == 0:
                    return OK
                record = None
            code = self.path.advance(model, state, run.path, n_steps, record)
            return self._analysis(model, state, run) if code == OK and n_steps == 0 else code
        system = run.system
        if not run.started and self._too_many(model, state, run):
            return NO_CONVERGENCE
        if not run.started and self.spin is not None:
            try:
                lin = linearization.at_steady_rotation(model, state, *self.spin[:3], system=system, **self.spin[3])
            except ValueError as exc:
                run.problem, run.failed, run.stopped_at = str(exc), "failed: no steady rotation", state.t
                return NO_CONVERGENCE
            state.x[:], state.q[:], state.v[:], state.w[:] = lin.x, lin.q, lin.v, lin.w
            run.spinning, run.lam, run.started = lin, lin.lam, True
        if not run.started:
            system.work.angle[:] = state.angle
            try:
                _, run.lam = system.consistent_accelerations(state.x, state.q, state.v, state.w, state.t,
                                                             1e-6, ce=1.0)
            except SingularMatrix:
                run.stopped_at = state.t
                return SINGULAR
            run.started = True
            _reference_warning(system, state, run.lam)
        if record is not None:
            x, q, v, w = state.x, state.q, state.v, state.w
            U = system.evaluate(x, q, v, w, np.zeros((x.shape[0], 6)), run.lam, state.t, True)
            system.write_record(record, x, q, v, w, U, state.clock, run.lam)
        return self._analysis(model, state, run) if n_steps == 0 else OK

    def _too_many(self, model, state, run) -> bool:
        """More modes asked than the model's independent coordinates at ``state`` (the free ones less the rank
        of the joints' Jacobian; the rank is computed only when the constraints could matter): the
        refusal is kept in ``run`` (:meth:`failure`)."""
        free, m = run.system.n_free, model.n_constraints
        if self.n_modes <= free - m:
            return False
        lin = linearization.linearize(model, state.x, state.q, None, None, None, state.t, state.angle, run.system)
        rank = null_space(lin.B)[1]
        if self.n_modes <= free - rank:
            return False
        self._refuse(run, f"{self.n_modes} {'buckling ' if self.name == 'buckling' else ''}modes asked of a model "
                          f"with {free - rank} independent coordinates ({free} free less {rank} independent "
                          f"constraints) at t = {state.t:g}; ask at most {free - rank}", state.t)
        return True

    def _refuse(self, run, problem: str, t: float) -> None:
        run.problem, run.stopped_at = problem, t
        run.failed = f"failed: {self.name} refused: {problem.split(';')[0].split(':')[0]}"[:200]

    def _analysis(self, model, state, run) -> int:
        """:meth:`analyse` once; a ValueError (a user error only the configuration shows) → a failed run."""
        if run.analysis is None and not run.problem:
            try:
                run.analysis = self.analyse(model, state, run)
            except ValueError as exc:
                self._refuse(run, str(exc), state.t)
                return NO_CONVERGENCE
        return NO_CONVERGENCE if run.problem else OK

    def failure(self, code: int, state, run) -> tuple[str, str]:
        if run.problem:
            kept = "; the records of the path are kept" if run.path is not None and run.path.started else ""
            return run.failed, run.problem + kept
        if run.path is not None:
            return self.path.failure(code, state, run.path)
        return ("failed: singular constraints at the reference state",
                "the constraint Jacobian at the initial state is singular (redundant, unregularised joints): "
                "the multipliers cannot be found; regularise the joints (epsilon > 0) or remove the redundancy")

    def recorded(self, run) -> dict:
        return self.path.recorded(run.path) if run.path is not None else {}

    def multipliers(self, run) -> np.ndarray:
        return run.path.lam if run.path is not None else run.lam

    def finish(self, model, state, run, completed: bool) -> dict:
        """The path's datasets and, when it completed, the analysis's (:meth:`analyse`)."""
        datasets = self.path.finish(model, state, run.path, completed) if run.path is not None else {}
        if completed:
            datasets.update(run.analysis if run.analysis is not None else self.analyse(model, state, run))
        return datasets

    def analyse(self, model, state, run) -> dict:
        raise NotImplementedError


class Modes(LinearAnalysis):
    """Vibration modes about the reference state, a static equilibrium or a steady rotation
    (``algorithm = "modes"``).

    Undamped modes when the reduced damping is zero and the stiffness symmetric, else the damped or
    gyroscopic quadratic problem (:func:`reference.modal.modes`).  Zero modes are counted among the
    lowest ``modes + mobility`` and compared with the mobility (:func:`reference.algorithms.linearization.mobility`):
    more zero modes than rigid and mechanism motions is warned about (a direction without stiffness).
    """

    name = "modes"
    deck_required = ("modes",)
    deck_optional = ("about", "t_end", "load_steps", "tolerance", "max_iterations", "output_every", "max_steps",
                     "spin_rate", "spin_axis", "spin_point")
    STATIC_KEYS = ("t_end", "load_steps")
    SPIN_KEYS = ("spin_rate", "spin_axis")

    def __init__(self, n_modes: int, path: Static | None = None, spin: tuple | None = None):
        super().__init__(n_modes, path)
        self.spin = spin

    @classmethod
    def deck_keys(cls, solver: dict) -> tuple[tuple, tuple]:
        """The keys of ``[solver]`` for its ``about``: the static algorithm's with ``"static"``, the spin's
        with ``"rotation"``."""
        about = solver.get("about", "reference")
        if about == "static":
            return cls.deck_required + cls.STATIC_KEYS, ("about",) + Static.deck_optional
        if about == "rotation":
            return cls.deck_required + cls.SPIN_KEYS, ("about", "spin_point", "tolerance", "max_iterations")
        return cls.deck_required, ("about",)

    @classmethod
    def deck_settings(cls, rd, solver: dict, domain) -> dict:
        """``spin_rate``, ``spin_axis`` (nonzero; normalised) and ``spin_point`` of modes about a rotation."""
        if "spin_rate" not in solver:
            return {}
        axis = rd.direction(solver["spin_axis"], "solver.spin_axis")
        return {"spin_rate": rd.number(solver["spin_rate"], "solver.spin_rate"),
                "spin_axis": tuple(axis / np.linalg.norm(axis)),
                "spin_point": tuple(rd.vector(solver.get("spin_point", [0.0, 0.0, 0.0]), "solver.spin_point"))}

    @classmethod
    def from_settings(cls, settings, dt=None):
        path = Static.from_settings(settings, dt) if settings.about == "static" else None
        newton = {k: v for k, v in (("tolerance", settings.tolerance), ("max_iterations", settings.max_iterations))
                  if v is not None}
        spin = ((settings.spin_rate, settings.spin_axis, settings.spin_point, newton) if settings.about == "rotation"
                else None)
        return cls(settings.modes, path, spin)

    def analyse(self, model, state, run) -> dict:
        if run.spinning is not None:
            lin = run.spinning
        else:
            lin = linearization.linearize(model, state.x, state.q, state.v, state.w, self.multipliers(run), state.t,
                                          state.angle, run.system)
        red = linearization.reduce(lin)
        size = red.M.shape[0]
        if self.n_modes > size:
            raise ValueError(f"{self.n_modes} modes asked of a model with {size} independent coordinates "
                             f"({lin.n_free} free less {red.rank} independent constraints); ask at most {size}")
        movable = linearization.mobility(model, lin)
        found = modes(red.M, red.D, red.K, min(self.n_modes + movable, size))
        zero = int(np.sum(found.kind == "zero"))
        if zero > movable:
            warnings.warn(f"{zero} zero modes, but the joints and fixed coordinates allow only {movable} rigid-body "
                          "or mechanism motions: some direction has no stiffness (an unsupported node, a zero "
                          "stiffness)", ModelWarning, stacklevel=2)
        k = self.n_modes
        shapes = lin.nodal((red.Z @ found.phi[:, :k]).T)
        out = {"modes/frequency": found.frequency[:k], "modes/damping_ratio": found.damping_ratio[:k],
               "modes/omega_squared": found.omega2[:k], "modes/root": np.stack([found.s.real, found.s.imag], 1)[:k],
               "modes/kind": found.kind[:k].astype(str), "modes/shape": shapes.real,
               "modes/zero_modes": np.int64(zero), "modes/mobility": np.int64(movable),
               "modes/constraint_rank": np.int64(red.rank), "modes/coordinates": np.int64(size),
               "modes/time": np.float64(state.t)}
        if self.spin is not None:
            out["modes/spin_rate"] = np.float64(self.spin[0])
        if found.damped:
            out["modes/shape_imaginary"] = shapes.imag
        return out

    def table(self, results) -> list[str]:
        """Mode, frequency [Hz], damping ratio, kind; then the zero modes against the mobility."""
        f, zeta, kind = (results.data(f"modes/{k}") for k in ("frequency", "damping_ratio", "kind"))
        lines = [f"{'mode':>4}  {'frequency [Hz]':>15}  {'damping ratio':>13}  kind"]
        lines += [f"{k + 1:>4}  {f[k]:>15.6g}  {zeta[k]:>13.4g}  {kind[k]}" for k in range(len(f))]
        zero, movable, size = (int(results.data(f"modes/{k}")) for k in ("zero_modes", "mobility", "coordinates"))
        about = f"t = {float(results.data('modes/time')):g}"
        spin = np.asarray(results.data("modes/spin_rate"))
        if spin.ndim == 0:  # a steady rotation (else the missing dataset's NaN per output)
            about = f"the steady rotation at {float(spin):g} rad/s (spinning frame)"
        lines.append(f"{zero} zero mode{'s' if zero != 1 else ''} (rigid-body or mechanism); mobility {movable}; "
                     f"{size} independent coordinates; about {about}")
        return lines


class Buckling(LinearAnalysis):
    """Linear buckling about the pre-stressed state of the deck's loads (``algorithm = "buckling"``).

    The static path from the equilibrium at t = 0 to ``t_end`` (load factor 1: the loads at ``t_end``),
    then ``(K_0 + μ K_g) φ = 0`` with ``K_g = K_T(t_end) − K_T(0)`` reduced to the null space of B at
    ``t_end`` (:func:`reference.modal.buckling`).  When the loads and drives at ``t_end`` are those at
    t = 0 (constant loads, the natural way to write a reference load), ``K_0`` is the tangent of the
    unloaded equilibrium instead (:meth:`unloaded`) and μ multiplies the whole loads at ``t_end``; with no
    load at ``t_end`` either, the analysis is refused.
    """

    name = "buckling"
    deck_required = ("modes",)
    deck_optional = ("t_end", "load_steps", "tolerance", "max_iterations", "output_every", "max_steps")

    NOTHING = ("no load at t_end, and neither the loads nor the drives change from t = 0 to t_end: nothing loads "
               "the structure; give the reference load (a [[loads]] entry, gravity or a prescribed displacement) at "
               "t_end")

    @classmethod
    def from_settings(cls, settings, dt=None):
        return cls(settings.modes, Static.from_settings(settings, dt))

    def refusal(self, model) -> str | None:
        """:meth:`LinearAnalysis.refusal`, and a model without loads, gravity, actuators or drives."""
        problem = super().refusal(model)
        if problem:
            return problem
        if (not np.any(model.loads.vec != 0.0) and not np.any(model.gravity != 0.0)
                and not np.any(model.force_elements.tf >= 0) and not np.any(model.joints.drive != 0)):
            return "the model has no load, gravity, actuator or drive: " + self.NOTHING.split(": ", 1)[1]
        return None

    def analyse(self, model, state, run) -> dict:
        x0, q0, lam0, t0 = run.initial
        lin1 = linearization.linearize(model, state.x, state.q, None, None, self.multipliers(run), state.t,
                                       state.angle, run.system)
        red = linearization.reduce(lin1)
        if self.n_modes > red.M.shape[0]:
            raise ValueError(f"{self.n_modes} buckling modes asked of a model with {red.M.shape[0]} independent "
                             f"coordinates; ask at most {red.M.shape[0]}")
        if _loads_change(run.system, lin1, t0):
            reference = "increment"
            lin0 = linearization.linearize(model, x0, q0, None, None, lam0, t0, state.angle, run.system)
        else:
            if not np.any(lin1.F[run.system.free] != 0.0):
                raise ValueError(self.NOTHING)
            reference = "loads"
            lin0 = self.unloaded(model, run)
        K0 = (red.Z.T @ lin0.K @ red.Z).tocsr()
        mu, phi = buckling(K0, red.K, self.n_modes)
        return {"buckling/load_factor": mu, "buckling/shape": lin1.nodal((red.Z @ phi).T),
                "buckling/time": np.float64(state.t), "buckling/reference_time": np.float64(t0),
                "buckling/reference": np.array(reference)}

    def unloaded(self, model, run) -> linearization.Linearization:
        """The linearisation at the equilibrium without loads: the model with its loads, gravity and actuators
        set to zero, solved by the static algorithm at the deck's initial time from its initial state (its
        drives kept).  Raises ValueError when that equilibrium is not found."""
        loads = model.loads._replace(vec=np.zeros_like(model.loads.vec))
        actuators = model.force_elements._replace(tf=np.full_like(model.force_elements.tf, -1))
        bare = model._replace(loads=loads, gravity=np.zeros_like(model.gravity), force_elements=actuators)
        static = Static(self.path.dt, self.path.tolerance, self.path.max_iterations)
        state = run.unloaded.copy()
        path = static.start(bare, state)
        code = static.advance(bare, state, path, 0, None)
        if code != OK:
            raise ValueError("the equilibrium without the loads (the reference of constant loads) was not found: "
                             + static.failure(code, state, path)[1])
        return linearization.linearize(bare, state.x, state.q, None, None, path.lam, state.t, state.angle, path.system)

    def table(self, results) -> list[str]:
        """Mode and load factor (the loads at t_end, their increment from t = 0 or the whole loads, times the
        factor)."""
        mu = results.data("buckling/load_factor")
        t1, t0 = float(results.data("buckling/time")), float(results.data("buckling/reference_time"))
        lines = [f"{'mode':>4}  {'load factor':>12}"] + [f"{k + 1:>4}  {mu[k]:>12.6g}" for k in range(len(mu))]
        whole = str(np.asarray(results.data("buckling/reference"))) == "loads"
        lines.append(f"load factor 1: the loads at t = {t1:g} "
                     + ("(the whole loads: they do not change from t = " if whole else "(the increment from t = ")
                     + f"{t0:g}); {len(mu)} positive factor{'s' if len(mu) != 1 else ''} found")
        return lines


def _loads_change(system, lin, t0: float) -> bool:
    """Whether the loads (on the free coordinates) or the drives' constraint values at the configuration of
    ``lin`` differ between ``t0`` and its time: the same evaluation at the two times, compared exactly (equal
    time-function values give equal numbers)."""
    N = lin.x.shape[0]
    zero = np.zeros((N, 3))
    system.evaluate(lin.x, lin.q, zero, zero, np.zeros((N, 6)), lin.lam, t0, False)
    F0, PHI0 = system.work.F[system.free], system.work.PHI.copy()
    system.evaluate(lin.x, lin.q, zero, zero, np.zeros((N, 6)), lin.lam, lin.t, False)
    return not (np.array_equal(F0, system.work.F[system.free]) and np.array_equal(PHI0, system.work.PHI))


def _reference_warning(system, state, lam) -> None:
    """Warn (one line) when modes about the reference state are taken about a state that moves, or that is
    not an equilibrium of the loads at its time (:data:`EQUILIBRIUM`): the linearisation is then not about
    the motion or the loaded equilibrium the user may expect."""
    free = system.free
    V = np.hstack([state.v, state.w])[free]
    speed = float(np.max(np.abs(V), initial=0.0))
    if speed > 0.0:
        warnings.warn(f"modes about the reference state: it moves (initial velocities up to {speed:.3g}), and the "
                      "linearisation about a moving state is not about a steady motion (no centrifugal stretch or "
                      "stiffening); for a spinning model use about = \"rotation\"", ModelWarning, stacklevel=3)
        return
    N = state.x.shape[0]
    zero = np.zeros((N, 3))
    system.evaluate(state.x, state.q, zero, zero, np.zeros((N, 6)), lam, state.t, False)
    unbalanced = float(np.max(np.abs(system.work.r[free]), initial=0.0))
    scale = max(float(np.max(np.abs(getattr(system.work, k)[free]), initial=0.0)) for k in ("F", "S", "G"))
    if scale > 0.0 and unbalanced > EQUILIBRIUM * scale:  # unloaded and unstrained: no loads to balance
        warnings.warn(f"modes about the reference state: it is not an equilibrium of the loads at t = {state.t:g} "
                      f"(unbalanced force {unbalanced:.3g} against loads up to {scale:.3g}); the modes are those of "
                      "the structure without the loads' effect: use about = \"static\" for the modes under the loads",
                      ModelWarning, stacklevel=3)
