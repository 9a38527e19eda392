"""The step control of generalized-α in Python: the oracle of the compiled control.

:func:`controlled_python` steps a :class:`~reference.algorithms.generalized_alpha.GeneralizedAlpha` run to the
next output with the rules of :mod:`reference.algorithms.step_control` (local error estimate, controller,
rejection and restore, the step cuts' growing back, landing on the output) applied in Python around one
compiled step of :data:`~reference.algorithms.alpha_steps.FIXED` mode per call.  The runs use the compiled
control (:func:`reference.algorithms.alpha_steps.steps` chooses the steps itself, many per call); this loop is
the documented reference that tests/test_step_control.py compares it with, bit for bit
(:attr:`~reference.algorithms.generalized_alpha.GeneralizedAlpha.python_control`).  It is its own module
because no run needs it: it is a test oracle, not a step of the algorithm.
"""

from __future__ import annotations

import numpy as np

from reference.algorithms import alpha_steps as ak
from reference.algorithms.alpha_steps import RECOVERABLE, set_step
from reference.algorithms.step_control import GROW_AFTER, error_norm, kept_step, landing_step, next_step, rejected
from reference.status import OK


def controlled_python(alpha, state, run, n_steps, rec) -> int:
    """:meth:`~reference.algorithms.generalized_alpha.GeneralizedAlpha._controlled` of the algorithm ``alpha``
    with the step control in Python (:mod:`reference.algorithms.step_control`'s functions) around one compiled
    step of :data:`~reference.algorithms.alpha_steps.FIXED` mode per call: the steps to the output time
    ``n_steps`` steps of ``dt`` ahead; the status."""
    system, par, stats = run.system, run.fields, run.stats
    x, q, v, w, f_prev = state[:5]
    clock = state.clock[0]
    par["control"] = ak.FIXED
    target = (run.nominal + n_steps) * alpha.dt
    control = alpha.error_tolerance is not None
    held = (x, q, v, w, run.vd, run.a, run.lam, state.clock, f_prev, run.powers)  # what a rejected step restores
    saved, after_rejection = None, False
    while True:
        left = target - clock["t"]
        if left <= 1e-9 * alpha.dt:
            break
        h = par["h_next"]
        h_use = landing_step(left, h)
        set_step(par, h_use, clock["t"], clock["n"])
        if control:
            saved = [arr.copy() for arr in held]
        angle = system.work.angle.copy()
        code, done = alpha._steps(state, run, 1, rec)
        if code != OK:
            system.work.angle[:] = angle
            if code not in RECOVERABLE:
                return code
            code = alpha._cut(state, run, code)
            if code != OK:
                return code
            continue
        if control:
            err = error_norm(run.a, saved[5], v, w, h_use, alpha.beta, run.L, alpha.error_tolerance)
            h_next = min(max(next_step(h_use, err), alpha.dt_min), alpha.dt_max)
            if rejected(err, h_use, landing_step(left, h_next), alpha.dt_min):
                for arr, old in zip(held, saved):
                    arr[...] = old
                system.work.angle[:] = angle
                par["U"] = np.nan  # the last evaluation is no longer at the state
                stats.rejected += 1
                par["h_next"] = h_next
                after_rejection = True
                continue
            if after_rejection:
                h_next, after_rejection = min(h_next, h_use), False  # no growth right after a rejection (HNW §II.4)
            h_next = kept_step(h_use, h_next, alpha.dead_band)
            stats.step(h_use, err)
            # a step shortened to land on an output keeps the controller's step for the next
            par["h_next"] = h_next if h_use >= h else max(h, h_next)
        else:
            stats.step(h_use)
            par["good"] += 1
            if par["h_next"] < par["ceiling"] and par["good"] >= GROW_AFTER:
                par["h_next"], par["good"] = min(2.0 * par["h_next"], par["ceiling"]), 0
    clock["t"] = target
    alpha._landed(state, run, n_steps)
    return OK
