"""``flexmbs bench``: solve times of the reference engine and of Exudyn, side by side.

Both engines solve the same dynamic problem from the same deck data, with the
same load history and time step, in one process, one after the other; each is
warmed up once (numba compilation, Exudyn's first-call set-up) and then timed
``repeat`` times; the table shows the median solve times and their ratio.
Only the solve is timed (model building excluded) on both sides.

Then the scaling of the constraint stage (:mod:`flexmbs.bench_scaling`: a chain of
K = 50 … 1,000 spherical links, two welded beams), the Beam2 throughput beside
PyElastica and the cost of ParaView output (:mod:`flexmbs.bench_throughput`).

Last, the implicit algorithms: the static roll-up against Exudyn's
static solver, and the work–precision study — for the three-bar and its steel
variant, each engine/algorithm at several steps, the error of the coupler's
mid-span deflection against a converged-in-time reference of the same mesh and
engine against the solve time; a figure, and the time of each at matched
accuracy (0.1 % of the peak deflection) with the ratios; the element families
(:mod:`flexmbs.bench_families`).  Last, the large models beside PyElastica and
Exudyn and the thread-scaling table (:mod:`flexmbs.bench_large`; ``--large``: that
section alone).  ``FLEXMBS_QUICK=1`` (or ``--quick``) runs fewer steps, and the
large models on small meshes.  ``--first-run``: only the first-run table, every deck's first ``flexmbs run`` from
an empty numba cache beside its warm rerun (:mod:`flexmbs.bench_first_run`; minutes).

Every line with a target ends in ``MET`` or ``MISSED`` (:class:`flexmbs.bench_common.Target`); the last
lines list the missed targets (:func:`flexmbs.bench_common.target_summary`), and the command exits with
status 1 when one is missed.
"""

from __future__ import annotations

import math
import os
import statistics
import time
from pathlib import Path

import numpy as np

from flexmbs.bench_common import COMPILED, MATCHED, ROOT, WP_CASES, Target, matched_time, target_summary


def time_reference(deck: Path, repeat: int) -> tuple[float, int]:
    from reference.io.deck import load_deck

    domain = load_deck(deck, overrides={"solver.backend": COMPILED}).domain
    domain.solve()  # warm-up: numba compiles (or loads its cache)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        domain.solve()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), int(round(domain.solver.t_end / domain.solver.dt))


def time_exudyn(deck: Path, repeat: int) -> tuple[float, int]:
    """Exudyn on the same deck through the generic translation (crosscheck.exudyn_model)."""
    from crosscheck.exudyn_model import solve
    from reference.io.deck import load_deck

    settings = load_deck(deck).domain.solver
    # warm-up, to the first output at least (Exudyn's run is checked to end on the output grid)
    solve(load_deck(deck).domain, t_end=max(20, settings.output_every) * settings.dt)
    times, steps = [], 0
    for _ in range(repeat):
        out = solve(load_deck(deck).domain)
        times.append(out["wall_time"])
        steps = out["steps"]
    return statistics.median(times), steps


CASES = {
    "embedded beam roll-up (12 Beam2, 10,000 steps)": ROOT / "models" / "embedded_beam.toml",
    "three-bar mechanism (4 Beam2 + 2 rigid, 5 joints, 50,000 steps)": ROOT / "models" / "three_bar.toml",
}


REPEAT = 3
"""Timed rounds per point of the work–precision study, the engines alternating (the fastest
counts; fewer rounds when one takes seconds)."""


