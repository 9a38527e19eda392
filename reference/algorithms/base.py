"""The abstract ``Algorithm`` (paper §4.2.4, Fig. 6) and its settings."""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass

ABOUT = ("reference", "static", "rotation")
"""The configurations a modal analysis linearises about (``solver.about``)."""
CALL_SECONDS = 0.1
"""The wall time [s] a compiled stepping call aims at (:class:`CallBudget`): Python's signal handlers
(Ctrl-C, SIGTERM), the results file's timed flush and the progress run between two calls only, so each
returns within about twice this."""


class CallBudget:
    """How many steps the next compiled call of a stepping loop may take, so that the call lasts about
    :data:`CALL_SECONDS` of wall time.

    The size follows the measured time per step of the previous call (``size · CALL_SECONDS / elapsed``),
    growing at most :attr:`GROWTH` times a call (a first call that compiled the kernels measures minutes a
    step; the size then grows back in a few calls), never below one step.  A call's own cost (Python and
    argument passing) is negligible against its budget (docs/benchmarks.md §10).
    """

    GROWTH = 4

    def __init__(self, size: int = 16, seconds: float = CALL_SECONDS):
        self.size, self.seconds, self._start = int(size), float(seconds), 0.0
        self.tick = None
        """Called (no arguments) after every call, or None: the solution loop's progress between two outputs
        (:func:`reference.solution.run`)."""

    def start(self) -> int:
        """The steps the next call may take; its clock starts."""
        self._start = time.perf_counter()
        return self.size

    def took(self, steps: int) -> None:
        """The call started by :meth:`start` took ``steps`` steps (fewer when it returned early)."""
        elapsed = time.perf_counter() - self._start
        if steps > 0 and elapsed > 0.0:
            self.size = max(1, min(self.GROWTH * self.size, int(self.seconds * steps / elapsed)))
        if self.tick is not None:
            self.tick()


class Algorithm(ABC):
    """A time-integration (or load-stepping) algorithm over the Domain's plain-data state.

    Subclasses provide ``name`` (the deck's ``[solver] algorithm``), ``dt``,
    ``explicit`` (True if the step is bounded by the critical time step),
    ``deck_required``/``deck_optional`` (its ``[solver]`` keys besides ``algorithm``),
    ``refusal(model) → str | None`` (why it cannot run a model),
    ``from_settings(settings, dt=None)`` (build from :class:`SolverSettings`, ``dt``
    an override), and:

    - ``start(model, state, critical_step=inf, guard=None) → run``: the algorithm's
      run state — everything it carries from one call of ``advance`` to the next
      besides the :class:`~reference.state.State` (work arrays, multipliers,
      accelerations, factors, counters); the algorithm object itself keeps only its
      settings, so a run can be continued or restarted from any (state, run) pair.
      ``critical_step`` [s] is the Domain's estimate (for an explicit scheme's
      messages), ``guard`` the round-off floor of the per-step energy guard's scale [J]
      (:func:`reference.monitor.energy_floor`; None: no per-step guard);
    - ``advance(model, state, run, n_steps, record) → status``: moves the state (and
      the run) forward in place by ``n_steps`` steps and, when ``record`` is given,
      fills it with the output at the starting time; the status is a code of
      :mod:`reference.status`;
    - ``failure(code, state, run) → (status, message)`` for a code other than ``OK``.

    What the solution loop (:func:`reference.solution.run`) asks besides, with defaults for a
    time-stepping algorithm: ``n_steps(t_end)`` (how many steps reach ``t_end``), ``recorded(run)``
    (values the algorithm adds to every output record, by record key) and ``finish(model, state, run,
    completed)`` (datasets written once at the end, by path in the results file).  The linearised
    analyses (:mod:`reference.algorithms.linear`) override them: they take no step, or only those of
    the static path to the state they linearise about, and write their modes at the end.
    """

    name: str
    dt: float
    explicit: bool = False
    linearised: bool = False
    """A linearised analysis (:mod:`reference.algorithms.linear`): its results have a table (:meth:`table`)."""
    deck_required: tuple = ()
    deck_optional: tuple = ()
    joint_labels: tuple = ()
    """The labels of the model's joints with multipliers, in the model's order (set by the solution loop,
    :func:`reference.solution.run`, for the messages that name a joint)."""

    @staticmethod
    def refusal(model) -> str | None:
        return None

    def setting_problem(self, model) -> tuple[str, str, str] | None:
        """``(deck entry, problem, fix)`` when ``model`` makes one of this algorithm's settings impossible (the
        deck reader's one-line error), None when it does not."""
        return None

    @classmethod
    def deck_keys(cls, solver: dict) -> tuple[tuple, tuple]:
        """``(required, optional)`` keys of ``[solver]`` besides ``algorithm`` for this table (some
        algorithms' keys depend on the value of another); all of them are in ``deck_required`` or
        ``deck_optional``."""
        return cls.deck_required, cls.deck_optional

    @classmethod
    @abstractmethod
    def from_settings(cls, settings, dt=None) -> "Algorithm": ...

    @abstractmethod
    def start(self, model, state, critical_step: float = float("inf"), guard: float | None = None): ...

    @abstractmethod
    def advance(self, model, state, run, n_steps: int, record) -> int: ...

    @abstractmethod
    def failure(self, code: int, state, run) -> tuple[str, str]: ...

    def n_steps(self, t_end: float) -> int:
        """The number of steps of ``dt`` from 0 to ``t_end``; ValueError when it is not a whole number."""
        steps = t_end / self.dt
        n_total = int(round(steps)) if steps < 2.0**62 else 0
        if n_total < 1 or abs(n_total * self.dt - t_end) > 1e-9 * max(t_end, 1.0):
            raise ValueError(f"t_end = {t_end} is not a whole number of steps of dt = {self.dt}")
        return n_total

    def recorded(self, run) -> dict:
        """Values added to each output record (record key → value, :data:`reference.io.results.DATASETS`)."""
        return {}

    def table(self, results) -> list[str]:
        """Lines of the terminal table of a linearised analysis's results (none for the others)."""
        return []

    def summary(self, run) -> str:
        """One line on how the run went (steps, iterations, cuts), printed after ``flexmbs run`` ("": none)."""
        return ""

    def finish(self, model, state, run, completed: bool) -> dict:
        """Datasets written once when the run ends (path in the results file → array); ``completed``
        whether every step was taken."""
        return {}

    def done(self, run) -> bool:
        """The run has ended before its ``n_steps`` (a path-following stop): the solution loop records the
        state once more and stops."""
        return False

    def record_last(self, model, state, run, record) -> bool:
        """After a failed ``advance``: fill ``record`` with the last converged state when it is not recorded
        yet (a static path's last sub-level after its cuts); True when filled."""
        return False

    @classmethod
    def deck_settings(cls, rd, solver: dict, domain) -> dict:
        """The :class:`SolverSettings` fields read from this algorithm's own ``[solver]`` keys (``rd`` the
        deck reader, for one-line errors); none for most algorithms."""
        return {}

    @classmethod
    def deck_check(cls, rd, solver: dict, settings: "SolverSettings") -> None:
        """Checks of the read settings together (``solver`` the deck's ``[solver]`` table, ``rd`` the deck
        reader): a one-line error for a combination that cannot work, a :class:`~reference.validation.ModelWarning`
        for one that does not do what it seems to; none for most algorithms."""


