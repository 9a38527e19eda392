"""Time-integration and load-stepping algorithms (paper §3.3, §4.2.4).

``ALGORITHMS`` is the registry the Domain looks the deck's ``[solver]
algorithm`` up in: a new algorithm is a subclass of :class:`Algorithm` in its
own module, added here by name.
"""

from reference.algorithms.arc_length import ArcLength
from reference.algorithms.base import Algorithm, SolverSettings
from reference.algorithms.generalized_alpha import GeneralizedAlpha
from reference.algorithms.linear import Buckling, Modes
from reference.algorithms.staggered import StaggeredCentralDifference, step
from reference.algorithms.static import Static

ALGORITHMS = {cls.name: cls for cls in (StaggeredCentralDifference, Static, GeneralizedAlpha, Modes, Buckling, ArcLength)}
"""Algorithm classes by deck name."""

__all__ = ["ALGORITHMS", "Algorithm", "ArcLength", "Buckling", "GeneralizedAlpha", "Modes", "SolverSettings",
           "StaggeredCentralDifference", "Static", "step"]