def _deflection_runner(deck: Path, t_end: float, every: float, algorithm: str, dt: float, engine: str):
    """A warmed-up solver of ``deck`` to ``t_end`` with one engine/algorithm at step dt: a callable
    returning (solve time [s], output times every ``every`` seconds (or every step if longer),
    coupler mid-span deflection)."""
    from flexmbs.verification import observables as ob
    from reference.io.deck import load_deck

    def domain():
        d = load_deck(deck, overrides={"t_end": t_end, "solver.backend": COMPILED}).domain
        d.solver.algorithm, d.solver.dt = algorithm, dt
        d.solver.output_every = max(int(round(every / dt)), 1)
        return d

    if engine == "flexmbs":
        d = domain()
        d.solve(t_end=max(20 * dt, 0.01))  # warm-up (numba cache, first-call set-up)

        def run():
            t0 = time.perf_counter()
            r = d.solve()
            return time.perf_counter() - t0, r.time, ob.midspan_deflection(r)
    else:
        from crosscheck.exudyn_model import solve

        warm = domain()
        solve(warm, dt=dt, t_end=max(20, warm.solver.output_every) * dt)  # warm-up, to the first output at least

        def run():
            out = solve(domain(), dt=dt)
            return out["wall_time"], out["results"].time, ob.midspan_deflection(out["results"])
    return run


def _timed(runners) -> list:
    """Run the runners in turn, up to ``REPEAT`` rounds (fewer when a round takes seconds), so
    that all see the same machine load; each keeps its fastest time."""
    best = [None] * len(runners)
    spent = 0.0
    for _ in range(REPEAT):
        for k, run in enumerate(runners):
            wall, tt, dd = run()
            spent += wall
            if best[k] is None or wall < best[k][0]:
                best[k] = (wall, tt, dd)
        if spent > 5.0:
            break
    return best


def _error(times, defl, ref_times, ref_defl) -> float:
    """Max deflection error on the common output times, relative to the reference's peak."""
    common = np.intersect1d(np.round(times, 9), np.round(ref_times, 9))
    a = np.interp(common, times, defl)
    b = np.interp(common, ref_times, ref_defl)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(ref_defl)))


def _whole_step(limit: float, every: float) -> float:
    """The largest step ≤ ``limit`` that divides the output interval ``every`` (hence the end time)."""
    return every / int(np.ceil(every / limit))


def work_precision(quick: bool = False) -> dict:
    """Error against a converged-in-time reference of the same mesh and engine, and solve time,
    for flexmbs explicit, flexmbs generalized-α and Exudyn's generalized-α (ρ∞ = 0.8, the
    decks' value) at several steps.  Returns ``{case: {"series": {name: [(dt, time, error)]}, …}}``."""
    from reference.io.deck import load_deck

    data = {}
    for name, (deck_name, t_end, every, implicit, explicit, dt_ref) in WP_CASES.items():
        deck = ROOT / "models" / deck_name
        if quick:
            implicit, explicit = implicit[1:4], explicit[:1]
        crit = load_deck(deck).domain.critical_time_step()
        series, refs = {}, {}
        for engine in ("flexmbs", "exudyn"):
            _, rt, rd = _deflection_runner(deck, t_end, every, "generalized_alpha", dt_ref, engine)()
            refs[engine] = (rt, rd)
            series[f"{engine} generalized-α"] = []
        for dt in implicit:
            runs = _timed([_deflection_runner(deck, t_end, every, "generalized_alpha", dt, e)
                           for e in ("flexmbs", "exudyn")])
            for engine, (wall, tt, dd) in zip(("flexmbs", "exudyn"), runs):
                series[f"{engine} generalized-α"].append((dt, wall, _error(tt, dd, *refs[engine])))
        rows = []
        for frac in explicit:
            dt = _whole_step(frac * crit, every)
            (wall, tt, dd), = _timed([_deflection_runner(deck, t_end, every, "staggered_central_difference", dt,
                                                         "flexmbs")])
            rows.append((dt, wall, _error(tt, dd, *refs["flexmbs"])))
        series["flexmbs explicit"] = rows
        data[name] = {"series": series, "t_end": t_end, "peak": float(np.max(np.abs(refs["flexmbs"][1]))),
                      "dt_ref": dt_ref}
    return data