@dataclass(kw_only=True)
class SolverSettings:
    """Algorithm settings.

    Parameters
    ----------
    algorithm : str
        A name of :data:`reference.algorithms.ALGORITHMS`: ``"staggered_central_difference"``
        (Park, explicit), ``"static"`` (load stepping, Newton), ``"generalized_alpha"`` (implicit),
        ``"modes"``, ``"buckling"`` (linearised analyses).
    dt : float
        Time step [s] (static: ``t_end / load_steps``).
    t_end : float
        End time [s] (static: the final load factor).
    damping : float
        Mass-proportional damping coefficient c [1/s] (force −c m v and moment
        −c J ω on every node), for quasi-static runs.
    output_every : int
        Output every this many steps (and at ``t_end``).
    consistent_initial_velocities : bool
        Project the initial velocities onto the velocity constraints at t = 0
        (``B V + Φ_t = 0``, the change of least kinetic energy), e.g. to start a
        mechanism at its full driving speed.
    load_steps : int
        Static: number of equal load steps from 0 to ``t_end``.
    rho_inf : float
        Generalized-α: spectral radius at infinite frequency (1: no numerical dissipation).
    tolerance, max_iterations : float, int, optional
        Newton settings of the implicit algorithms (None: the algorithm's default).
    error_tolerance : float, optional
        Generalized-α: bound of the local error estimate; the algorithm chooses the step
        (:mod:`reference.algorithms.step_control`; None: fixed steps of ``dt``).
    dt_min, dt_max, first_step : float, optional
        Generalized-α with ``error_tolerance``: bounds of the step and the first step [s] (``dt`` is
        then the output grid).
    modes : int
        Modes and buckling: how many of the lowest modes (load factors) to compute.
    about : str
        Modes: the configuration linearised about, ``"reference"`` (the initial state), ``"static"``
        (the static equilibrium at ``t_end``) or ``"rotation"`` (the whole model spinning steadily).
    spin_rate, spin_axis, spin_point : float, tuple, tuple
        Modes about a rotation: the rate Ω [rad/s], the axis (inertial) and a point of it [m].
    backend : str
        Which implementation of the equations runs the algorithm: ``"compiled"`` (default; the numba
        kernels), ``"reference"`` (the plain NumPy path of ``reference/plain/``, the same generated
        physics, no compilation) or ``"auto"`` (the reference path when the run is too short to pay for
        compiling the kernels it needs, else the compiled one; the rule, its measurements and its one
        line on the terminal: ``reference/plain/backend.py``).
    arc_length, max_points, max_load_factor, branch_switch, stop_when, control
        Arc length: the initial arc (scaled norm), the converged points, the stop on ``|λ|``, the switch
        at a bifurcation, the stop on a node coordinate and the displacement control (:class:`reference.algorithms.arc_length.ArcLength`).
    """

    algorithm: str = "staggered_central_difference"
    dt: float = 1e-3
    t_end: float = 1.0
    damping: float = 0.0
    output_every: int = 1
    consistent_initial_velocities: bool = False
    load_steps: int = 1
    rho_inf: float = 0.8
    tolerance: float | None = None
    max_iterations: int | None = None
    error_tolerance: float | None = None
    dt_min: float | None = None
    dt_max: float | None = None
    first_step: float | None = None
    modes: int = 6
    about: str = "reference"
    arc_length: float = 0.0
    max_points: int = 0
    max_load_factor: float = math.inf
    branch_switch: bool = False
    stop_when: tuple | None = None
    control: tuple | None = None
    spin_rate: float = 0.0
    spin_axis: tuple = (0.0, 0.0, 1.0)
    spin_point: tuple = (0.0, 0.0, 0.0)
    backend: str = "compiled"
