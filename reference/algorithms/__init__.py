"""Time-integration algorithms (paper §3.3, §4.2.4)."""

from reference.algorithms.base import Algorithm
from reference.algorithms.staggered import StaggeredCentralDifference, step

__all__ = ["Algorithm", "StaggeredCentralDifference", "step"]
