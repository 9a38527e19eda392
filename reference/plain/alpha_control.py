"""Generalized-α's step size on the reference path: which steps lead to the next output (:func:`to_output`).

The rules are the compiled algorithm's (:mod:`reference.algorithms.generalized_alpha`,
:mod:`reference.algorithms.alpha_steps`; the controller and its constants in
:mod:`reference.algorithms.step_control`, docs/formulation.md §13), as its Python oracle
:func:`reference.algorithms.alpha_python_control.controlled_python` applies them:

- fixed steps of ``dt`` while every step converges;
- a step whose Newton iteration fails is halved (down to ``dt_min``); the step then grows back, doubling after
  ``GROW_AFTER`` converged steps up to the step that failed, that ceiling doubling at every output, and the
  steps return to fixed once they are ``dt`` again;
- with ``error_tolerance`` every step is chosen by the controller from the local error estimate, a step whose
  estimate is over the tolerance is taken again shorter, and the steps land on every output.
"""

from __future__ import annotations

from dataclasses import dataclass

from reference.algorithms.alpha_steps import RECOVERABLE
from reference.algorithms.step_control import GROW_AFTER, error_norm, kept_step, landing_step, next_step, rejected
from reference.status import OK


@dataclass
class StepControl:
    """The step size's state: ``h`` the step being taken [s], ``h_next`` the next one the controller or the growth
    proposes, ``ceiling`` the step a cut step grows back to, ``good`` the converged steps since the last cut,
    ``after_rejection`` whether the last step was rejected, ``varying`` whether the steps are chosen one by one
    (error control, or a cut step growing back), ``nominal`` the steps of ``dt`` reached (the output grid)."""

    h: float
    ceiling: float
    varying: bool = False
    h_next: float = 0.0
    good: int = 0
    after_rejection: bool = False
    nominal: int = 0

    def __post_init__(self):
        self.h_next = self.h_next or self.h


def to_output(algo, state, run, n_steps: int) -> int:
    """Advance ``state`` to the output ``n_steps`` steps of ``dt`` ahead (``algo`` a
    :class:`reference.plain.generalized_alpha.PlainGeneralizedAlpha`, ``run`` its run); the status."""
    c, clock = run.control, state.clock[0]
    done, code = 0, OK
    if not c.varying:
        for _ in range(n_steps):
            code = algo.step(state, run, algo.dt)
            if code != OK:
                break
            done += 1
            clock["n"] += 1
            clock["t"] = run.start[0] + (clock["n"] - run.start[1]) * algo.dt
        c.nominal += done
        if code == OK:
            return OK
        if code not in RECOVERABLE or not _cut(algo, run, algo.dt):
            return code
    return _varying(algo, state, run, n_steps - done)


def _cut(algo, run, h: float) -> bool:
    """Halve the step h that failed (False when below ``dt_min``: the run stops, ``run.tried`` says why)."""
    c = run.control
    if 0.5 * h < algo.dt_min * (1.0 - 1e-12):
        run.tried = (f"with the step cut from {algo.dt:g} to {h:g} s" if algo.error_tolerance is None
                     else f"with the step at dt_min = {algo.dt_min:g} s")
        return False
    run.stats.cuts += 1
    c.h_next = c.ceiling = 0.5 * h
    c.good, c.varying = 0, True
    return True


def _varying(algo, state, run, n_steps: int) -> int:
    """Steps chosen one by one to the output ``n_steps`` steps of ``dt`` ahead, the last landing on it."""
    c, clock, stats = run.control, state.clock[0], run.stats
    target = run.start[0] + (c.nominal + n_steps) * algo.dt
    while target - clock["t"] > 1e-9 * algo.dt:
        left = target - clock["t"]
        h = c.h_next
        c.h = h_use = landing_step(left, h)
        a_old = run.alpha.a.copy()
        restore = (*state[:6], *run.alpha.arrays(), run.newton.angle)
        saved = [a.copy() for a in restore]
        code = algo.step(state, run, h_use, count=False)
        if code != OK:
            if code not in RECOVERABLE or not _cut(algo, run, h_use):
                return code
            continue
        if algo.error_tolerance is None:
            stats.step(h_use)
            c.good += 1
            if c.h_next < c.ceiling and c.good >= GROW_AFTER:
                c.h_next, c.good = min(2.0 * c.h_next, c.ceiling), 0
        else:
            err = error_norm(run.alpha.a, a_old, state.v, state.w, h_use, algo.beta, run.L, algo.error_tolerance)
            h_next = min(max(next_step(h_use, err), algo.dt_min), algo.dt_max)
            if rejected(err, h_use, landing_step(left, h_next), algo.dt_min):
                for array, old in zip(restore, saved):
                    array[...] = old
                stats.rejected += 1
                c.h_next, c.after_rejection = h_next, True
                continue
            if c.after_rejection:
                h_next, c.after_rejection = min(h_next, h_use), False  # no growth right after a rejection (HNW §II.4)
            h_next = kept_step(h_use, h_next, algo.dead_band)
            stats.step(h_use, err)
            c.h_next = h_next if h_use >= h else max(h, h_next)  # a step shortened to land keeps the controller's
        clock["n"] += 1
        clock["t"] += h_use
    clock["t"] = target
    c.nominal += n_steps
    c.ceiling = min(2.0 * c.ceiling, algo.dt)
    if algo.error_tolerance is None and c.h_next == algo.dt:
        c.varying, c.h, run.start = False, algo.dt, (float(clock["t"]), int(clock["n"]))  # back to the fixed steps
    return OK
