"""The abstract ``Algorithm`` (paper §4.2.4, Fig. 6)."""

from __future__ import annotations

from abc import ABC, abstractmethod


class Algorithm(ABC):
    """A time-integration (or load-stepping) algorithm over the Domain's plain-data state.

    Subclasses provide ``name`` (the deck's ``[solver] algorithm``), ``dt``,
    ``explicit`` (True if the step is bounded by the critical time step),
    ``deck_required``/``deck_optional`` (its ``[solver]`` keys besides ``algorithm``),
    ``refusal(model) → str | None`` (why it cannot run a model),
    ``from_settings(settings, dt=None)`` (build from
    :class:`~reference.domain.SolverSettings`, ``dt`` an override),
    ``advance(model, state, n_steps, record, scratch) → status``, which moves
    the :class:`~reference.state.State` forward in place by ``n_steps`` steps
    and, when ``record`` is given, fills it with the output at the starting
    time, and ``failure(code, t_last, domain) → (status, message)`` for a
    status other than 0 (success).
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
    def advance(self, model, state, n_steps, record, scratch) -> int: ...

    @abstractmethod
    def failure(self, code: int, t_last: float, domain) -> tuple[str, str]: ...
