"""The abstract ``Algorithm`` (paper §4.2.4, Fig. 6) and its settings."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass


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
    """

    name: str
    dt: float
    explicit: bool = False
    deck_required: tuple = ()
    deck_optional: tuple = ()

    @staticmethod
    def refusal(model) -> str | None:
        return None

    @classmethod
    @abstractmethod
    def from_settings(cls, settings, dt=None) -> "Algorithm": ...

    @abstractmethod
    def start(self, model, state, critical_step: float = float("inf"), guard: float | None = None): ...

    @abstractmethod
    def advance(self, model, state, run, n_steps: int, record) -> int: ...

    @abstractmethod
    def failure(self, code: int, state, run) -> tuple[str, str]: ...


@dataclass
class SolverSettings:
    """Algorithm settings.

    Parameters
    ----------
    algorithm : str
        A name of :data:`reference.algorithms.ALGORITHMS`: ``"staggered_central_difference"``
        (Park, explicit), ``"static"`` (load stepping, Newton), ``"generalized_alpha"`` (implicit).
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
