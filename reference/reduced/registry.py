"""Which Domains carry reduced bodies (issue 39), and the reduced bodies as a formulation of the reference path.

:func:`reference.io.deck_reduce.read_reduce` registers the reduced beams of a Domain read from a deck
(:func:`register`); the backend's choice (:func:`reference.plain.backend.decide`, through
:data:`reference.plain.backend.REFERENCE_ONLY`, where this module enters :data:`REDUCED`) asks :meth:`Reduced.labels`
of the model it is handed: the Domain caches the model it runs (``Domain.model``), so the model identifies the
Domain.  Weak references: a Domain that is gone leaves nothing behind.
"""

from __future__ import annotations

import weakref

from reference.plain import backend

RUNS = ("staggered_central_difference", "static", "generalized_alpha", "modes")
"""The algorithms that run a model with reduced bodies (:data:`reference.reduced.algorithms.REDUCED_TWINS`)."""

_DOMAINS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
"""Domain → its reduced beams (label → ``(ReducedBody, node ids)``)."""


def register(domain, bodies: dict) -> None:
    """Record the reduced beams ``bodies`` (label → ``(ReducedBody, node ids)``) of ``domain``."""
    _DOMAINS[domain] = dict(bodies)


def domain_of(model):
    """``(domain, bodies)`` of the Domain with reduced beams whose cached model is ``model``, else None."""
    for domain, bodies in list(_DOMAINS.items()):
        if bodies and getattr(domain, "_model", None) is model:
            return domain, bodies
    return None


class Reduced:
    """Reduced bodies as an entry of :data:`reference.plain.backend.REFERENCE_ONLY`."""

    name = "reduced beam"
    algorithms = RUNS

    @staticmethod
    def labels(model) -> tuple:
        """The labels of the reduced beams of ``model`` (none: an empty tuple)."""
        found = domain_of(model)
        return tuple(found[1]) if found else ()

    @staticmethod
    def twin(algo, model):
        """:func:`reference.reduced.algorithms.reduced_twin` on the
        :class:`~reference.reduced.coupling.CoupledModel` of ``model``."""
        from reference.reduced.algorithms import reduced_twin
        from reference.reduced.coupling import CoupledModel

        return reduced_twin(algo, CoupledModel(model, *domain_of(model)))


REDUCED = Reduced()
if not any(isinstance(f, Reduced) for f in backend.REFERENCE_ONLY):
    backend.REFERENCE_ONLY.append(REDUCED)
