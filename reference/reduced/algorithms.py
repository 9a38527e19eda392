"""The algorithms that run a model with reduced bodies, by deck name (:data:`REDUCED_TWINS`, issue 39).

Each is a subclass of the reference path's twin of that name (the same settings, deck keys and messages) that
steps the generalised coordinates of :class:`reference.reduced.coupling.CoupledModel`;
:func:`reduced_twin` makes one from the compiled algorithm the Domain built
(:func:`reference.plain.backend.twin` calls it when :func:`reference.plain.backend.decide` chose the reference
path for a model with reduced bodies).
"""

from __future__ import annotations

from reference.reduced.coupling import CoupledModel
from reference.reduced.explicit import ReducedStaggered
from reference.reduced.implicit import ReducedGeneralizedAlpha, ReducedModes, ReducedStatic

REDUCED_TWINS = {cls.name: cls for cls in (ReducedStaggered, ReducedStatic, ReducedGeneralizedAlpha, ReducedModes)}
"""Algorithm classes for models with reduced bodies, by deck name."""


def reduced_twin(algo, coupled_model: CoupledModel):
    """The reduced twin of the compiled algorithm ``algo`` (its settings copied) for ``coupled_model``."""
    cls = REDUCED_TWINS[algo.name]
    copy = object.__new__(cls)
    copy.__dict__.update(vars(algo))
    copy.coupled_model = coupled_model
    return copy
