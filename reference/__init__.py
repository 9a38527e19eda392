"""flexmbs reference engine: the paper's computational engine in readable Python.

The entry point is :class:`Domain`.  A model is built in Python from the names exported here, which
follow the deck's words: ``[sections.NAME]`` → :class:`Section`, ``[[loads]]`` → :class:`NodalLoad`,
``[[line_loads]]`` → :class:`LineLoad`, ``[gravity]`` → :class:`Gravity` (a vector),
``[[joints]]`` → :class:`Joint`, ``[[springs]]`` → :class:`PointToPoint`, :class:`Rotational`,
:class:`Bushing`, ``[solver]`` → :class:`SolverSettings`, time functions by their deck names
(:class:`Ramp`, :class:`Step`, …).  Lesson 6 (``notebooks/06_implicit_explicit.py``) builds a model
this way.
"""

from reference.algorithms.base import SolverSettings
from reference.domain import Domain
from reference.elements.section import Section
from reference.forces import Bushing, PointToPoint, Rotational
from reference.interactions import (Clamp, Constant, Expression, FixedCoordinates, Gravity, LineLoad, NodalLoad,
                                    PiecewiseLinear, Ramp, Sine, SmoothStep, Step)
from reference.joints import Jacobian, Joint, MasterSlave, joint_frame

__all__ = ["Bushing", "Clamp", "Constant", "Domain", "Expression", "FixedCoordinates", "Gravity", "Jacobian", "Joint",
           "LineLoad", "MasterSlave", "NodalLoad", "PiecewiseLinear", "PointToPoint", "Ramp", "Rotational", "Section",
           "Sine", "SmoothStep", "SolverSettings", "Step", "joint_frame"]
