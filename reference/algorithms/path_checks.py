"""Converged equilibria that are not the path's, and why a path cannot start or go on: the checks the static
load stepping (:class:`reference.algorithms.static.Static`) and the arc length
(:class:`reference.algorithms.arc_length.ArcLength`) share.

Newton converges to *an* equilibrium, not necessarily to the next one along the path asked for.  The checks:

* a rotation drive at the other root of its equation ``sin(θ − θ(t)) = 0``, π from θ(t)
  (:func:`drive_alignment`): a static step is refused, an arc-length path does not start;
* a jump to another branch across a snap-back: the reaction of a displacement drive or prescribed displacement
  (static, :func:`why_refused`) or the load factor under displacement control (arc length,
  :func:`load_factor_jump`) falling by more than :data:`JUMP` of its largest magnitude along the path;
* a limit point passed inside one load step under load control, traced again by arc length
  (:func:`reference.algorithms.limit_point.limit_point_trace`, with :data:`RATIO` and :data:`TRACE_POINTS` from here);
* an arc-length path with nothing to scale or a controlled coordinate the load does not move
  (:func:`start_problem`, :data:`START_FIX`, :func:`unmoved`), and why a path that went well ended (:func:`path_end`).

They are their own module because both algorithms use them: imported by both, this module imports neither
(nor does it import :mod:`reference.algorithms.limit_point`, which runs the arc length from inside the static
algorithm).  :func:`row_forces`, the joints' forces Bᵀλ per node, is here for the same reason.
"""

from __future__ import annotations

import math
import operator

import numpy as np

from reference.algorithms.implicit import relative_rotation
from reference.connector import body_fixed_parts
from reference.generated.joints import joint_primitives
from reference.interactions import tf_integral, tf_value
from reference.jit import kernel
from reference.status import NO_CONVERGENCE, OK

JUMP = 0.5
"""A load step is refused and cut when the magnitude of the reaction of a displacement drive or prescribed
displacement falls by more than this fraction of its largest magnitude along the path (across zero: all of
its magnitude before the step, :func:`fall`): a jump across a snap-back, where the pushed displacement
itself turns back and Newton lands on another branch of the path.
A smooth path changes its reaction by a small fraction per step (the von Mises truss pushed in 29 steps: a
quarter at most)."""
RATIO = 4.0
"""Under load control, a step whose displacement per unit load (scaled norm: translations over the model size,
rotations in rad) exceeds this multiple of the previous step's is traced again by arc length from the previous
equilibrium (:func:`reference.algorithms.limit_point.limit_point_trace`) to see whether it passed a limit point."""
TRACE_POINTS = 40
"""Arc-length points of that trace before it gives up (an eighth of the step's chord each, adaptive)."""
STILL = 1e-8
"""Displacement control: the load does not move the controlled coordinate when its rate along the load tangent is
below this fraction of the tangent's size (scaled norm): round-off, as for a coordinate across a plane of symmetry."""
DISPLACEMENT_DRIVES = (3, 4, 5)
"""Drive codes whose multiplier is the force that pushes a displacement (docs/formulation.md §5)."""
PUSHED_FIX = ("The pushed displacement may have reached a snap-back point (where it turns back along the path) or "
              "the step is too large: raise load_steps or max_iterations, or stop t_end before it; past a snap-back, "
              "trace the path with algorithm = \"arc_length\".")
"""The advice of a displacement-controlled static run that stops (the deck already pushes)."""
START_FIX = ("The path starts from the equilibrium at load factor 0 with the drives and prescribed displacements at "
             "their values at t_end, imposed at once: reach that state first (a static run, or a smaller t_end), or "
             "give them smaller values.")
"""The advice of an arc-length path whose equilibrium at load factor 0 is not found."""
STOP_OPERATORS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
"""Comparisons of ``stop_when``."""


