"""How a step ends: the status codes the compiled steps return, and the messages they become.

Every algorithm's ``advance`` returns one of these codes; the solution loop
(:func:`reference.solution.run`) turns a code other than :data:`OK` into the
results file's ``status`` and a one-paragraph message with the fix, through the
algorithm's ``failure`` (which fills in what it knows: the step, the critical step,
its Newton settings) and the functions below.
"""

from __future__ import annotations

OK = 0
"""The steps were taken."""
DIVERGED = 1
"""The state became non-finite (left at the last finite step)."""
SINGULAR = 2
"""The constraint matrix (explicit) or the Newton matrix (implicit) lost rank."""
BLOWUP = 3
"""The explicit scheme's energy balance failed (:mod:`reference.monitor`)."""
NO_CONVERGENCE = 4
"""Newton did not converge within its iterations (after the step cuts the algorithm makes)."""
REFACTOR = 5
"""Internal to generalized-α's compiled steps: the kept factor contracts too slowly; the caller
refactors the Newton matrix and resumes the step."""


REGULARISE = "Regularise the joints (epsilon > 0) or remove the redundancy."
"""The advice of singular constraints without a better diagnosis (:func:`reference.monitor.rediagnosed`)."""


def explicit_failure(code: int, t_last: float, cause: str) -> tuple[str, str]:
    """``(status, message)`` of a failed explicit step after ``t_last`` [s]; ``cause`` the likely
    cause and fix of a blow-up (:func:`reference.monitor.likely_cause`)."""
    if code == SINGULAR:
        return (f"singular constraints after t = {t_last:.6g}",
                f"the constraint matrix became singular after t = {t_last:.6g} "
                f"(redundant or degenerate joints); results up to that time are kept. {REGULARISE}")
    what = "the energy balance failed" if code == BLOWUP else "the solution became non-finite"
    return (f"diverged after t = {t_last:.6g}",
            f"{what} after t = {t_last:.6g}: {cause}; results up to then kept")


def newton_failure(code: int, where: str, max_iterations: int, cut_note: str, fix: str) -> tuple[str, str]:
    """``(status, message)`` of a failed implicit step at ``where`` (e.g. ``"t = 0.25"`` or
    ``"load factor 0.5"``); ``cut_note`` what was tried besides the iterations, ``fix`` what to change."""
    if code == SINGULAR:
        return (f"singular tangent at {where}",
                f"the Newton matrix became singular at {where} (a mechanism with an unconstrained "
                "motion, redundant or degenerate joints, or a buckling point); results up to there are kept. "
                "Constrain the free motion, regularise the joints (epsilon > 0) or stop before the limit point.")
    if code == NO_CONVERGENCE:
        return (f"Newton did not converge at {where}",
                f"Newton did not converge beyond {where} within {max_iterations} iterations"
                f"{' ' + cut_note if cut_note else ''}; results up to there are kept. {fix}")
    return (f"diverged after {where}",
            f"the solution became non-finite after {where}; results up to there are kept. Check the loads.")
