"""The abstract ``Algorithm`` (paper §4.2.4, Fig. 6)."""

from __future__ import annotations

from abc import ABC, abstractmethod


class Algorithm(ABC):
    """A time-integration algorithm over the Domain's plain-data state.

    Subclasses provide ``name``, ``dt`` and
    ``advance(model, state, n_steps, record, scratch) → status``, which moves
    the :class:`~reference.state.State` forward in place by ``n_steps`` steps
    and, when ``record`` is given, fills it with the output at the starting
    time.  Status 0 is success; :meth:`failure` explains any other.
    """

    name: str
    dt: float

    @abstractmethod
    def advance(self, model, state, n_steps, record, scratch) -> int: ...

    def failure(self, code: int) -> tuple[str, str]:
        """``(status, explanation)`` of a non-zero status code of :meth:`advance`, for the results
        file and the message (e.g. ``("diverged", "the solution became non-finite")``).
        Subclasses with codes of their own override it."""
        return "diverged", f"the {self.name} algorithm stopped with status {code}"
