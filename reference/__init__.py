"""flexmbs reference engine: the paper's computational engine in readable Python.

The entry point is :class:`Domain`; ``Domain.solve`` (or ``solve(domain)``, :func:`reference.solution.solve`, the
same run) runs it.  A model is built in Python from the names exported here, which
follow the deck's words: ``[sections.NAME]`` → :class:`Section`, ``[[loads]]`` → :class:`NodalLoad`,
``[[line_loads]]`` → :class:`LineLoad`, ``[gravity]`` → :class:`Gravity` (a vector),
``[[joints]]`` → :class:`Joint`, ``[[springs]]`` → :class:`PointToPoint`, :class:`Rotational`,
:class:`Bushing`, ``[solver]`` → :class:`SolverSettings`, time functions by their deck names
(:class:`Ramp`, :class:`Step`, …).  Lesson 6 (``notebooks/06_implicit_explicit.py``) builds a model
this way.
Arguments whose meaning a position would hide (flags, stiffnesses, settings) are keyword-only.

Examples
--------
A cantilever of ten Beam2 elements under a tip force that steps on at t = 0:

>>> from reference import Clamp, Domain, NodalLoad, Section, SolverSettings, Step
>>> d = Domain("cantilever")
>>> section = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2,
...                   rhoJ3=1e-2)
>>> nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 10, section)
>>> clamp = d.add_interaction(Clamp(nodes[0]))
>>> tip = d.add_interaction(NodalLoad(nodes[-1], [0.0, 0.0, 1e-2], time_function=Step(0.0, 0.0, 1.0)))
>>> d.solver = SolverSettings(algorithm="generalized_alpha", dt=1e-2, t_end=0.1)
>>> len(nodes), d.node("beam:10") is nodes[-1]
(11, True)

Gravity is a vector, as in the deck's ``[gravity] g``:

>>> from reference import Gravity
>>> Gravity(-9.81)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
ValueError: Gravity g [m/s²]: expected a vector of 3 finite numbers, got -9.81; give a vector, e.g. ...
"""

from __future__ import annotations

import importlib

_WHERE = {"SolverSettings": "reference.algorithms.base", "Domain": "reference.domain",
          "Section": "reference.elements.section",
          **dict.fromkeys(("Bushing", "PointToPoint", "Rotational"), "reference.forces"),
          **dict.fromkeys(("Clamp", "Constant", "Expression", "FixedCoordinates", "Gravity", "LineLoad", "NodalLoad",
                           "PiecewiseLinear", "Ramp", "Sine", "SmoothStep", "Step"), "reference.interactions"),
          **dict.fromkeys(("Jacobian", "Joint", "MasterSlave", "joint_frame"), "reference.joints"),
          "solve": "reference.solution"}
"""Each public name → the module that defines it, imported when the name is first used (:func:`__getattr__`):
``import reference`` (or of one engine module) loads nothing else, and ``from reference import Domain`` what the
Domain needs."""


def __getattr__(name: str):
    """A public name, imported from its module on first use (PEP 562)."""
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_WHERE})


__all__ = ["Bushing", "Clamp", "Constant", "Domain", "Expression", "FixedCoordinates", "Gravity", "Jacobian", "Joint",
           "LineLoad", "MasterSlave", "NodalLoad", "PiecewiseLinear", "PointToPoint", "Ramp", "Rotational", "Section",
           "Sine", "SmoothStep", "SolverSettings", "Step", "joint_frame", "solve"]