def why_refused(run, labels, x, q, lam, t0, t1) -> str:
    """Why the static equilibrium just converged at load factor ``t1`` (from ``t0``) is not the path's ("" when
    it is): a rotation drive at the other root of its equation, ``sin(θ − θ(t)) = 0`` solved by
    ``θ = θ(t) + π`` (``cos(θ − θ(t)) < 0``, from the primitives' rows 5 and 9: docs/formulation.md §5),
    or the reaction of a displacement drive or prescribed displacement falling by more than
    :data:`JUMP` of its largest magnitude along the path (a jump across a snap-back).  Sets
    ``run.refused_fix``, the advice of the failure that follows when no shorter step helps, and keeps the
    reactions and their largest magnitudes in ``run.reactions`` and ``run.peaks``; ``labels`` the joints'."""
    model, system = run.system.model, run.system
    driven = drives(model)
    if not driven:
        return ""
    for k, cos in drive_alignment(model, x, q, t1, driven):
        if cos < 0.0:
            run.refused_fix = ("Raise load_steps so that the drive turns less than π/2 per load step, or "
                               "start the drive nearer its angle at t = 0.")
            return (f"the rotation drive {joint_label(labels, k)} converged π away from its angle θ(t) at load "
                    f"factor {t1:.6g} (the other root of sin(θ − θ(t)) = 0; cos(θ − θ(t)) = {cos:.3g}): "
                    "refused")
    pushed = [k for k, code in driven if code in DISPLACEMENT_DRIVES]
    if not pushed:
        return ""
    rows = model.joints.row0[pushed]
    values = lam[rows]
    if run.reactions is None:
        run.reactions, run.peaks = values.copy(), np.abs(values)
        return ""
    wk = system.work
    noise = 1e-8 * max(float(np.max(np.abs(wk.S), initial=0.0)), float(np.max(np.abs(wk.F), initial=0.0)))
    for n, (old, new) in enumerate(zip(run.reactions, values)):
        peak = max(run.peaks[n], abs(new))
        if peak > noise and fall(old, new) > JUMP * peak:
            k = pushed[n]
            run.refused_fix = ("The pushed displacement turns back along the path there (a snap-back): trace it "
                               "with algorithm = \"arc_length\", or stop t_end before it.")
            return (f"the reaction of {joint_label(labels, k)} jumps from {old:.6g} to {new:.6g} between load factor "
                    f"{t0:.6g} and {t1:.6g} (more than {JUMP:g} of its largest magnitude {peak:.6g}): a jump to "
                    "another branch of the path, refused")
    run.reactions, run.peaks = values.copy(), np.maximum(run.peaks, np.abs(values))
    return ""


def row_forces(system, lam) -> np.ndarray:
    """The joints' forces Bᵀλ per node (N, 6) from the last evaluation of ``system``
    (:class:`reference.algorithms.implicit.NewtonSystem`): the reactions the static step's and the arc length's
    work increments and jump checks read."""
    model = system.model
    out = np.zeros((model.nodes.mass.shape[0], 6))
    Bl = system.work.Bl
    for k in range(model.joints.i.shape[0]):
        r0, neq = int(model.joints.row0[k]), int(model.joints.neq[k])
        i, j = int(model.joints.i[k]), int(model.joints.j[k])
        out[i] += Bl[r0:r0 + neq, :6].T @ lam[r0:r0 + neq]
        if j >= 0:
            out[j] += Bl[r0:r0 + neq, 6:].T @ lam[r0:r0 + neq]
    return out


def start_problem(system, x, q, t_end: float, labels) -> tuple:
    """``(status, message)`` of an arc-length path that cannot start from its equilibrium at load factor 0
    (``()`` when it can): the loads at ``t_end`` are zero (nothing to scale), or a rotation drive converged π
    from its angle at ``t_end`` (:func:`drive_alignment`); ``labels`` the joints'."""
    loads = system.work.F[system.free]
    if not np.any(loads != 0.0):
        return ("failed: no load to scale",
                f"arc_length scales the loads at t_end = {t_end:g} by the load factor, and "
                "they are zero (no [[loads]], [[line_loads]] or gravity, or their time functions "
                "vanish at t_end): the path would not move. Give a load nonzero at t_end; to "
                "follow a prescribed displacement alone, use algorithm = \"static\".")
    for k, cos in drive_alignment(system.model, x, q, t_end, drives(system.model)):
        if cos < 0.0:
            return ("failed: drive π away at load factor 0",
                    f"the rotation drive {joint_label(labels, k)} converged π away from its angle at t_end = "
                    f"{t_end:g} (the other root of sin(θ − θ(t)) = 0): the path starts with "
                    "the drives at their t_end values, imposed at once; reach that state with a "
                    "static run first, or give the drive a smaller angle at t_end.")
    return ()


def unmoved(text: str, lam: float) -> tuple:
    """``(status, message)`` of a displacement-controlled path whose load does not move the controlled
    coordinate ``text`` at load factor ``lam`` (its rate along the load below :data:`STILL` of the tangent's
    size)."""
    return ("failed: the load does not move the controlled coordinate",
            f"the load does not move the controlled coordinate {text!r} at "
            f"load factor {lam:.6g} (its rate along the load is zero: perpendicular "
            "to the motion, or a plane of symmetry); control a coordinate the load "
            "moves, e.g. the load point's along the load.")


