"""Step-size control of generalized-α (docs/formulation.md §13): step cuts when Newton fails, the local
error estimate and the step-size controller of ``[solver] error_tolerance``, and the solver statistics.

**Step cuts.**  A step whose Newton iteration fails (no convergence in ``max_iterations``, a non-finite
iterate, a singular Newton matrix) is retried from the last converged state with half the step, up to
:data:`MAX_CUTS` halvings in a row (or down to ``dt_min``); after :data:`GROW_AFTER` converged steps at
a cut step it is doubled again, up to the deck's ``dt``.  Newton's tolerance is the same on every step: it
bounds the residual left relative to the step's forces (:mod:`reference.algorithms.generalized_alpha`), an
error of the accelerations that twice as many steps of half the size do not make larger.

**Local error estimate** (Zienkiewicz & Xie 1991, "A simple error estimator and adaptive time stepping
procedure for dynamic analysis", Earthquake Eng. Struct. Dyn. 20, 871–887): the leading term of the local
error of the Newmark configuration update is ``e = h² (β − 1/6) (a_{n+1} − a_n)``; generalized-α updates the
configuration with Newmark's formula in its algorithmic accelerations a, which are used here.  The error of each coordinate is measured
against its own increment over the step, ``h |V|`` (a relative error of the step's motion, so that the
errors that add up over a run are a fraction ``error_tolerance`` of the motion), with an absolute floor
:data:`FLOOR` × L [m] (L the model size, :meth:`ImplicitAlgorithm.length_scale`) for translations and
:data:`FLOOR` rad for rotations; the norm is the largest over the coordinates (a maximum, not a sum: refining
the mesh does not tighten the control).  Positions and rotations enter each in its own units through its
own increment, so neither the mesh's length scale nor the node count changes the meaning of the tolerance.

**Controller** (Hairer, Nørsett & Wanner 1993, *Solving Ordinary Differential Equations I*, §II.4): a step with error
norm ``err ≤ 1`` is accepted, one with ``err > 1`` is taken again from its start; either way the next
step is ``h · min(MAX_GROWTH, max(MIN_SHRINK, SAFETY · err^(−1/3)))`` (local error O(h³)), within
``[dt_min, dt_max]``, and no larger than the rejected one right after a rejection.

**At dt_min** (:func:`rejected`): a step with ``err > 1`` is taken again only when the step that would replace it
(the controller's, landed on the output) is shorter.  Unclamped, the controller's factor is below
``SAFETY`` = 0.9 and landing stretches a step by at most ``1/(1 − (LANDING − 1))``, so the retry is at most
0.95 of the rejected step; clamped at ``dt_min``, the retry is ``dt_min`` landed, which a second rejection cannot
shorten.  So the steps tried from one state fall geometrically to ``dt_min`` and the controller ends: at
``dt_min`` (or the landing step just above it) a step over the tolerance is accepted and counted
(``/solver/steps_over_tolerance``), and the run ends with one warning giving their number and the largest
error norm.  (Before, the landing stretched ``dt_min`` by a few 1e-6, the stretched step was rejected, and
the controller clamped it back to ``dt_min``: the same step forever, from the same state.)

**Dead band** (Hairer & Wanner 1996, *Solving Ordinary Differential Equations II*, §IV.8, RADAU5's
``quot1``/``quot2`` rule): the step enters the Newton matrix's coefficients, so a new step costs a new
factorisation; an accepted step after which the controller proposes a growth factor in ``[1, DEAD_BAND)`` is
kept as it is (:func:`kept_step`), and so is its factor.

**Landing on the outputs** (no interpolation): the time left to the next output is divided into the fewest
equal steps no longer than the controller's step, or together at most ``(LANDING − 1) h`` longer
(:func:`landing_step`).  Between outputs equally spaced, a controller's step that changes little then gives
the same steps output after output, and the same factor.

**Compiled.**  The loop that applies these rules step after step runs in compiled code
(:func:`reference.algorithms.alpha_steps.steps`, many steps per call); the functions here are its
documented source and the oracle the tests compare it with, bit for bit
(:attr:`reference.algorithms.generalized_alpha.GeneralizedAlpha.python_control`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

MAX_CUTS = 10
"""Halvings of a step in a row before a run without ``error_tolerance`` stops (smallest step dt/1024)."""
GROW_AFTER = 4
"""Converged steps at a cut step before it is doubled (runs without ``error_tolerance``)."""
SAFETY, MIN_SHRINK, MAX_GROWTH = 0.9, 0.2, 2.0
"""The controller's safety factor and limits on the step ratio (Hairer, Nørsett & Wanner 1993, §II.4)."""
FLOOR = 1e-6
"""The error norm's absolute floor: a coordinate's increment over a step counts at least ``FLOOR · L`` [m]
(translations, L the model size) or ``FLOOR`` rad (rotations), so that a coordinate at rest is held to an
absolute error of ``error_tolerance · FLOOR · L`` per step."""
LANDING = 1.05
"""The time left to the next output is divided into equal steps, together at most ``(LANDING − 1) h`` longer than
steps of the controller's h (:func:`landing_step`)."""
DEAD_BAND = 1.2
"""An accepted step after which the controller proposes a growth factor in ``[1, DEAD_BAND)`` is kept, and its
factorisation with it (Hairer & Wanner 1996, §IV.8: RADAU5's ``quot1 = 1``, ``quot2 = 1.2``)."""


