"""A limit point passed inside one load step of the static algorithm, traced again by arc length.

Under load control Newton may converge past a limit point onto another branch of the path within one load step
(a snap-through).  :class:`reference.algorithms.static.Static` sees the step's displacement per unit load jump
(:data:`reference.algorithms.path_checks.RATIO`) and calls :func:`limit_point_trace`, which runs
:class:`reference.algorithms.arc_length.ArcLength` over the step from the equilibrium before it.  It is its own
module so that the static algorithm imports the arc length through it, and the checks both algorithms share
(:mod:`reference.algorithms.path_checks`) import neither.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from reference.algorithms.arc_length import ArcLength
from reference.algorithms.path_checks import TRACE_POINTS, drive_value, drives, moved, row_forces, vertex
from reference.state import new_clock
from reference.status import OK
from reference.validation import ModelWarning


def limit_point_trace(static, model, state, run, saved, F0, now, t0, t1) -> None:
    """The load interval ``[t0, t1]`` of a static step whose displacement per unit load jumped (:data:`RATIO`),
    traced again by arc length from the equilibrium before it (``saved``: x, q, λ, the force elements'
    angles; ``F0`` its loads; ``now`` the step's x, q, λ; ``static`` the algorithm, for its Newton settings):
    when the load factor along that path reaches a maximum below ``t1`` and falls, the step passed a limit
    point onto another branch — one warning line with the limit load, and an event of ``/stability`` (kind
    ``"limit point"``).  Only for proportional loads (``F(t0) = c F(t1)``, 0 ≤ c < 1) and drives that do not
    move over the step; the run's state is left as it is."""
    system = run.system
    F1 = system.work.F[system.free]
    F_0 = F0[system.free]
    top = float(F1 @ F1)
    c = float(F_0 @ F1) / top if top > 0.0 else -1.0
    if not (0.0 <= c < 1.0) or np.max(np.abs(F_0 - c * F1), initial=0.0) > 1e-12 * math.sqrt(top):
        return
    for k, _ in drives(model):
        tf = int(model.joints.tf[k])
        if drive_value(model, k, tf, t0) != drive_value(model, k, tf, t1):
            return
    x1, q1, _ = now
    x0, q0, lam0, angle0 = saved
    chord = math.sqrt(moved(system, x0, q0, x1, q1, run.L) ** 2 + (1.0 - c) ** 2)
    arc = ArcLength(chord / 8.0, TRACE_POINTS, math.inf, t1, static.tolerance, static.max_iterations)
    trace = arc.start(model, state)
    trace.L = run.L
    x, q = x0.copy(), q0.copy()
    trace.mu[:] = lam0
    trace.system.work.angle[:] = angle0
    if arc._correct(trace, x, q, c, None)[0] != OK:
        return
    trace.lam, trace.F, trace.P = c, trace.system.work.F.copy(), row_forces(trace.system, trace.mu)
    path = [(0.0, c)]
    clock = new_clock()[0]
    for _ in range(TRACE_POINTS):
        if arc._point(trace, x, q, clock) != OK:
            return
        path.append((trace.s, trace.lam))
        if trace.lam >= 1.0:
            return
        if trace.lam < path[-2][1]:
            break
    else:
        return
    (s0, l0), (s1, l1), (s2, l2) = path[-3:] if len(path) >= 3 else [path[0]] + path[-2:]
    peak = vertex(s0, l0, s1, l1, s2, l2)
    t_lim = t0 + (peak - c) / (1.0 - c) * (t1 - t0)
    run.events.append((t0, t1, t_lim, "limit point", run.negative))
    warnings.warn(f"the load step from load factor {t0:.6g} to {t1:.6g} passed a limit point at load factor "
                  f"{t_lim:.6g} (traced by arc length) and jumped to another branch of the path: use algorithm = "
                  "\"arc_length\" to follow it, or push the structure ([[prescribed_displacements]])",
                  ModelWarning, stacklevel=3)