def work_precision_table(data: dict) -> list[str]:
    """Markdown lines: every run, then the time at matched accuracy and the ratio to Exudyn."""
    lines = []
    for name, case in data.items():
        lines += [f"**{name}**, {case['t_end']:g} s; reference: each engine's own generalized-α at "
                  f"dt = {case['dt_ref']:g}; peak coupler deflection {case['peak']:.3e} m", "",
                  "| engine / algorithm | dt [s] | solve [s] | error / peak |", "|---|---|---|---|"]
        for series, rows in case["series"].items():
            for dt, wall, err in rows:
                lines.append(f"| {series} | {dt:.3g} | {wall:.4f} | {err:.2e} |")
        lines += ["", f"At matched accuracy ({MATCHED:.1%} of the peak deflection):", "",
                  "| engine / algorithm | solve [s] | how | ratio to Exudyn |", "|---|---|---|---|"]
        t_ex, _ = matched_time(case["series"]["exudyn generalized-α"])
        for series, rows in case["series"].items():
            t, how = matched_time(rows)
            if t is None:
                lines.append(f"| {series} | – | {how} | – |")
            else:
                ratio = f"{t / t_ex:.3f}" if t_ex else "–"
                lines.append(f"| {series} | {t:.4f} | {how} | {ratio} |")
        lines.append("")
    return lines


