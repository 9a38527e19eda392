"""``flexmbs report``: the verification report, ``reports/verification.md`` (and .html) with figures.

The report is generic over the decks in ``models/``: each gets a section built
from its own data — description, provenance, sections and bodies, a sketch of
the model, the checks of its ``[checks]`` tables (tolerance and reason read
from the deck) and the Exudyn cross-check of its ``[crosscheck]`` tables.  What
needs code to compute a reference value (a closed form, a literature table, a
convergence study) lives in the deck's check module, ``flexmbs.deckchecks.<name>``
(found by the deck's ``meta.name``; see :mod:`flexmbs.deckchecks`).  A deck
without a module still runs, is drawn and cross-checked, and its ``[checks]``
are listed as *not evaluated*.  After the decks come the element families' suite
(:mod:`flexmbs.verification.families`) and the parameter sensitivities' checks
(:mod:`flexmbs.verification.sensitivities`, counted with the decks' checks).

The header names the date, the git commit (``dirty`` if the tree has
uncommitted changes) and the versions of Python and every package the
numbers depend on.  Solve times are *warm*: each deck first runs a few steps
(timed and reported separately as compilation and set-up), so that numba's
compilation is never counted as solve time.  Progress goes to the terminal for
each deck and engine.  A failed check is printed as failed and makes the
command exit with status 1.
"""

from __future__ import annotations

import datetime
import platform
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexmbs.plot import save_figure

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
REPORTS = ROOT / "reports"


@dataclass
class Check:
    """One row of a check table: the computed measure must not exceed the tolerance."""

    name: str
    reference: str
    computed: float
    tolerance: float
    why: str

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.computed) and abs(self.computed) <= self.tolerance)


@dataclass
class Context:
    """What a deck's check module gets: its deck, where to write, and the report's services."""

    deck: Path
    out: Path
    figures: Path
    quick: bool
    timings: list = field(default_factory=list)
    checks: dict = field(default_factory=dict)

    def domain(self, **overrides):
        """A fresh Domain of the deck (overrides: ``t_end``, ``dt``, ``refine``)."""
        from reference.io.deck import load_deck

        return load_deck(self.deck, overrides=overrides or None).domain

    def solve(self, domain, what: str = "", results_file: bool = False):
        """Solve warm with a progress bar; the solve time is recorded for the timing table."""
        from flexmbs.progress import ProgressBar

        warm_up(self.deck, domain)
        label = f"{self.deck.stem}{' ' + what if what else ''}"
        bar = ProgressBar(f"  {label}")
        path = self.out / self.deck.stem / f"{what.replace(' ', '_') or 'results'}.h5" if results_file else None
        try:
            r = domain.solve(results_path=path, progress=bar)
        finally:
            bar.close()
        steps = int(round(domain.solver.t_end / domain.solver.dt))
        self.timings.append((label, "reference", steps, r.wall_time))
        return r

    def tolerance(self, name: str) -> tuple[float, str]:
        """A check's tolerance and its reason, as the deck's ``[checks.NAME]`` states them."""
        try:
            spec = self.checks[name]
            return float(spec["tolerance"]), " ".join(str(spec["reason"]).split()).replace("|", "/")
        except KeyError:
            raise KeyError(f"{self.deck}: the report needs [checks.{name}] with a tolerance and its reason") from None

    def check(self, name: str, label: str, reference: str, computed: float) -> Check:
        """A :class:`Check` with the tolerance and reason of the deck's ``[checks.NAME]``."""
        return Check(label, reference, float(computed), *self.tolerance(name))

    def figure(self, fig, name: str, caption: str) -> str:
        """Save a figure under ``figures/`` and return its Markdown line."""
        save_figure(fig, self.figures / name, dpi=130)
        return f"![{caption}](figures/{name})"


_WARM: set = set()


def warm_up(path, domain) -> float:
    """Run the deck at ``path`` for two steps of ``domain``'s once per deck, so that compilation is not
    solve time (:func:`reference.io.deck.warm_up`).

    Returns the time spent (0 if this deck was already warmed up).
    """
    from reference.io.deck import warm_up as solve_two_steps

    key = (str(path), len(domain.nodes), len(domain.joints))
    if key in _WARM:
        return 0.0
    _WARM.add(key)
    return solve_two_steps(path, domain.solver.dt)


