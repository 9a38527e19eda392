"""``flexmbs bench``: large models beside PyElastica and Exudyn at matched accuracy, and thread scaling.

* **Explicit, 50,000 elements**: the throughput rod (:data:`flexmbs.bench_throughput.THROUGHPUT`, a
  clamped 10 m rod under a constant end moment) meshed with 50,000 elements, flexmbs beside PyElastica at
  the same step (3/4 of flexmbs' critical step estimate).  The largest stable step of each code is
  probed (:data:`PROBE_FACTORS`), the error of each is its tip deflection against its own run at half the
  step, and the cost per element-step is timed with the runs alternating.
* **Static and generalized-α, 5,004 elements**: the roll-up of ``models/embedded_beam.toml`` (its 12
  elements refined 417 times).  Static: the full circle at load factor k = 2, whose closed form puts the
  tip back on the clamp (exactly, for the polygon of equal chords too); each code at the fewest load steps
  of :data:`LOAD_STEPS` that it converges with.  Generalized-α: the same beam made :data:`HEAVY` times
  heavier and undamped, so that its lowest period (~2 s) is the ramp's time scale (the deck's own beam,
  quasi-static with a 16 ms period and damping, gives errors that do not converge at steps a benchmark can
  afford), under the deck's ramped moment to k = 1; the error of the tip history against each code's own
  run at a much smaller step, each code's time at the matched accuracy :data:`MATCHED_DYNAMIC`
  interpolated between the steps that bracket it (:func:`flexmbs.bench_common.matched_time`).
* **Threads**: the 50,000-element explicit run and a short 5,004-element generalized-α run at 1, 2, …
  threads (as many as ``os.sched_getaffinity`` grants), per-step cost, speed-up and whether the final
  state is bit for bit that of one thread.  Only the thread count is set (:func:`reference.jit.use_threads`);
  what runs in parallel is the engine's business.

:func:`large_models` prints the tables; ``quick=True`` runs the same code on small meshes (seconds).
"""

from __future__ import annotations

import importlib.util
import math
import os
import statistics
import time

import numpy as np

from flexmbs.bench_common import COMPILED, ROOT, Target, matched_time

EXPLICIT_ELEMENTS, EXPLICIT_STEPS, EXPLICIT_FACTOR = 50_000, 500, 0.75
"""The explicit model: elements, timed steps, step as a fraction of flexmbs' critical step estimate."""
PROBE_FACTORS, PROBE_STEPS = (1.0, 1.5, 2.0, 3.0), 200
"""Steps (fractions of flexmbs' critical step) at which each code is run for ``PROBE_STEPS`` steps to find
the largest stable one: a run is unstable when it stops (flexmbs' energy guard) or its tip moves more than
100 times as far as at the benchmark's step."""
ROLLUP_REFINE = 417
"""The roll-up deck's 12 elements refined 417 times: 5,004 elements, 30,024 free coordinates."""
LOAD_STEPS = (1, 2, 5, 10, 20)
"""Load-step counts tried in turn for the static roll-up to k = 2 (the first that converges counts)."""
STATIC_ERROR = 1e-6
"""Static target error: the tip's distance from the clamp at k = 2 over L (the closed form: 0)."""
DYNAMIC_T_END, DYNAMIC_STEPS, DYNAMIC_REFERENCE = 1.0, (0.1, 0.05, 0.025, 0.0125), 0.003125
"""The generalized-α roll-up: end time (load factor k) and steps [s]; the reference step of each code (its
own error, from the step's second order, ~1e-6 L at 240 elements: 1 % of :data:`MATCHED_DYNAMIC`)."""
HEAVY = 2e4
"""Mass factor of the generalized-α roll-up's beam (ρA, ρJ of the deck × 2e4; no damping): lowest period
~2 s against the deck's 16 ms, so that the ramped moment's response is resolved by steps of 0.01–0.1 s."""
MATCHED_DYNAMIC = 1e-4
"""Matched accuracy of the generalized-α roll-up: the tip's largest distance from each code's reference
over the outputs (every Δk = 0.1), over L."""


def _alternate(runners: dict, rounds: int, *args) -> dict:
    """Run every runner once per round, in turn (so all see the same machine load); ``{name: [(wall, out)]}``."""
    out = {name: [] for name in runners}
    for _ in range(rounds):
        for name, run in runners.items():
            out[name].append(run(*args))
    return out


