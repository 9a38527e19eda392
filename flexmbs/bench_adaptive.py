"""``make bench``: work–precision of generalized-α at a requested ``error_tolerance``.

For each work–precision case of :data:`flexmbs.bench.WP_CASES`: the error of the coupler's mid-span
deflection against the converged run of the same mesh (relative to its peak, as the fixed-step table)
and the solve time at ``error_tolerance`` = 1e-2 … 1e-6 with no ``dt`` (outputs at the deck's interval,
steps landing on them), beside the time Exudyn's generalized-α at a fixed step needs for the same error
(log–log interpolation of its fixed-step rows, :func:`flexmbs.bench.matched_time`).
"""

from __future__ import annotations

import time

import numpy as np

TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def tolerance_rows(deck, t_end: float, every: float, dt_ref: float, tolerances=TOLERANCES) -> tuple[list, float]:
    """``[(tolerance, achieved error, solve time [s], steps, step cuts)]`` and the reference's peak deflection."""
    from flexmbs.verification import observables as ob
    from reference.domain import Domain

    def domain(**solver):
        d = Domain.from_deck(deck, overrides={"t_end": t_end})
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


def tolerance_table(data: dict, quick: bool = False) -> list[str]:
    """Markdown lines of the tolerance rows of every case, with Exudyn's fixed-step time at each achieved
    error from the fixed-step work–precision ``data`` (:func:`flexmbs.bench.work_precision`)."""
    from flexmbs.bench import ROOT, WP_CASES, matched_time

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
    return lines