def provenance_header(quick: bool) -> list[str]:
    """Date, commit and versions: what a reviewer needs to reproduce the numbers."""
    import importlib.metadata as md

    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=20).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    commit = git("rev-parse", "HEAD") or "unknown (not a git checkout)"
    # the report's own outputs (reports/) are tracked: a previous report must not mark the next one dirty
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)reports")
    versions = []
    for pkg in ("flexmbs", "numpy", "scipy", "numba", "sympy", "h5py", "matplotlib", "exudyn"):
        try:
            versions.append(f"{pkg} {md.version(pkg)}")
        except md.PackageNotFoundError:
            versions.append(f"{pkg} (not installed)")
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return [
        "# flexmbs verification report",
        "",
        "Generated by `flexmbs report`" + (" --quick" if quick else "") + " — do not edit by hand. Every check names "
        "its reference and the reason for its tolerance; the equations are in `docs/formulation.md`, the models' "
        "definitions and the reason for every number in `docs/benchmarks.md`.",
        "",
        f"- **Date:** {now}",
        f"- **Commit:** `{commit}`" + (" (**dirty**: uncommitted changes in tracked files)" if dirty else ""),
        f"- **Python** {platform.python_version()} ({platform.machine()}, {platform.system()}); " + ", ".join(versions),
        f"- **Machine:** {platform.processor() or platform.machine()}, {_cpus()} CPUs",
        "",
    ]


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def deck_data(deck) -> list[str]:
    """Provenance and data of a deck (:class:`reference.io.deck.Deck`), for the report."""
    domain, meta = deck.domain, deck.metadata
    prov = meta.get("provenance", {})
    prov = prov if isinstance(prov, dict) else {"source": prov}
    lines = ["**Provenance:** " + "; ".join(f"{k}: {v}" for k, v in prov.items()), ""]
    if meta.get("notes"):
        lines += ["**Why these data:** " + " ".join(str(meta["notes"]).split()), ""]
    sections = {id(e.formulation.section): e.formulation.section for e in domain.elements}
    if sections:
        lines += ["| section | EA [N] | GA2 | GA3 | GJ [N m²] | EI2 | EI3 | ρA [kg/m] | ρJ1 [kg m] | ρJ2 | ρJ3 |",
                  "|---|" + "---|" * 10]
        for k, sec in enumerate(sections.values()):
            lines.append(f"| {k + 1} | " + " | ".join(f"{v:g}" for v in (*sec.stiffness, sec.rhoA, *sec.rotary_inertia)) + " |")
        lines.append("")
    for n in (n for n in domain.nodes if n.mass > 0.0 and not n.label.rpartition(":")[2].isdigit()):
        lines.append(f"- rigid body `{n.label}`: mass {n.mass:g} kg, inertia about the centre of mass (body frame) "
                     f"diag {np.round(np.diag(n.inertia), 6).tolist()} kg m², centre {np.round(n.position, 6).tolist()} m")
    steps = int(round(domain.solver.t_end / domain.solver.dt))
    families = Counter(e.formulation.family for e in domain.elements)
    elements = ", ".join(f"{n} {family} element{'s' * (n != 1)}" for family, n in families.items()) or "no elements"
    counts = (f"{len(domain.nodes)} nodes, {elements}, {len(domain.joints)} joints "
              f"({domain.model.n_constraints} constraint equations)")
    algo = domain.algorithm()
    if algo.name == "arc_length":  # no time step: the load factor follows the path
        s = domain.solver
        return lines + ["", f"{counts}; `{algo.name}`: the loads at t = {s.t_end:g} times a load factor, "
                            f"initial arc length {s.arc_length:g}, at most {s.max_points} points, "
                            f"|λ| up to {s.max_load_factor:g}.", ""]
    if algo.linearised:  # no time step: what is linearised, and how many modes
        where = (f"the static equilibrium at t = {domain.solver.t_end:g} ({domain.solver.load_steps} load steps)"
                 if algo.n_steps(domain.solver.t_end) else "the initial state")
        if domain.solver.about == "rotation":
            where = (f"the steady rotation at {domain.solver.spin_rate:g} rad/s about "
                     f"{np.round(domain.solver.spin_axis, 6).tolist()} (in the spinning frame)")
        return lines + ["", f"{counts}; `{algo.name}`: the {algo.n_modes} lowest, about {where}.", ""]
    # the critical step bounds only an explicit scheme's step: an implicit deck's margin would mean nothing
    crit = domain.critical_time_step() if domain.elements and algo.explicit else None
    lines += ["", f"{counts}; `{algo.name}`, h = {domain.solver.dt:g} s, t_end = "
              f"{domain.solver.t_end:g} s ({steps} steps)"
              + (f"; critical step {crit:.3e} s (margin {crit / domain.solver.dt:.2f})" if crit else "")
              + (f"; mass-proportional damping c = {domain.solver.damping:g} 1/s" if domain.solver.damping else "") + ".", ""]
    return lines