def _stable_factor(make_runner, crit: float, dt: float) -> float:
    """Largest of :data:`PROBE_FACTORS` × ``crit`` at which a :data:`PROBE_STEPS`-step run stays bounded: it
    does not stop and its tip moves at most 100 times as far as in the same steps at ``dt`` (0 when none
    does; the factors are tried upwards and the first unstable one ends the search)."""
    _, motion = make_runner(dt)(PROBE_STEPS)
    best = 0.0
    for factor in PROBE_FACTORS:
        try:
            _, tip = make_runner(factor * crit)(PROBE_STEPS)
        except RuntimeError:  # flexmbs' energy guard stopped the run
            break
        if not math.isfinite(tip) or abs(tip) > 100.0 * (factor * crit / dt) ** 2 * abs(motion):
            break
        best = factor
    return best


def explicit_large(elements: int = EXPLICIT_ELEMENTS, steps: int = EXPLICIT_STEPS, repeat: int = 5,
                   pyelastica: bool = True) -> list[str]:
    """The explicit rod beside PyElastica (skipped with a line when it is not installed or not
    ``pyelastica``): stable steps,
    errors against the half step, µs per element-step (alternating runs); returns the printed lines.  No
    target: the issue's one-thread target is at 768 elements (:func:`flexmbs.bench_throughput.beam_throughput`)."""
    from flexmbs.bench_throughput import elastica_runner, flexmbs_runner, solve_runner, throughput_cantilever
    from reference.jit import threads

    crit = throughput_cantilever(elements).critical_time_step()
    dt = EXPLICIT_FACTOR * crit
    makers = {"flexmbs": lambda h: flexmbs_runner(elements, h)}
    if pyelastica and importlib.util.find_spec("elastica") is not None:
        makers["PyElastica"] = lambda h: elastica_runner(elements, h)
    runners = {name: make(dt) for name, make in makers.items()}
    runners["flexmbs solve()"] = solve_runner(elements, dt)
    for run in runners.values():
        run(2)  # warm-up: compilation or cache load
    timed = _alternate(runners, repeat, steps)
    whole = timed.pop("flexmbs solve()")
    half = {name: make(dt / 2)(2 * steps)[1] for name, make in makers.items()}
    lines = [f"**Explicit, {elements:,} elements** (clamped rod, end moment; dt = {dt:.4g} s = {EXPLICIT_FACTOR:g} of "
             f"flexmbs' critical step estimate {crit:.4g} s; {steps} steps; {repeat} alternating rounds, median; "
             f"flexmbs on {threads(elements + 1)} thread(s), the default for this size — the thread table below has "
             "one and more —, PyElastica on one):", "",
             "| code | µs per element-step | tip z at t = steps·dt [m] | error against dt/2 | largest stable step "
             "probed |", "|---|---|---|---|---|"]
    per = {}
    for name, rows in timed.items():
        per[name] = statistics.median(w for w, _ in rows) / (steps * elements)
        tip = rows[-1][1]
        stable = _stable_factor(makers[name], crit, dt)
        stable_text = f"{stable:g} × {crit:.3g} s" if stable else f"< {PROBE_FACTORS[0]:g} × {crit:.3g} s"
        lines.append(f"| {name} | {per[name] * 1e6:.3f} | {tip:.6e} | {abs(tip - half[name]) / abs(half[name]):.1e} "
                     f"| {stable_text} |")
    per_whole = statistics.median(w for w, _ in whole) / (steps * elements)
    lines.append(f"| flexmbs, whole `solve()` | {per_whole * 1e6:.3f} | {whole[-1][1]:.6e} | as flexmbs | as flexmbs |")
    lines.append("")
    lines.append("flexmbs: the compiled stepping with its per-step energy guard (model assembly and start excluded); "
                 "flexmbs, whole `solve()`: the same run through `Domain.solve` (model assembly, start, energy floor, "
                 "critical step check and two outputs included); PyElastica: the `integrate` call (rod built and "
                 "finalized before).")
    if "PyElastica" in per:
        lines.append(f"ratio flexmbs / PyElastica {per['flexmbs'] / per['PyElastica']:.2f}; the two codes' "
                     f"tips at dt/2 differ by {abs(half['flexmbs'] - half['PyElastica']) / abs(half['flexmbs']):.1e} "
                     "(their discretisations differ: nodal against staggered rotations)")
    else:
        lines.append("PyElastica not installed (pip install -e '.[bench]') or not asked for: comparison skipped")
    return lines + [""]