def work_precision_figure(data: dict, path: Path) -> Path:
    """Error against solve time (log–log), one panel per case; returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(data), figsize=(5.2 * len(data), 4.2))
    for ax, (name, case) in zip(np.atleast_1d(axes), data.items()):
        for (series, rows), marker in zip(case["series"].items(), "os^"):
            rows = sorted(rows)
            ax.loglog([r[1] for r in rows], [r[2] for r in rows], marker=marker, label=series)
        ax.axhline(MATCHED, color="0.5", lw=0.8, ls="--", label=f"matched accuracy {MATCHED:.1%}")
        ax.set_xlabel("solve time [s]")
        ax.set_ylabel("max deflection error / peak")
        ax.set_title(name)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def static_rollup(targets: list | None = None) -> list[str]:
    """The roll-up with ``algorithm = "static"``, 20 load steps: flexmbs against Exudyn's static
    solver, same process (median of 5 interleaved solves after a warm-up), and the tip against
    the discrete polygon."""
    from crosscheck.exudyn_model import solve
    from flexmbs.verification.analytic import polygon_tip
    from reference.domain import SolverSettings
    from reference.io.deck import load_deck

    def domain():
        d = load_deck(ROOT / "models" / "embedded_beam.toml").domain
        d.solver = SolverSettings(algorithm="static", t_end=2.0, load_steps=20, dt=0.1, backend=COMPILED)
        return d

    d = domain()
    d.solve()
    solve(domain())
    ours, theirs = [], []
    for _ in range(5):  # interleaved, so that both see the same machine load
        t0 = time.perf_counter()
        r = d.solve()
        ours.append(time.perf_counter() - t0)
        theirs.append(solve(domain())["wall_time"])
    err = np.linalg.norm(r.position("beam:12")[10] - polygon_tip(10.0, 12, 1.0)) / 10.0
    t_o, t_e = statistics.median(ours), statistics.median(theirs)
    target = Target("static roll-up, flexmbs / Exudyn", t_o / t_e, 0.3, "{:.3f}")
    (targets if targets is not None else []).append(target)
    return ["**Static roll-up** (12 Beam2, 20 load steps to k = 2), median of 5 interleaved solves:", "",
            "| engine | solve [s] |", "|---|---|", f"| flexmbs static | {t_o:.4f} |",
            f"| Exudyn static solver | {t_e:.4f} |", "",
            f"ratio flexmbs / Exudyn = {t_o / t_e:.3f} (target ≤ 0.3) {target.mark}; flexmbs tip at k = 1 "
            "against the "
            f"discrete 12-chord polygon: {err:.1e} L", ""]


def main(args=None) -> int:
    repeat = getattr(args, "repeat", 3) or 3
    rows, targets = [], []
    quick = bool(getattr(args, "quick", False)) or os.environ.get("FLEXMBS_QUICK") == "1"
    if getattr(args, "large", False):
        return large(quick, repeat, targets)
    if getattr(args, "first_run", False):
        from flexmbs.bench_first_run import every_deck, table

        print("\n".join(table(every_deck())))
        return 0
    print(f"flexmbs bench: median of {repeat} timed solves after one warm-up, same process, same data")
    for name, deck in CASES.items():
        t_ref, n_ref = time_reference(deck, repeat)
        t_exu, n_exu = time_exudyn(deck, repeat)
        rows.append((name, t_ref, n_ref, t_exu, n_exu))
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'reference [s]':>13}  {'Exudyn [s]':>10}  {'ratio':>6}  steps (ref/Exudyn)  target")
    for name, t_ref, n_ref, t_exu, n_exu in rows:
        target = Target(f"{name}, reference / Exudyn", t_ref / t_exu if t_exu > 0 else math.nan, 0.3, "{:.3f}")
        targets.append(target)
        print(f"{name:<{width}}  {t_ref:13.4f}  {t_exu:10.4f}  {t_ref / t_exu:6.3f}  {f'{n_ref}/{n_exu}':<18}  "
              f"{target.mark}")
    print("ratio = reference time / Exudyn time (target ≤ 0.3)")
    print()
    from flexmbs.bench_scaling import chain_scaling, welded_vs_shared
    from flexmbs.bench_throughput import beam_throughput, vtk_cost

    chain_scaling(repeat, targets=targets)
    print()
    welded_vs_shared(repeat, targets=targets)
    print()
    beam_throughput(repeat, targets=targets)
    print()
    vtk_cost(targets=targets)
    print()
    from flexmbs.bench_modes import modes_timing

    print("\n".join(modes_timing(repeat, targets)))
    print()
    from flexmbs.bench_sensitivity import sensitivity_timing

    print("\n".join(sensitivity_timing(repeat, targets)))
    print()
    lines = static_rollup(targets)
    print("\n".join(lines))
    data = work_precision(quick)
    table = work_precision_table(data)
    print("\n".join(table))
    from flexmbs.bench_adaptive import tolerance_table

    adaptive = tolerance_table(data, quick, targets)
    print("\n".join(adaptive))
    table = table + adaptive
    out = Path(getattr(args, "out", None) or ROOT / "out" / "bench")
    figure = work_precision_figure(data, out / "work_precision.png")
    (out / "work_precision.md").write_text("\n".join(lines + table + [f"![work-precision]({figure.name})", ""]),
                                           encoding="utf-8")
    print(f"figure and tables: {figure}, {out / 'work_precision.md'}")
    print()
    from flexmbs import bench_families

    families = bench_families.work_precision(quick)
    lines = bench_families.table(families)
    print("\n".join(lines))
    figure = bench_families.figure(families, out / "work_precision_families.png")
    (out / "work_precision_families.md").write_text("\n".join(lines + [f"![work-precision]({figure.name})", ""]),
                                                    encoding="utf-8")
    ratio = bench_families.target_lines(families)[1]
    targets.append(Target("element families at 1e-6 L, best / Beam2 solve time", 1.0 / ratio, 0.1, "{:.3f}"))
    coupler, worst = bench_families.coupler_crosscheck(out / "three_bar_beam3_crosscheck", t_end=1.0 if quick else None)
    print("\n".join(coupler))
    targets.append(Target("three-bar, beam3 coupler against Exudyn (converged meshes): worst verdict / tolerance",
                          worst, 1.0, "{:.3f}"))
    print()
    return large(quick, repeat, targets)


def large(quick: bool, repeat: int, targets: list) -> int:
    """The large-model section (:mod:`flexmbs.bench_large`), then the closing target lines; the exit status."""
    from flexmbs.bench_large import large_models

    large_models(quick, max(repeat, 5), targets)
    closing, status = target_summary(targets)
    print("\n".join(closing))
    return status