def sketch(domain, path: Path) -> Path:
    """The model at t = 0: bodies as drawn by :func:`flexmbs.plot.configuration`, joints, clamps, loads."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.plot import chains, configuration, geometry
    from reference.io.results import Results

    N = len(domain.nodes)
    pos = np.array([n.position for n in domain.nodes])[None]
    r0 = Results(time=np.zeros(1), labels=[n.label for n in domain.nodes], positions=pos,
                 rotations=np.array([n.rotation for n in domain.nodes])[None], velocities=np.zeros((1, N, 3)),
                 angular_velocities=np.zeros((1, N, 3)), energy={}, constraint_violation=np.zeros(1),
                 velocity_constraint_violation=np.zeros(1))
    lines = configuration(r0, 0, geometry(domain), beams=chains(domain))
    allp = np.concatenate([p for _, p in lines] + [np.array([j.point for j in domain.joints]).reshape(-1, 3)])
    spread = allp.max(axis=0) - allp.min(axis=0)
    a, b = sorted(np.argsort(spread)[::-1][:2]) if np.count_nonzero(spread > 1e-9) >= 2 else (0, 2)
    fig, ax = plt.subplots(figsize=(5.2, 4.2))
    for label, P in lines:
        ax.plot(P[:, a], P[:, b], "o-" if len(P) > 1 else "s", ms=3 if len(P) > 1 else 7, lw=2, label=label)
    at_point = {}
    for j in domain.joints:  # joints at one point share one marker and one label
        at_point.setdefault(tuple(np.round(j.point, 9)), []).append(j.label)
    for point, names in at_point.items():
        ax.plot(point[a], point[b], "o", mfc="white", mec="k", ms=8)
        ax.annotate(", ".join(names), (point[a], point[b]), textcoords="offset points", xytext=(6, 6), fontsize=7)
    for grav in (g for g in domain.loading if type(g).__name__ == "Gravity"):
        gv = np.asarray(grav.g, dtype=float)
        d = np.array([gv[a], gv[b]]) / max(np.linalg.norm(gv), 1e-300)
        start = np.array([0.08, 0.9]) - 0.06 * d
        ax.annotate("", start + 0.12 * d, start, xycoords="axes fraction",
                    arrowprops=dict(arrowstyle="->", color="purple", lw=1.5))
        ax.text(*(start + [0.03, 0.0]), "gravity", transform=ax.transAxes, fontsize=7, color="purple", va="center")
    for bc in domain.boundary_conditions:
        node = getattr(bc, "node", None)
        if node is not None:
            ax.plot(node.position[a], node.position[b], "k^", ms=10)
    arrow = 0.15 * max(float(spread.max()), 1e-9)
    for load in domain.loading:
        node, vec = getattr(load, "node", None), np.asarray(getattr(load, "vector", np.zeros(3)), dtype=float)
        if node is None or not np.any(vec):
            continue
        if getattr(load, "moment", False):
            ax.plot(node.position[a], node.position[b], "o", mfc="none", mec="r", ms=14, mew=1.5)
        else:
            d = vec / np.linalg.norm(vec) * arrow
            ax.annotate("", (node.position[a] + d[a], node.position[b] + d[b]), (node.position[a], node.position[b]),
                        arrowprops=dict(arrowstyle="->", color="r", lw=1.5))
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.15)
    ax.set_xlabel(f"{'xyz'[a]} [m]")
    ax.set_ylabel(f"{'xyz'[b]} [m]")
    if len(lines) <= 8:
        ax.legend(fontsize=7, loc="best")
    ax.set_title(f"{domain.name} at t = 0 (○ joints, ▲ clamped/fixed nodes, red: loads)", fontsize=9)
    return save_figure(fig, path, dpi=110)


def _table(checks: list[Check]) -> list[str]:
    lines = ["| check | reference | computed | tolerance | result | why this tolerance |", "|---|---|---|---|---|---|"]
    for c in checks:
        # a bar inside a cell would split the table: absolute values are written with "∣" (U+2223)
        name, reference = (text.replace("|", "∣") for text in (c.name, c.reference))
        lines.append(f"| {name} | {reference} | {c.computed:.3e} | {c.tolerance:.1e} | "
                     f"{'pass' if c.passed else '**FAIL**'} | {c.why} |")
    return lines


def reaction_lines(cmp, figure: Path) -> list[str]:
    """The joint reactions a deck cross-checks, both engines over time (``crosscheck/reactions.py``)."""
    from crosscheck.reactions import reaction_comparison

    scalar = [o if "." in o.split(":", 1)[0] else o.replace(":", ".norm:", 1)
              for o in dict.fromkeys(v.observable for v in cmp["verdicts"]) if o.startswith("reaction_")]
    if not scalar:
        return []
    head = ["Joint reactions, Exudyn's joint sensors against the reference's multipliers:", ""]
    return head + reaction_comparison(cmp["reference"], cmp["exudyn"], scalar, path=figure)["markdown"] + [""]


def crosscheck_lines(ctx: Context, deck) -> tuple[list[str], list[Check]]:
    """The deck in Exudyn at every refinement its ``[crosscheck]`` tables name (only the first in --quick)."""
    domain = deck.domain
    if not deck.crosscheck:
        return [], []
    try:
        from crosscheck.exudyn_model import Unsupported
        from crosscheck.harness import run
    except ImportError as exc:
        return [f"Exudyn cross-check skipped: {exc}.", ""], []
    from flexmbs.progress import ProgressBar

    refines = sorted({int(spec.get("refine", 1)) for spec in deck.crosscheck.values()})
    lines, checks = [], []
    for refine in refines[:1] if ctx.quick else refines:
        t_end = None
        if ctx.quick:  # the first second only (a whole number of output intervals)
            interval = domain.solver.dt * domain.solver.output_every
            t_end = min(domain.solver.t_end, max(1, int(1.0 / interval)) * interval)
        label = ctx.deck.stem + (f" ×{refine}" if refine > 1 else "")
        try:
            cmp = run(ctx.deck, ctx.out / f"crosscheck_{ctx.deck.stem}_{refine}", refine=refine, t_end=t_end,
                      figures=ctx.figures, progress=ProgressBar(f"  {label} reference"),
                      exudyn_progress=ProgressBar(f"  {label} Exudyn"))
        except Unsupported as exc:
            lines += [f"**Exudyn cross-check not run:** {exc}.", ""]
            checks.append(Check(f"Exudyn cross-check{f' ×{refine}' if refine > 1 else ''}", "Exudyn", np.nan, 0.0,
                                f"the deck asks for it but it cannot be translated: {exc}"))
            continue
        steps = int(round((t_end or domain.solver.t_end) / domain.solver.dt))
        ctx.timings.append((label + " (cross-check run)", "reference", steps * refine, cmp["reference"].wall_time))
        ctx.timings.append((label + " (cross-check run)", "Exudyn", steps, cmp["exudyn_wall"]))
        lines += cmp["markdown"]
        lines += reaction_lines(cmp, ctx.figures / f"{ctx.deck.stem}_reactions_{refine}.png")
        for v in cmp["verdicts"]:
            checks.append(Check(f"Exudyn cross-check{f' ×{refine}' if refine > 1 else ''}: {v.observable}",
                                f"Exudyn, relative to {v.relative_to}", v.measure, v.tolerance, v.reason.replace("|", "/")))
    return lines, checks


def view_lines(results: Path, page: Path, deck) -> list[str]:
    """The interactive view of the deck's own run (:mod:`flexmbs.view`, at most
    :data:`flexmbs.view.EMBEDDED_FRAMES` frames) as ``views/NAME.html`` and its Markdown line; the HTML report
    draws it in place (:func:`flexmbs.html.markdown_to_html`).  Nothing when the deck's check module wrote no
    results file."""
    from flexmbs.view import EMBEDDED_FRAMES, write

    if not results.exists():
        return []
    write(results, page, max_frames=EMBEDDED_FRAMES, domain=deck.domain)
    what = "pick a mode, " if deck.domain.algorithm().linearised else "play it, scrub its time, colour it by a section force, "
    return [f"[Interactive 3D view of {deck.domain.name}](views/{page.name}): drag to turn it, {what}"
            "in the HTML report (`reports/verification.html`) or on its own.", ""]


def deck_section(number: int, deck: Path, out: Path, figures: Path, quick: bool, timings: list):
    """One deck's section: data, sketch, its check module's checks, the Exudyn cross-check."""
    from flexmbs.deckchecks import module_for
    from reference.io.deck import load_deck

    read = load_deck(deck)
    domain = read.domain
    ctx = Context(deck, out, figures, quick, timings, read.checks)
    main_run = out / deck.stem / "results.h5"  # the deck's own run (Context.solve with results_file=True)
    main_run.unlink(missing_ok=True)
    t0 = time.perf_counter()
    compile_time = warm_up(deck, domain)
    print(f"[{number}] {deck.name}: warm-up (compilation and set-up) {compile_time:.1f} s", file=sys.stderr)
    title = read.metadata.get("title") or domain.name.replace("_", " ")
    lines = [f"## {number}. {title[0].upper() + title[1:]}", "",
             f"Deck: `models/{deck.name}` — {domain.description}", "", *deck_data(read)]
    lines += [f"![sketch of {domain.name}](figures/{sketch(domain, figures / f'{domain.name}_sketch.png').name})", ""]
    module = module_for(domain.name)
    if module is None:
        checks = []
        r = ctx.solve(load_deck(deck).domain, results_file=True)
        lines += [f"No check module (`flexmbs/deckchecks/{domain.name}.py`) evaluates this deck's `[checks]`: "
                  + (", ".join(f"`{k}`" for k in read.checks) + " are **not evaluated** here." if read.checks
                     else "it has none."), "",
                  f"Ran to t = {r.time[-1]:g} s: max ‖Φ‖ {np.nanmax(r.constraint_violation):.2e}.", ""]
    else:
        more, checks = module.evaluate(ctx)
        lines += more
    lines += view_lines(main_run, figures.parent / "views" / f"{deck.stem}.html", read)
    xlines, xchecks = crosscheck_lines(ctx, read)
    lines += xlines
    checks += xchecks
    lines += ["", f"**Checks of this deck** ({sum(c.passed for c in checks)} of {len(checks)} pass; section built in "
              f"{time.perf_counter() - t0:.1f} s, of which warm-up {compile_time:.1f} s):", "", *_table(checks), ""]
    return lines, checks, compile_time


def contents(lines: list[str]) -> list[str]:
    """The contents table: a link to every section (``## `` heading), by its GitHub anchor."""
    from flexmbs.html import anchor

    seen, toc = {}, ["## Contents", ""]
    for line in lines:
        if line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            slug = anchor(line[level:].strip(), seen)
            if level == 2:
                toc.append(f"- [{line[3:].strip()}](#{slug})")
    return toc + [""]


LIMITATIONS = [
    "## Limitations: what this report does not verify",
    "",
    "Verified **only by the test suite** (`make test`), not in this report: rotation parametrisations and their "
    "round trips near 0 and π; every joint's Jacobian against finite differences of its constraint equations; the "
    "Beam2 internal forces against finite differences of the strain energy and zero force under rigid motion; "
    "the deck reader's validation (one-line errors); the results file contract; the VTK output; the master/slave "
    "joint formulation against Lagrange multipliers; the notebooks (executed in a Jupyter kernel).",
    "",
    "**Not verified** anywhere:",
    "",
    "- the exact staging of Park's staggered algorithm and the form of the Park–Chiou stabilisation are "
    "reconstructions (docs/formulation.md §6–7): verified to be second order, stable and drift-free, not to be "
    "identical to the originals;",
    "- the three-bar mechanism's data are this project's (the paper's source could not be retrieved): its "
    "flexible response is compared with Exudyn, not with the paper's Fig. 14 numerically;",
    "- the cross-check compares two codes with different beam elements (lumped vs consistent mass, another "
    "rotation interpolation): agreement is checked at the tolerances the decks state, not to round-off;",
    "- long-time behaviour beyond each deck's horizon, contact, friction, plasticity, and beams with shear "
    "centre ≠ centroid are outside the formulation;",
    "- solve times are of this machine, one run each (no repetition statistics; `flexmbs bench` repeats).",
    "",
]


def main(args=None) -> int:
    quick = bool(getattr(args, "quick", False))
    reports = Path(getattr(args, "out", None) or REPORTS)
    out = reports / "_runs"
    figures = reports / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    header = provenance_header(quick)  # the commit and tree state the numbers come from: taken before the runs
    from flexmbs.verification.reduced import DECKS as REDUCED_DECKS

    # the reduced decks are the "Reduced bodies" section's (run against their full-beam decks and Exudyn there)
    decks = [d for d in sorted(MODELS.glob("*.toml")) if d.name not in REDUCED_DECKS]
    # the paper's two examples first, then the gallery in alphabetical order
    first = [MODELS / "embedded_beam.toml", MODELS / "three_bar.toml"]
    decks = [d for d in first if d in decks] + [d for d in decks if d not in first]
    lines, checks, timings, compile_total = [], [], [], 0.0
    for number, deck in enumerate(decks, start=1):
        more_lines, more_checks, compile_time = deck_section(number, deck, out, figures, quick, timings)
        lines, checks, compile_total = lines + more_lines, checks + more_checks, compile_total + compile_time
        failed_here = [c for c in more_checks if not c.passed]
        print(f"[{number}/{len(decks)}] {deck.name}: {len(more_checks) - len(failed_here)}/{len(more_checks)} checks pass",
              file=sys.stderr)
    from flexmbs.verification.families import report_lines
    from flexmbs.verification.reduced import report_section
    from flexmbs.verification.sensitivities import report_lines as sensitivity_lines

    families = report_lines()
    print("sensitivities: the four checks on the reference path", file=sys.stderr)
    text, rows = sensitivity_lines(quick, out / "sensitivities")
    sensitivity_checks = [Check(*row) for row in rows]
    families += text + _table(sensitivity_checks) + [""]
    checks += sensitivity_checks
    reduced, reduced_checks = report_section(quick, out)
    families += reduced
    checks += [Check(*row) for row in reduced_checks]
    failed = [c for c in checks if not c.passed]
    head = header + [
        f"**{len(checks) - len(failed)} of {len(checks)} checks pass** over {len(decks)} decks." + (
            "  Failed: " + "; ".join(c.name for c in failed) if failed else ""),
        "",
        *contents(lines + families + ["## Solve times"] + LIMITATIONS + ["## All checks"]),
    ]
    timing = ["## Solve times", "",
              "Warm solve times (the solve call only; numba's compilation is excluded: every deck first runs two "
              f"steps, {compile_total:.1f} s in total for compilation and set-up, most of it for the first deck). "
              "Exudyn's time is its `SolveSystem` call.", "",
              "| run | engine | steps | solve [s] | µs per step |", "|---|---|---|---|---|"]
    timing += [f"| {label} | {engine} | {steps} | {wall:.3f} | {1e6 * wall / max(steps, 1):.1f} |"
               for label, engine, steps, wall in timings]
    body = head + lines + families + timing + [""] + LIMITATIONS + ["## All checks", ""] + _table(checks)
    body += ["", f"Report generated in {time.perf_counter() - t0:.1f} s."]
    name = "verification_quick.md" if quick else "verification.md"
    (reports / name).write_text("\n".join(body) + "\n", encoding="utf-8")
    from flexmbs.html import write_html

    write_html(reports / name)
    print(f"wrote {reports / name}: {len(checks) - len(failed)}/{len(checks)} checks pass "
          f"({time.perf_counter() - t0:.0f} s)")
    for c in failed:
        print(f"FAILED: {c.name}: computed {c.computed:.3e}, tolerance {c.tolerance:.1e}")
    return 1 if failed else 0