def rollup_domain(algorithm: str, refine: int, dt: float, t_end: float, load_steps: int = 1, heavy: bool = False):
    """``models/embedded_beam.toml`` with its elements refined ``refine`` times, solved by ``algorithm`` at the
    step ``dt`` (``static``: ``load_steps`` load steps) to ``t_end``, outputs every Δk = 0.1; ``heavy``: the
    beam :data:`HEAVY` times heavier and undamped."""
    from reference.io.deck import load_deck

    overrides = {"refine": refine, "solver.backend": COMPILED}
    if heavy:
        overrides.update({"solver.damping": 0.0, "sections.rollup.rhoA": 6.4e-7 * HEAVY,
                          **{f"sections.rollup.rhoJ{k}": 1.6e-5 * HEAVY for k in (1, 2, 3)}})
    d = load_deck(ROOT / "models" / "embedded_beam.toml", overrides=overrides).domain
    d.solver.algorithm, d.solver.t_end = algorithm, t_end
    if algorithm == "static":
        d.solver.load_steps, d.solver.dt, d.solver.output_every = load_steps, t_end / load_steps, 1
    else:
        d.solver.dt, d.solver.output_every = dt, max(int(round(0.1 / dt)), 1)
    return d


def _engines():
    """``{name: solve(domain) → (wall [s], Results)}`` for flexmbs and Exudyn (its sparse solver above the
    translation's dense limit, :func:`crosscheck.exudyn_model.solve`)."""
    from crosscheck.exudyn_model import solve

    def ours(d):
        t0 = time.perf_counter()
        r = d.solve()
        return time.perf_counter() - t0, r

    def theirs(d):
        out = solve(d)
        return out["wall_time"], out["results"]

    return {"flexmbs": ours, "Exudyn": theirs}


def static_large(refine: int = ROLLUP_REFINE, repeat: int = 3, targets: list | None = None) -> list[str]:
    """Static roll-up to the full circle: each code at its fewest converging load steps, time (median of
    ``repeat``, alternating) and tip error; returns the printed lines."""
    from crosscheck.exudyn_model import ExudynFailed

    engines = _engines()
    chosen, lines = {}, []
    for name, solve in engines.items():
        for n in LOAD_STEPS:
            try:
                _, r = solve(rollup_domain("static", refine, 0.0, 2.0, n))
            except (ExudynFailed, RuntimeError):
                continue
            err = float(np.linalg.norm(r.position("beam:end")[-1])) / 10.0
            if err <= STATIC_ERROR:
                chosen[name] = (n, err)
                break
    walls = {name: [] for name in chosen}
    for _ in range(repeat):
        for name in chosen:
            walls[name].append(engines[name](rollup_domain("static", refine, 0.0, 2.0, chosen[name][0]))[0])
    elements = 12 * refine
    lines += [f"**Static roll-up, {elements:,} elements** ({6 * elements:,} free coordinates) to the full circle (k = 2; "
              f"closed form: the tip on the clamp), each code at the fewest of {', '.join(map(str, LOAD_STEPS))} load "
              f"steps that reaches {STATIC_ERROR:g} L; median of {repeat} alternating solves:", "",
              "| code | load steps | solve [s] | tip error / L |", "|---|---|---|---|"]
    for name in engines:
        if name in chosen:
            lines.append(f"| {name} | {chosen[name][0]} | {statistics.median(walls[name]):.3f} | {chosen[name][1]:.1e} |")
        else:
            lines.append(f"| {name} | – | – | not reached with {LOAD_STEPS[-1]} load steps |")
    lines += ["", f"flexmbs' time is the whole `Domain.solve` (model assembly included: {_assembly(refine):.3f} s); "
              "Exudyn's the `SolveSystem` call (the translated system built and assembled before)."]
    if len(chosen) == 2:
        ratio = Target(f"static roll-up {elements:,} elements, flexmbs / Exudyn at {STATIC_ERROR:g} L",
                       statistics.median(walls["flexmbs"]) / statistics.median(walls["Exudyn"]), 0.3, "{:.3f}")
        if targets is not None:
            targets.append(ratio)
        lines += ["", f"ratio flexmbs / Exudyn {ratio.value:.3f} (target ≤ 0.3) {ratio.mark}"]
    return lines + [""]


def _assembly(refine: int) -> float:
    """Seconds flexmbs' ``Domain.initialization`` (the model assembly every ``solve`` starts with) takes on the
    refined roll-up (median of 3)."""
    d = rollup_domain("static", refine, 0.0, 2.0)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        d.initialization()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _history_error(r, ref) -> float:
    """Largest distance of the tip from the reference's over the reference's output times, over L."""
    tip, tip_ref = r.position("beam:end"), ref.position("beam:end")
    at = np.array([np.interp(ref.time, r.time, tip[:, k]) for k in range(3)]).T
    return float(np.max(np.linalg.norm(at - tip_ref, axis=1))) / 10.0


