"""``make bench``: work–precision of generalized-α at a requested ``error_tolerance``.

For each work–precision case of :data:`flexmbs.bench_common.WP_CASES`: the error of the coupler's mid-span
deflection against the converged run of the same mesh (relative to its peak, as the fixed-step table)
and the solve time at ``error_tolerance`` = 1e-2 … 1e-6 with no ``dt`` (outputs at the deck's interval,
steps landing on them), beside the time Exudyn's generalized-α at a fixed step needs for the same error
(log–log interpolation of its fixed-step rows, :func:`flexmbs.bench_common.matched_time`).
"""

from __future__ import annotations

import math
import time

import numpy as np

TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def tolerance_rows(deck, t_end: float, every: float, dt_ref: float, tolerances=TOLERANCES) -> tuple[list, float]:
    """``[(tolerance, achieved error, solve time [s], steps, step cuts)]`` and the reference's peak deflection."""
    from flexmbs.verification import observables as ob
    from reference.io.deck import load_deck

    def domain(**solver):
        d = load_deck(deck, overrides={"t_end": t_end}).domain
        d.solver.algorithm = "generalized_alpha"
        for key, value in solver.items():
            setattr(d.solver, key, value)
        return d

    ref = domain(dt=dt_ref, output_every=max(int(round(every / dt_ref)), 1)).solve()
    ref_defl = ob.midspan_deflection(ref)
    peak = float(np.max(np.abs(ref_defl)))
    rows = []
    for tol in tolerances:
        d = domain(dt=every, output_every=1, error_tolerance=tol)
        d.solve(t_end=min(20 * every, t_end))  # warm-up
        t0 = time.perf_counter()
        r = d.solve()
        wall = time.perf_counter() - t0
        defl = np.interp(ref.time, r.time, ob.midspan_deflection(r))
        stats = d.last_run["solver"].stats
        rows.append((tol, float(np.max(np.abs(defl - ref_defl)) / peak), wall, stats.steps,
                     stats.cuts + stats.rejected))
    return rows, peak


def tolerance_table(data: dict, quick: bool = False, targets: list | None = None) -> list[str]:
    """Markdown lines of the tolerance rows of every case, with Exudyn's fixed-step time at each achieved
    error from the fixed-step work–precision ``data`` (:func:`flexmbs.bench.work_precision`), then the
    mechanism with near-singular passages (:func:`near_singular_rows`, its targets into ``targets``)."""
    from flexmbs.bench_common import ROOT, WP_CASES, matched_time

    lines = ["### generalized-α at a requested error (error_tolerance, no dt)", "",
             "| case | error_tolerance | achieved error | achieved / requested | solve [s] | steps | steps taken again "
             "| Exudyn generalized-α, fixed step, same error [s] |", "|---|---|---|---|---|---|---|---|"]
    for name, (deck_name, t_end, every, _, _, dt_ref) in WP_CASES.items():
        rows, _ = tolerance_rows(ROOT / "models" / deck_name, t_end, every, dt_ref,
                                 TOLERANCES[1:4] if quick else TOLERANCES)
        exudyn = data.get(name, {}).get("series", {}).get("exudyn generalized-α", [])
        for tol, err, wall, steps, again in rows:
            t_exu, how = matched_time(exudyn, err) if exudyn else (None, "not run")
            exu = f"{t_exu:.3g} ({how})" if t_exu is not None else how
            lines.append(f"| {name} | {tol:g} | {err:.3g} | {err / tol:.3g} | {wall:.3f} | {steps:,} | {again:,} | {exu} |")
    lines.append("")
    return lines + near_singular_rows(targets, quick)


FOUR_BAR = ("bench_decks/bauchau_four_bar.toml", 12.0, 1e-2)
"""The mechanism with near-singular passages: deck (below flexmbs/), t_end [s], output interval [s]."""
FOUR_BAR_REFERENCE = (1e-5, 1e-12)
"""The four-bar's reference: fixed-step generalized-α at this step [s] (1.2 million steps) and Newton tolerance.
Its own error is shown beside it: the difference to the run at twice its step (the last of
:data:`FOUR_BAR_FIXED`) over 3, the second-order estimate."""
FOUR_BAR_FIXED = (6.25e-4, 3.125e-4, 1.5625e-4, 7.8125e-5, 4e-5, 2e-5)
"""Fixed steps [s] beside the controlled run (the deck's default Newton tolerance, as the controlled run), each a
divisor of the output interval so that every run has the same output times."""
FOUR_BAR_TOLERANCES = (1e-2, 1e-3)
"""The controlled runs' ``error_tolerance``; the target is read at :data:`FOUR_BAR_TOLERANCE`."""
FOUR_BAR_TOLERANCE, FOUR_BAR_ERROR, FOUR_BAR_SPEED = 1e-3, 2e-3, 0.5
"""The target: at error_tolerance 1e-3 the achieved error ≤ 2e-3 of the peak over the whole run, in at most
half the time of the fixed-step run that reaches the same error (log–log interpolation between the two fixed
steps that bracket it, :func:`flexmbs.bench_common.matched_time`)."""


