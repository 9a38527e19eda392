"""The reference path's algorithms by deck name (:data:`REFERENCE_TWINS`).

Each is the twin of the compiled algorithm of the same name in :data:`reference.algorithms.ALGORITHMS`:
a subclass with the same settings, deck keys, records and messages, whose ``start`` and ``advance``
run on :class:`reference.plain.model.Evaluation` (plain NumPy, no compilation).  The solution loop
(:func:`reference.solution.run`) runs the twin for ``[solver] backend = "reference"``.
"""

from __future__ import annotations

from reference.plain.arc_length import PlainArcLength
from reference.plain.generalized_alpha import PlainGeneralizedAlpha
from reference.plain.linear import PlainBuckling, PlainModes
from reference.plain.static import PlainStatic

REFERENCE_TWINS = {cls.name: cls for cls in (PlainStatic, PlainGeneralizedAlpha, PlainModes, PlainBuckling,
                                                   PlainArcLength)}
"""Reference-path algorithm classes by deck name (the implicit and linear ones; the explicit one is
:mod:`reference.plain.park`'s)."""