def dynamic_large(refine: int = ROLLUP_REFINE, steps=DYNAMIC_STEPS, reference: float = DYNAMIC_REFERENCE,
                  targets: list | None = None) -> list[str]:
    """Generalized-α roll-up to k = :data:`DYNAMIC_T_END`: every code at every step, its error against its own
    run at ``reference`` and its time (a run that fails is listed as such); then each one's time at
    :data:`MATCHED_DYNAMIC`; returns the lines."""
    from reference.errors import SolverDiverged

    engines = _engines()
    rows, refs = {}, {}
    for name, solve in engines.items():
        solve(rollup_domain("generalized_alpha", refine, steps[0], 2 * steps[0], heavy=True))  # warm-up
        refs[name] = solve(rollup_domain("generalized_alpha", refine, reference, DYNAMIC_T_END, heavy=True))[1]
        rows[name] = []
    failed = []
    for dt in steps:  # the codes alternate at each step
        for name, solve in engines.items():
            try:
                wall, r = solve(rollup_domain("generalized_alpha", refine, dt, DYNAMIC_T_END, heavy=True))
            except SolverDiverged as exc:  # either code's one-line failure (ExudynFailed is one)
                failed.append(f"| {name} | {dt:g} | – | failed: {' '.join(str(exc).split())[:120]} |")
                continue
            rows[name].append((dt, wall, _history_error(r, refs[name])))
    elements = 12 * refine
    lines = [f"**Generalized-α roll-up, {elements:,} elements** ({HEAVY:g} × the deck's mass, undamped, the deck's "
             f"ramped moment, ρ∞ = 0.8, to "
             f"k = {DYNAMIC_T_END:g}); error: the tip's largest distance from the same code's run at dt = {reference:g} "
             f"over the outputs (every 0.1), over L; the two references differ by "
             f"{_history_error(refs['Exudyn'], refs['flexmbs']):.1e} L:",
             "", "| code | dt [s] | solve [s] | error / L |", "|---|---|---|---|"]
    for name, runs in rows.items():
        lines += [f"| {name} | {dt:g} | {wall:.3f} | {err:.2e} |" for dt, wall, err in runs]
    lines += failed
    lines += ["", f"At matched accuracy ({MATCHED_DYNAMIC:g} L):", "", "| code | solve [s] | how |", "|---|---|---|"]
    matched = {name: matched_time(runs, MATCHED_DYNAMIC) for name, runs in rows.items()}
    for name, (t, how) in matched.items():
        lines.append(f"| {name} | {'–' if t is None else f'{t:.3f}'} | {how} |")
    t_ours, t_theirs = matched["flexmbs"][0], matched["Exudyn"][0]
    value = t_ours / t_theirs if t_ours is not None and t_theirs is not None else math.nan
    ratio = Target(f"generalized-α roll-up {elements:,} elements, flexmbs / Exudyn at {MATCHED_DYNAMIC:g} L", value, 0.3,
                   "{:.3f}")
    if targets is not None:
        targets.append(ratio)
    return lines + ["", f"ratio flexmbs / Exudyn {value:.3f} (target ≤ 0.3) {ratio.mark}; flexmbs' times include its "
                    f"model assembly ({_assembly(refine):.3f} s), Exudyn's exclude building its system", ""]


def thread_counts() -> list[int]:
    """1, 2, 4, … up to the cores this process may run on, and that count itself."""
    cores = len(os.sched_getaffinity(0))
    counts = [1]
    while counts[-1] * 2 < cores:
        counts.append(counts[-1] * 2)
    return counts + [cores] if cores > 1 else counts