def near_singular_rows(targets: list | None = None, quick: bool = False) -> list[str]:
    """Markdown lines of the four-bar with near-singular passages (:data:`FOUR_BAR`): the error of the
    coupler's mid-span deflection vector (its largest norm over the run, relative to the peak norm of the
    reference) and the solve time of generalized-α at ``error_tolerance`` = :data:`FOUR_BAR_TOLERANCES`
    and at the fixed steps :data:`FOUR_BAR_FIXED`; the targets (``targets``, :class:`flexmbs.bench_common.Target`)
    on the error and on the time ratio to the fixed step of the same error.  ``quick``: not run."""
    from pathlib import Path

    from flexmbs.bench_common import Target, matched_time
    from reference.io.deck import load_deck
    from reference.observables import parse

    deck_name, t_end, every = FOUR_BAR
    deck = Path(__file__).resolve().parent / deck_name
    title = f"### A mechanism with near-singular passages: {deck_name} ({t_end:g} s)"
    if quick:
        return [title, "", "not run with --quick (a converged reference takes a million steps)", ""]

    def run(**solver):
        d = load_deck(deck, overrides={"t_end": t_end}).domain
        for key, value in solver.items():
            setattr(d.solver, key, value)
        d.solve(t_end=20 * every)  # warm-up
        t0 = time.perf_counter()
        r = d.solve()
        wall = time.perf_counter() - t0
        return wall, parse("midspan_deflection:coupler", r).evaluate(r), d.last_run["solver"].stats

    def every_steps(dt):
        return max(int(round(every / dt)), 1)

    dt_ref, tol_ref = FOUR_BAR_REFERENCE
    _, ref, _ = run(dt=dt_ref, output_every=every_steps(dt_ref), tolerance=tol_ref)
    peak = float(np.max(np.linalg.norm(ref, axis=1)))

    def error(defl):
        return float(np.max(np.linalg.norm(defl - ref, axis=1)) / peak)

    lines = [title, "",
             f"Reference: fixed-step generalized-α at dt = {dt_ref:g} (Newton tolerance {tol_ref:g}); peak mid-span "
             f"deflection of the coupler {peak:.3e} m; error = largest deflection difference over the run / peak.", "",
             "| run | solve [s] | steps | steps taken again | factorisations | error / peak |", "|---|---|---|---|---|---|"]
    controlled = {}
    for tol in FOUR_BAR_TOLERANCES:
        wall, defl, s = run(dt=every, output_every=1, error_tolerance=tol)
        controlled[tol] = (wall, error(defl))
        lines.append(f"| error_tolerance = {tol:g} | {wall:.2f} | {s.steps:,} | {s.rejected + s.cuts:,} | "
                     f"{s.factorizations:,} | {controlled[tol][1]:.3g} |")
    fixed = []
    for dt in FOUR_BAR_FIXED:
        w, d, s = run(dt=dt, output_every=every_steps(dt))
        fixed.append((dt, w, error(d)))
        lines.append(f"| fixed dt = {dt:g} | {w:.2f} | {s.steps:,} | {s.cuts:,} | {s.factorizations:,} | "
                     f"{fixed[-1][2]:.3g} |")
    lines.append(f"| (the reference's own error, second-order estimate from the last row: {fixed[-1][2] / 3:.2g}) "
                 "| | | | | |")
    wall, achieved = controlled[FOUR_BAR_TOLERANCE]
    t_fixed, how = matched_time(fixed, achieved)
    ratio = wall / t_fixed if t_fixed else math.nan
    found = (f"fixed step at the same error {t_fixed:.2f} s, {how}" if t_fixed
             else "no fixed step of the list reaches the same error")
    checks = [Target(f"four-bar, error_tolerance {FOUR_BAR_TOLERANCE:g}: error / peak", achieved, FOUR_BAR_ERROR),
              Target(f"four-bar, error_tolerance {FOUR_BAR_TOLERANCE:g}: solve time / fixed step's at the same error "
                     f"({found})", ratio, FOUR_BAR_SPEED)]
    if targets is not None:
        targets.extend(checks)
    return lines + [""] + [f"{t.describe()} {t.mark}" for t in checks] + [""]