def error_norm(a_new: np.ndarray, a_old: np.ndarray, v: np.ndarray, w: np.ndarray, h: float, beta: float,
               L: float, tol: float) -> float:
    """The weighted local error norm of one step (module docstring): ``e = h² |β − 1/6| |a_{n+1} − a_n|``
    of every coordinate over ``tol`` × (its increment ``h |V|`` over the step + the floor, ``FLOOR · L`` [m]
    for translations, ``FLOOR`` rad for rotations), largest over the coordinates; ``v``, ``w`` (N, 3) the
    velocities at the step's end."""
    c = h * h * abs(beta - 1.0 / 6.0)
    ex = np.abs(a_new[:, :3] - a_old[:, :3]) * c / (tol * (h * np.abs(v) + FLOOR * L))
    er = np.abs(a_new[:, 3:] - a_old[:, 3:]) * c / (tol * (h * np.abs(w) + FLOOR))
    return max(float(ex.max(initial=0.0)), float(er.max(initial=0.0)))


def next_step(h: float, err: float) -> float:
    """The controller's next step after a step h with error norm ``err`` (module docstring)."""
    factor = MAX_GROWTH if err <= 0.0 else min(MAX_GROWTH, max(MIN_SHRINK, SAFETY * err ** (-1.0 / 3.0)))
    return h * factor


def landing_step(left: float, h: float) -> float:
    """The next step when ``left`` [s] remain to the next output and the controller proposes h: ``left / n``, the
    fewest equal steps that land on the output stretching none of them by more than ``(LANDING − 1) h / n``
    (module docstring)."""
    return left / max(1.0, math.ceil(left / h - (LANDING - 1.0)))


def rejected(err: float, h_use: float, h_retry: float, dt_min: float) -> bool:
    """Whether a step ``h_use`` [s] with error norm ``err`` is taken again: ``err > 1``, the step above ``dt_min``,
    and the step that would replace it, ``h_retry`` (:func:`landing_step` of the controller's next step), shorter
    (module docstring, "At dt_min": the rule that makes the controller end)."""
    return err > 1.0 and h_use > dt_min * (1.0 + 1e-12) and h_retry < h_use


def kept_step(h: float, h_next: float, band: float) -> float:
    """The step after an accepted step h for which the controller proposes ``h_next``: h itself when the growth
    ``h_next / h`` lies in ``[1, band)`` (the dead band, :data:`DEAD_BAND`; ``band = 1`` turns it off)."""
    return h if h <= h_next < band * h else h_next


@dataclass
class SolverStatistics:
    """Counts of an implicit run (generalized-α, static), in total and since the last output (``/solver/…``
    of the results).

    ``steps`` accepted steps, ``iterations`` Newton corrections, ``cuts`` steps cut after a Newton
    failure, ``rejected`` steps taken again for their error estimate, ``factorizations`` Newton
    matrices factored; ``h_min``, ``h_max`` the smallest and largest accepted step [s]; ``error`` the
    largest error estimate since the last output (NaN without error control); ``over`` the accepted steps
    whose error norm is above 1 (at ``dt_min``, :func:`rejected`), ``worst`` the largest error norm of the run
    (0: none); ``controlled`` whether the records carry ``steps_over_tolerance`` (error control).
    """

    steps: int = 0
    iterations: int = 0
    cuts: int = 0
    rejected: int = 0
    factorizations: int = 0
    h_min: float = np.inf
    h_max: float = 0.0
    error: float = np.nan
    over: int = 0
    worst: float = 0.0
    controlled: bool = False
    last: dict = field(default_factory=dict)

    def step(self, h: float, err: float = np.nan) -> None:
        """One accepted step of size h with error norm ``err``."""
        self.steps += 1
        self.h_min, self.h_max = min(self.h_min, h), max(self.h_max, h)
        if err == err:
            self.error = err if self.error != self.error else max(self.error, err)
            self.worst = max(self.worst, err)
            self.over += err > 1.0

    def output(self, h: float, residual: float) -> dict:
        """The record of the steps since the last output (record keys of ``/solver/…``); restarts the
        interval's error estimate."""
        totals = (self.steps, self.iterations, self.cuts, self.rejected, self.factorizations, self.over)
        before = self.last.get("totals", (0, 0, 0, 0, 0, 0))
        d = [a - b for a, b in zip(totals, before)]
        row = {"step_size": float(h), "newton_iterations": float(d[1]), "residual_norm": float(residual),
               "step_cuts": float(d[2] + d[3]), "factorizations": float(d[4]), "error_estimate": float(self.error),
               "steps": float(d[0])}
        if self.controlled:
            row["steps_over_tolerance"] = float(d[5])
        self.last = {"totals": totals}
        self.error = np.nan
        return row

    def summary(self, steps: str = "steps", dt: str = "dt") -> str:
        """One line: steps, step range, Newton iterations a step, step cuts, factorisations (``steps``,
        ``dt`` the words for a step and its size: "load steps", "load step" in a static run)."""
        if self.steps == 0:
            return f"no {steps} taken"
        span = (f"{dt} {self.h_min:.3g}" if self.h_max <= self.h_min * (1.0 + 1e-9)
                else f"{dt} {self.h_min:.3g}…{self.h_max:.3g}")
        cuts = f"{self.cuts:,} step cut{'s' * (self.cuts != 1)}"
        if self.rejected:
            cuts += f", {self.rejected:,} step{'s' * (self.rejected != 1)} rejected for their error"
        if self.over:
            cuts += f", {self.over:,} over the tolerance at dt_min (error up to {self.worst:.3g} × it)"
        noun = steps if self.steps != 1 else steps[:-1]
        return (f"{self.steps:,} {noun}, {span}, {self.iterations / self.steps:.1f} Newton iterations a step, "
                f"{cuts}, {self.factorizations:,} factorisations")