def thread_scaling(elements: int = EXPLICIT_ELEMENTS, steps: int = EXPLICIT_STEPS, refine: int = ROLLUP_REFINE,
                   repeat: int = 5, targets: list | None = None) -> list[str]:
    """The thread-scaling table: for each model, per-step cost at each of :func:`thread_counts` (rounds over the
    counts, median), speed-up over one thread and whether the final state is bit for bit one thread's."""
    from flexmbs.bench_throughput import flexmbs_runner, throughput_cantilever
    from reference.jit import THREADS_ENV, use_threads

    counts = thread_counts()
    dt = EXPLICIT_FACTOR * throughput_cantilever(elements).critical_time_step()
    finals = {n: {} for n in counts}
    explicit = {n: flexmbs_runner(elements, dt, finals[n]) for n in counts}

    def implicit(n):
        def run(_):
            d = rollup_domain("generalized_alpha", refine, 0.1, 0.3, heavy=True)
            t0 = time.perf_counter()
            r = d.solve()
            wall = time.perf_counter() - t0
            finals[n]["implicit"] = (r.position("beam:end").copy(), r.rotation("beam:end").copy())
            return wall, 3
        return run

    models = {f"explicit, {elements:,} elements, {steps} steps": (explicit, steps, elements, steps),
              f"generalized-α roll-up, {12 * refine:,} elements, 3 steps": ({n: implicit(n) for n in counts}, 0,
                                                                            12 * refine, 3)}
    lines = [f"**Threads** (cores available: {len(os.sched_getaffinity(0))}; {repeat} rounds over the thread counts, "
             "median):", "", "| model | threads | µs per element-step | speed-up | final state as one thread's |",
             "|---|---|---|---|---|"]
    def set_threads(n):  # the override every run honours (each run sets its threads from it, reference.jit.threads)
        os.environ[THREADS_ENV] = str(n)
        use_threads(n)

    saved = os.environ.get(THREADS_ENV)
    try:
        for model, (runners, arg, n_el, n_steps) in models.items():
            times = {n: [] for n in counts}
            for n in counts:
                set_threads(n)
                runners[n](max(arg // 50, 1) if arg else 0)  # warm-up
            for _ in range(repeat):
                for n in counts:
                    set_threads(n)
                    times[n].append(runners[n](arg)[0])
            base = statistics.median(times[1])
            for n in counts:
                same = _same_state(finals[1], finals[n], "implicit" if not arg else None)
                per = statistics.median(times[n]) / (n_el * n_steps)
                lines.append(f"| {model} | {n} | {per * 1e6:.4g} | {base / statistics.median(times[n]):.2f} | "
                             f"{'bit for bit' if same else 'DIFFERENT'} |")
                if n > 1 and targets is not None:
                    targets.append(Target(f"{model}, {n} threads: final state differs from one thread's",
                                          0.0 if same else 1.0, 0.0, "{:g}"))
                if n == 2 and arg and targets is not None:  # the two-thread target: ≥ 1.7× one thread
                    targets.append(Target(f"{model}, two threads' time / one thread's",
                                          statistics.median(times[2]) / base, 1.0 / 1.7, "{:.3f}"))
    finally:
        if saved is None:
            os.environ.pop(THREADS_ENV, None)
        else:
            os.environ[THREADS_ENV] = saved
        use_threads()
    return lines + [""]


def _same_state(a: dict, b: dict, key: str | None) -> bool:
    """Whether two runs' final states are bit for bit the same (explicit: ``x``, ``q``; implicit: ``key``)."""
    if key is not None:
        return all(np.array_equal(p, s) for p, s in zip(a[key], b[key]))
    return np.array_equal(a["x"], b["x"]) and np.array_equal(a["q"], b["q"])


QUICK = dict(elements=200, steps=20, refine=2, repeat=1, dynamic_steps=(0.1, 0.05), reference=0.0125)
"""The small version (the tests, ``--quick``): the same code on small meshes and short runs."""


def large_models(quick: bool = False, repeat: int = 5, targets: list | None = None, pyelastica: bool = True) -> list[str]:
    """Every large-model table (the small version when ``quick``), printed as it is made; returns the lines.
    ``pyelastica=False`` leaves PyElastica out (the tests: its kernels compile for ~30 s on a cold cache)."""
    size = QUICK if quick else dict(elements=EXPLICIT_ELEMENTS, steps=EXPLICIT_STEPS, refine=ROLLUP_REFINE,
                                    repeat=repeat, dynamic_steps=DYNAMIC_STEPS, reference=DYNAMIC_REFERENCE)
    lines = []
    for part in (lambda: explicit_large(size["elements"], size["steps"], size["repeat"], pyelastica),
                 lambda: thread_scaling(size["elements"], size["steps"], size["refine"], size["repeat"], targets),
                 lambda: static_large(size["refine"], size["repeat"], targets),
                 lambda: dynamic_large(size["refine"], size["dynamic_steps"], size["reference"], targets)):
        t0 = time.perf_counter()
        new = part() + [f"(this table took {time.perf_counter() - t0:.0f} s)", ""]
        print("\n".join(new), flush=True)
        lines += new
    return lines