def load_factor_jump(run, lam, text: str, cut_note: str) -> int:
    """Under displacement control of the coordinate ``text``: :data:`reference.status.NO_CONVERGENCE` (the point
    refused, the step cut) when the magnitude of the load factor falls by more than :data:`JUMP` of its largest
    along the path from the last point (across zero: all of it) — the controlled coordinate turned back (a
    snap-back) and the corrector landed on another branch; ``run.problem`` says so should the cuts not help.
    OK otherwise."""
    old = run.lam
    peak = max(run.peak, abs(lam))
    if peak > 0.0 and fall(old, lam) > JUMP * peak:
        run.problem = (f"failed: snap-back in {text}",
                       f"the load factor jumps from {old:.6g} to {lam:.6g} past load factor {old:.6g} under "
                       f"control of {text!r}, {cut_note} (more than {JUMP:g} of its largest magnitude "
                       f"{peak:.6g}): that coordinate turns back along the path (a snap-back), which "
                       "displacement control cannot pass; results up to there are kept. Remove `control` (the "
                       "arc length passes snap-backs) or control a coordinate that grows monotonically.")
        return NO_CONVERGENCE
    return OK


def path_end(x, lam: float, max_load_factor: float, stop_when) -> str:
    """Why an arc-length path ends at the point ``(x, λ)`` ("" when it goes on): ``|λ|`` reached
    ``max_load_factor``, or the node coordinate of ``stop_when`` ``(node, component, comparison, value, text)``
    compares true."""
    if abs(lam) >= max_load_factor:
        return f"|load factor| {abs(lam):.6g} reached max_load_factor {max_load_factor:g}"
    if stop_when is not None:
        node, comp, op, value, text = stop_when
        if STOP_OPERATORS[op](x[node, comp], value):
            return f"stop_when {text!r} met at load factor {lam:.6g}"
    return ""


def drives(model):
    """``(joint index, drive code)`` of the model's drives and prescribed displacements."""
    return [(k, int(code)) for k, code in enumerate(model.joints.drive.tolist()) if code > 0]


def drive_value(model, k, tf, t) -> float:
    """θ(t) [rad] or s(t) [m] of drive k: its time function's value, or its integral for a drive given by its
    rate (``mode = "velocity"``: codes 2 and 4)."""
    kind, par = model.time_functions.kind[tf], model.time_functions.par[tf]
    code = int(model.joints.drive[k])
    return float(tf_integral(kind, par, t) if code in (2, 4) else tf_value(kind, par, t))


def drive_alignment(model, x, q, t, driven):
    """``(joint index, cos(θ − θ(t)))`` of every rotation drive at (x, q, t): θ the rotation of body i relative
    to body j about the drive's axis from the primitives' rows 5 and 9 (sin θ and cos θ,
    :mod:`derivations.joints`), θ(t) the prescribed angle.  The drive's equation ``sin(θ − θ(t)) = 0`` holds
    at both roots; this is +1 at the prescribed one and −1 at the one π away.  ``driven``: :func:`drives` of
    the model."""
    out = []
    phi, B = np.zeros(10), np.zeros(120)
    jt = model.joints
    for k, code in driven:
        if code not in (1, 2):
            continue
        j = int(jt.j[k])
        xj, qj = (x[j], q[j]) if j >= 0 else (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))
        joint_primitives(x[int(jt.i[k])], q[int(jt.i[k])], xj, qj, *body_fixed_parts(jt.par[k]), phi, B)
        th = drive_value(model, k, int(jt.tf[k]), t)
        out.append((k, float(phi[9] * math.cos(th) + phi[5] * math.sin(th))))
    return out


def joint_label(labels, k) -> str:
    """The joint's label (quoted) for a message, or its number when it has none."""
    return repr(labels[k]) if k < len(labels) else f"number {k}"


def moved(system, x0, q0, x, q, L) -> float:
    """The scaled size of the move from (x0, q0) to (x, q): ``√(Σ|Δx/L|² + Σ|Δθ|²)`` over the free coordinates
    (the arc length's norm without its load part), ``L`` the length scale [m]; at every converged load step of
    the static algorithm, one compiled call."""
    return float(_scaled_move(x0, q0, x, q, float(L), system.free))


@kernel
def _scaled_move(x0, q0, x, q, L, free):
    """:func:`moved` of the coordinates marked in ``free`` (N, 6)."""
    dth = np.empty_like(x)
    relative_rotation(q0, q, dth, np.empty(4))
    total = 0.0
    for i in range(x.shape[0]):
        for k in range(6):
            if free[i, k]:
                d = (x[i, k] - x0[i, k]) / L if k < 3 else dth[i, k - 3]
                total += d * d
    return math.sqrt(total)


def fall(old: float, new: float) -> float:
    """How far ``|old|`` falls towards zero on the way to ``new``: ``|old| − |new|`` of the same sign, all of
    ``|old|`` across zero (a rise, or a start from zero, is no fall)."""
    return abs(old) - (abs(new) if old * new > 0.0 else 0.0)


def vertex(s0, f0, s1, f1, s2, f2) -> float:
    """The largest value of the parabola through three points (s, f), s0 < s1 < s2 (the largest of the three
    values when the parabola has no maximum)."""
    a, b, c = np.polyfit([s0, s1, s2], [f0, f1, f2], 2)
    top = max(f0, f1, f2)
    return float(c - b * b / (4.0 * a)) if a < 0.0 else top
