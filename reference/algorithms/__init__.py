"""Time-integration and load-stepping algorithms (paper §3.3, §4.2.4).

``ALGORITHMS`` is the registry the Domain looks the deck's ``[solver]
algorithm`` up in: a new algorithm is a subclass of :class:`Algorithm` in its
own module, added to :data:`WHERE` by name as ``"module:Class"``.

An algorithm's module is imported when its class is first asked for (a lookup
in ``ALGORITHMS``, or an attribute of this package such as ``ArcLength``), not
when the package is: each algorithm's module imports its kernels' modules
(numba, SciPy, the generated physics), and a command that runs one algorithm
need not load the others (docs/benchmarks.md, "Warm process start").
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping

from reference.algorithms.base import Algorithm, SolverSettings

WHERE = {
    "staggered_central_difference": "reference.algorithms.staggered:StaggeredCentralDifference",
    "static": "reference.algorithms.static:Static",
    "generalized_alpha": "reference.algorithms.generalized_alpha:GeneralizedAlpha",
    "modes": "reference.algorithms.linear:Modes",
    "buckling": "reference.algorithms.linear:Buckling",
    "arc_length": "reference.algorithms.arc_length:ArcLength",
}
"""Each algorithm's deck name → ``"module:Class"`` of its class (whose ``name`` is the deck name)."""

_ATTRIBUTES = {"StaggeredCentralDifference": "reference.algorithms.staggered", "step": "reference.algorithms.staggered",
               "Static": "reference.algorithms.static", "GeneralizedAlpha": "reference.algorithms.generalized_alpha",
               "Modes": "reference.algorithms.linear", "Buckling": "reference.algorithms.linear",
               "ArcLength": "reference.algorithms.arc_length"}
"""The package's names that live in an algorithm's module, imported on first use (:func:`__getattr__`)."""


def resolve(where: str):
    """The object that ``"module:name"`` names, its module imported on first use."""
    module, _, name = where.partition(":")
    return getattr(importlib.import_module(module), name)


class Registry(Mapping):
    """A read-only mapping of names to the objects that :data:`WHERE`-style ``"module:name"`` strings name,
    each imported when it is first looked up: iterating over the names, ``in`` and ``len`` import nothing."""

    def __init__(self, where: dict[str, str]):
        self._where = dict(where)

    def __getitem__(self, name: str):
        return resolve(self._where[name])

    def __iter__(self) -> Iterator[str]:
        return iter(self._where)

    def __len__(self) -> int:
        return len(self._where)

    def __repr__(self) -> str:
        return f"Registry({self._where!r})"


ALGORITHMS = Registry(WHERE)
"""Algorithm classes by deck name (each module imported on first lookup)."""


def __getattr__(name: str):
    """An algorithm's class (or the explicit ``step``), imported from its module on first use (PEP 562)."""
    if name in _ATTRIBUTES:
        return getattr(importlib.import_module(_ATTRIBUTES[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_ATTRIBUTES})


__all__ = ["ALGORITHMS", "Algorithm", "ArcLength", "Buckling", "GeneralizedAlpha", "Modes", "Registry",
           "SolverSettings", "StaggeredCentralDifference", "Static", "WHERE", "resolve", "step"]
