"""Modes and linear buckling on the reference path.

The analyses of :mod:`reference.algorithms.linear` (their configurations, eigenproblems, datasets and
messages, stated there once) with the linearisation taken from :class:`reference.plain.model.Evaluation`:
:mod:`reference.algorithms.linearization` and :mod:`reference.algorithms.linear` read the Newton system through
:class:`reference.plain.newton.EngineFace`, the static path is :class:`reference.plain.static.PlainStatic`,
and the eigenproblems are SciPy's (:mod:`reference.modal`), as on the compiled path.  Modes about a steady
rotation (``about = "rotation"``) search the relative equilibrium with
:func:`reference.algorithms.linearization.at_steady_rotation` over the same face.  The analyses themselves (the
datasets, the mobility count, the warnings) are the compiled algorithms' own methods, inherited.
"""

from __future__ import annotations

import numpy as np

from reference.algorithms import linearization
from reference.algorithms.linear import Buckling, LinearRun, Modes
from reference.plain.newton import EngineFace, Newton
from reference.plain.static import PlainStatic
from reference.status import OK


def _plain_path(algo):
    """``algo`` with its static path (if any) on the reference path (a twin made from the compiled algorithm's
    settings, :func:`reference.plain.backend.twin`, carries the compiled path until it starts)."""
    if algo.path is not None and not isinstance(algo.path, PlainStatic):
        algo.path = PlainStatic(algo.path.dt, algo.path.tolerance, algo.path.max_iterations)
    return algo


def _start(algo, model, state) -> LinearRun:
    """:meth:`reference.algorithms.linear.LinearAnalysis.start` on the reference path."""
    _plain_path(algo)
    problem = algo.refusal(model)
    if problem:
        raise ValueError(problem)
    if algo.path is not None:
        path = algo.path.start(model, state)
        return LinearRun(path.system, path)
    return LinearRun(EngineFace(Newton(model)), None)


class PlainModes(Modes):
    """:class:`reference.algorithms.linear.Modes` on the reference path (about the reference state or a
    static equilibrium)."""

    @classmethod
    def from_settings(cls, settings, dt=None):
        return _plain_path(super().from_settings(settings, dt))

    def start(self, model, state, critical_step=None, guard=None) -> LinearRun:
        return _start(self, model, state)


class PlainBuckling(Buckling):
    """:class:`reference.algorithms.linear.Buckling` on the reference path."""

    @classmethod
    def from_settings(cls, settings, dt=None):
        return _plain_path(super().from_settings(settings, dt))

    def start(self, model, state, critical_step=None, guard=None) -> LinearRun:
        return _start(self, model, state)

    def unloaded(self, model, run) -> linearization.Linearization:
        """:meth:`reference.algorithms.linear.Buckling.unloaded` with :class:`PlainStatic`."""
        loads = model.loads._replace(vec=np.zeros_like(model.loads.vec))
        actuators = model.force_elements._replace(tf=np.full_like(model.force_elements.tf, -1))
        bare = model._replace(loads=loads, gravity=np.zeros_like(model.gravity), force_elements=actuators)
        static = PlainStatic(self.path.dt, self.path.tolerance, self.path.max_iterations)
        state = run.unloaded.copy()
        path = static.start(bare, state)
        code = static.advance(bare, state, path, 0, None)
        if code != OK:
            raise ValueError("the equilibrium without the loads (the reference of constant loads) was not found: "
                             + static.failure(code, state, path)[1])
        return linearization.linearize(bare, state.x, state.q, None, None, path.lam, state.t, state.angle, path.system)
