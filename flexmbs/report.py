"""``flexmbs report``: the verification report, ``reports/verification.md`` and its figures.

For each deck in ``models/`` the report states its provenance and data, runs it
with the reference engine (and, where a cross-check model exists, with
Exudyn), reproduces the paper's figure, tabulates every check (reference value,
computed value, tolerance, pass/fail), and shows the convergence study.  A
failed check is printed as failed and makes the command exit with status 1.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexmbs.plot import save_figure

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
REPORTS = ROOT / "reports"


def tolerance(domain, name: str) -> tuple[float, str]:
    """A check's tolerance and its reason, as the deck's ``[checks.NAME]`` states them."""
    try:
        spec = domain.checks[name]
        return float(spec["tolerance"]), str(spec["reason"])
    except KeyError:
        raise KeyError(f"{domain.deck_path}: the report needs [checks.{name}] with a tolerance and its reason") from None


@dataclass
class Check:
    """One row of a check table."""

    name: str
    reference: str
    computed: float
    tolerance: float
    why: str

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.computed) and abs(self.computed) <= self.tolerance)


def deck_data(domain) -> list[str]:
    """Provenance and data of a deck, for the report."""
    meta = domain.metadata
    prov = meta.get("provenance", {})
    lines = ["**Provenance:** " + "; ".join(f"{k}: {v}" for k, v in prov.items()), ""]
    if meta.get("notes"):
        lines += ["**Why these data:** " + " ".join(str(meta["notes"]).split()), ""]
    sections = {id(e.formulation.section): e.formulation.section for e in domain.elements}
    if sections:
        lines += ["| section | EA | GA2 | GA3 | GJ | EI2 | EI3 | ρA | ρJ1 | ρJ2 | ρJ3 |", "|---|" + "---|" * 10]
        for k, sec in enumerate(sections.values()):
            lines.append(f"| {k + 1} | " + " | ".join(f"{v:g}" for v in (*sec.stiffness, sec.rhoA, *sec.rotary_inertia)) + " |")
        lines.append("")
    rigid = [n for n in domain.nodes if n.mass > 0.0]
    for n in rigid:
        lines.append(f"Rigid body `{n.label}`: mass {n.mass:g}, inertia diag {np.round(np.diag(n.inertia), 6).tolist()}, "
                     f"centre {np.round(n.position, 6).tolist()}.")
    lines += ["", f"{len(domain.nodes)} nodes, {len(domain.elements)} Beam2 elements, {len(domain.joints)} joints; "
              f"h = {domain.solver.dt:g}, t_end = {domain.solver.t_end:g}.", ""]
    return lines


def _table(checks: list[Check]) -> list[str]:
    lines = ["| check | reference | computed | tolerance | result | why this tolerance |", "|---|---|---|---|---|---|"]
    for c in checks:
        lines.append(f"| {c.name} | {c.reference} | {c.computed:.3e} | {c.tolerance:.1e} | "
                     f"{'pass' if c.passed else '**FAIL**'} | {c.why} |")
    return lines


def rollup_section(out: Path, quick: bool, figures: Path) -> tuple[list[str], list[Check]]:
    """Embedded beam (paper §5.1): Fig. 12, tip table, convergence, Exudyn comparison."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reference.analytic import elastica_tip, polygon_tip
    from reference.domain import Domain

    deck = MODELS / "embedded_beam.toml"
    domain = Domain.from_deck(deck)
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    n0 = len(domain.elements)
    t0 = time.perf_counter()
    r = domain.solve(results_path=out / "embedded_beam" / "results.h5")
    wall = time.perf_counter() - t0
    tip_label = domain.nodes[-1].label
    ks = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0]

    def at(res, label, k):
        return res.position(label)[int(np.argmin(np.abs(res.time - k)))]

    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for k in ks:
        i = int(np.argmin(np.abs(r.time - k)))
        ax.plot(r.positions[i, :, 0], r.positions[i, :, 2], "o-", ms=3, lw=1.2, label=f"k = {k:g}")
        s = np.linspace(0, L, 200)
        th = k * np.pi / L * s
        ax.plot(L * np.sin(th) / (k * np.pi), L * (1 - np.cos(th)) / (k * np.pi), "k:", lw=0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    ax.set_title("Successive deflections of the embedded beam (paper Fig. 12)\n"
                 f"{n0} Beam2 elements; dotted: elastica arcs", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    save_figure(fig, figures / "rollup_fig12.png", dpi=130)

    lines = [
        "## 1. Embedded beam rolled up by an end torque (paper §5.1, Figs. 11–12)",
        "",
        f"Deck: `models/embedded_beam.toml` — {domain.metadata.get('description', domain.description)}",
        "",
        *deck_data(domain),
        f"{n0} Beam2 elements, L = {L:g}, Δk = {domain.solver.dt:g} ({int(round(domain.solver.t_end / domain.solver.dt))} steps), "
        f"mass-proportional damping c = {domain.solver.damping:g}; critical step estimate "
        f"{domain.critical_time_step():.3e} (margin {domain.critical_time_step() / domain.solver.dt:.2f}). "
        f"Reference solve: {r.wall_time:.3f} s ({wall:.2f} s including compilation and file output).",
        "",
        "![Fig. 12](figures/rollup_fig12.png)",
        "",
        "Tip position against the elastica (closed form: x = L sin t/t, z = L(1 − cos t)/t, t = kπ) and against "
        "the converged discrete answer (a regular polygon of unstrained chords):",
        "",
        "| k | x/L | z/L | closed form x/L | closed form z/L | error / L | polygon error / L |",
        "|---|---|---|---|---|---|---|",
    ]
    checks = []
    worst = 0.0
    tip_tol, tip_why = tolerance(domain, "tip_vs_elastica")
    for k in ks:
        p = at(r, tip_label, k)
        ex = elastica_tip(L, k)
        err = np.linalg.norm(p - ex) / L
        perr = np.linalg.norm(p - polygon_tip(L, n0, k)) / L
        worst = max(worst, err)
        lines.append(f"| {k:g} | {p[0] / L:.6f} | {p[2] / L:.6f} | {ex[0] / L:.6f} | {ex[2] / L:.6f} | {err:.2e} | {perr:.2e} |")
        checks.append(Check(f"tip error at k = {k:g}, {n0} elements", "elastica", err, tip_tol, tip_why))
    checks.append(Check("tip at k = 2 (closed circle)", "0", float(np.linalg.norm(at(r, tip_label, 2.0)) / L),
                        *tolerance(domain, "closes_at_k2")))
    checks.append(Check("max out-of-plane y over all nodes and times", "0 exactly",
                        float(np.abs(r.positions[:, :, 1]).max()), *tolerance(domain, "out_of_plane")))
    e = r.energy
    balance = np.max(np.abs(e["external_work"] - e["strain"] - e["kinetic"] - e["dissipated"])) / e["external_work"][-1]
    checks.append(Check("energy balance W − (U + T + D), relative to W", "0", float(balance),
                        *tolerance(domain, "energy_balance")))

    refinements = [1, 2] if quick else [1, 2, 4, 8]
    runs = {}
    for rf in refinements:
        d = Domain.from_deck(deck, overrides={"refine": rf})
        runs[rf * n0] = (d, d.solve())
    ns = sorted(runs)
    diffs = []
    for a, b in zip(ns[:-1], ns[1:]):
        (da, ra), (db, rb) = runs[a], runs[b]
        diffs.append(max(np.linalg.norm(at(ra, da.nodes[-1].label, k) - at(rb, db.nodes[-1].label, k)) for k in ks) / L)
    errs = [max(np.linalg.norm(at(runs[n][1], runs[n][0].nodes[-1].label, k) - elastica_tip(L, k)) for k in ks) / L
            for n in ns]
    lines += ["", "### Convergence with the mesh", "",
              "The step halves with the element length (the critical step does). Raw tip errors contain a "
              "mesh-independent dynamic lag, so the order is measured on differences between successive meshes "
              "(BENCHMARKS.md §1).", "",
              "| elements | Δk | max tip error / L (vs elastica) | max difference to next mesh / L | observed order |",
              "|---|---|---|---|---|"]
    orders = [np.log2(d1 / d2) for d1, d2 in zip(diffs[:-1], diffs[1:])]
    for i, n in enumerate(ns):
        diff = f"{diffs[i]:.3e}" if i < len(diffs) else "—"
        order = f"{orders[i - 1]:.3f}" if 0 < i < len(diffs) else "—"
        lines.append(f"| {n} | {runs[n][0].solver.dt:g} | {errs[i]:.3e} | {diff} | {order} |")
    if orders:
        checks.append(Check(f"observed order ({ns[0]}→{ns[-1]} elements), 2 − p", "≤ 0.1",
                            max(0.0, 2.0 - min(orders)), *tolerance(domain, "convergence_order")))
    fig, ax = plt.subplots(figsize=(5.4, 4.0))
    ax.loglog(ns, errs, "o-", label="max tip error vs elastica")
    if diffs:
        ax.loglog(ns[:-1], diffs, "s-", label="difference to the next mesh")
        ax.loglog(ns[:-1], diffs[0] * (np.array(ns[:-1]) / ns[0]) ** -2.0, "k--", lw=0.8, label="slope −2")
    ax.set_xlabel("number of elements")
    ax.set_ylabel("/ L")
    ax.legend(fontsize=8)
    ax.set_title("Roll-up: tip error against the number of elements", fontsize=10)
    save_figure(fig, figures / "rollup_convergence.png", dpi=130)
    lines += ["", "![convergence](figures/rollup_convergence.png)", ""]

    return lines, checks


def rigid_coupler_deck(deck: Path, path: Path, extra_solver: str = "") -> Path:
    """The three-bar deck with the coupler made rigid (the rigid limit).

    A planar four-bar of rigid bodies closed by revolute joints is redundant in
    3D, so the closing joints B and O3 are regularised (ε = 1e-10).  The deck's
    ``[crosscheck]`` tables (observables of the flexible coupler) are dropped.
    """
    text = re.sub(r"\n\[crosscheck\.[^\n]*\](\n(?!\[)[^\n]*)*", "", deck.read_text())
    text = text.replace('section = "coupler"\naxis2', 'section = "coupler"\nrigid = true\naxis2')
    text = text.replace('body_i = "coupler:start"', 'body_i = "coupler"').replace('body_i = "coupler:end"', 'body_i = "coupler"')
    for joint in ('label = "B"', 'label = "O3"'):
        text = text.replace(joint, joint + "\nepsilon = 1e-10")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text.replace("[solver]", "[solver]" + extra_solver))
    return path


def three_bar_section(out: Path, quick: bool, figures: Path) -> tuple[list[str], list[Check]]:
    """Three-bar mechanism (paper §5.2): Fig. 14, rigid limit, drift, energy, time-step study."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reference.analytic import fourbar_rocker_angle
    from reference.domain import Domain
    from reference.io.deck import load_deck
    from reference.observables import crank_angle, midspan_deflection, rocker_angle, wrap

    deck = MODELS / "three_bar.toml"
    domain = Domain.from_deck(deck)
    drive = next(j for j in domain.joints if j.kind == "rotation_drive")
    theta0 = np.pi / 2

    def prescribed(t):
        return theta0 + np.array([drive.time_function.integral(s) for s in t])

    r = domain.solve(results_path=out / "three_bar" / "results.h5")
    t = r.time
    departure = wrap(rocker_angle(r) - fourbar_rocker_angle(prescribed(t)))
    defl = midspan_deflection(r)
    e = r.energy
    balance = e["external_work"] - e["kinetic"] - e["strain"]
    checks = []

    rr = load_deck(rigid_coupler_deck(deck, out / "three_bar_rigid.toml")).solve()
    rigid_err = np.max(np.abs(wrap(rocker_angle(rr) - fourbar_rocker_angle(prescribed(rr.time)))))
    checks.append(Check("three-bar rigid limit: rocker angle vs closed form [rad]", "four-bar position analysis",
                        float(rigid_err), *tolerance(domain, "rigid_limit")))
    checks.append(Check("three-bar flexible: max ‖Φ‖", "0", float(r.constraint_violation.max()),
                        *tolerance(domain, "constraint_drift")))
    second = int(round(1.0 / (domain.solver.dt * domain.solver.output_every)))
    growth = r.constraint_violation[-second:].max() / r.constraint_violation[1:second].max()
    checks.append(Check("three-bar flexible: ‖Φ‖ growth (last s / first s) − 1", "≤ 1 (not growing)",
                        float(max(growth - 1.0, 0.0)), *tolerance(domain, "drift_growth")))
    checks.append(Check("three-bar energy balance / peak kinetic energy", "0",
                        float(np.max(np.abs(balance)) / e["kinetic"].max()), *tolerance(domain, "energy_balance")))
    checks.append(Check("three-bar rocker departure from the rigid linkage [rad]", "≈ 5e-4 (Exudyn)",
                        float(np.max(np.abs(departure))), *tolerance(domain, "rocker_departure")))

    fig, ax = plt.subplots(figsize=(6.4, 5.4))
    mag = 50.0
    nodes = sorted((int(l.rsplit(":", 1)[1]), l) for l in r.labels if l.startswith("coupler:"))
    n = nodes[-1][0]
    times = np.arange(2.0, 6.0 + 1e-9, 0.25)
    cmap = plt.get_cmap("viridis")
    for k, tt in enumerate(times):
        i = int(np.argmin(np.abs(t - tt)))
        P = np.array([r.positions[i, r.labels.index(l)] for _, l in nodes])
        chord = P[0] + np.outer(np.arange(n + 1) / n, P[-1] - P[0])
        shown = chord + mag * (P - chord)
        col = cmap(k / (len(times) - 1))
        ax.plot([0.0, P[0, 0]], [0.0, P[0, 1]], "-", color=col, lw=2)
        ax.plot(shown[:, 0], shown[:, 1], "o-", color=col, ms=2.5, lw=1)
        ax.plot([P[-1, 0], 4.0], [P[-1, 1], 0.0], "-", color=col, lw=2)
    ax.plot([0, 4], [0, 0], "k^", ms=8)
    ax.set_aspect("equal")
    ax.set_title(f"Successive deformed configurations of the three-bar mechanism (paper Fig. 14)\n"
                 f"t = 2 … 6 s every 0.25 s; coupler deflection magnified ×{mag:g}", fontsize=9)
    save_figure(fig, figures / "three_bar_fig14.png", dpi=130)

    fig, axes = plt.subplots(3, 1, figsize=(6.4, 7.0), sharex=True)
    axes[0].plot(t, defl)
    axes[0].set_ylabel("coupler mid-span\ndeflection")
    axes[1].plot(t, departure)
    axes[1].set_ylabel("rocker − rigid\nlinkage [rad]")
    axes[2].semilogy(t[1:], r.constraint_violation[1:], label="‖Φ‖")
    axes[2].semilogy(t[1:], np.maximum(np.abs(balance[1:]) / e["kinetic"].max(), 1e-16), label="|energy balance| / peak T")
    axes[2].legend(fontsize=8)
    axes[2].set_xlabel("t [s]")
    save_figure(fig, figures / "three_bar_histories.png", dpi=130)

    dts = [2e-4, 1e-4] if quick else [2e-4, 1e-4, 5e-5, 2.5e-5]
    runs = {}
    for dt in dts:
        runs[dt] = Domain.from_deck(deck, overrides={"dt": dt}).solve() if dt != 2e-4 else r
    finest = runs[dts[-1]]
    step_lines = ["| dt | max rocker difference to finest [rad] | max deflection difference to finest |", "|---|---|---|"]
    rocker_diffs, defl_diffs = [], []
    for dt in dts[:-1]:
        ra = runs[dt]
        rd_ = float(np.max(np.abs(wrap(rocker_angle(ra) - rocker_angle(finest)))))
        dd = float(np.max(np.abs(midspan_deflection(ra) - midspan_deflection(finest))))
        rocker_diffs.append(rd_)
        defl_diffs.append(dd)
        step_lines.append(f"| {dt:g} | {rd_:.3e} | {dd:.3e} |")
    orders = [np.log2(a / b) for a, b in zip(defl_diffs[:-1], defl_diffs[1:])]
    if orders:
        step_lines.append("")
        step_lines.append("Observed order of the deflection history in the step: " + ", ".join(f"{o:.2f}" for o in orders)
                          + " (central differences: 2; the difference to the finest run slightly inflates the last one).")
    fig, ax = plt.subplots(figsize=(5.0, 3.8))
    ax.loglog(dts[:-1], defl_diffs, "o-", label="coupler deflection")
    ax.loglog(dts[:-1], rocker_diffs, "s-", label="rocker angle")
    ax.loglog(dts[:-1], defl_diffs[0] * (np.array(dts[:-1]) / dts[0]) ** 2, "k--", lw=0.8, label="slope 2")
    ax.set_xlabel("dt [s]")
    ax.set_ylabel("max difference to the finest run")
    ax.legend(fontsize=8)
    save_figure(fig, figures / "three_bar_dt.png", dpi=130)

    lines = [
        "## 2. Three-bar mechanism (paper §5.2, Figs. 13–14)",
        "",
        f"Deck: `models/three_bar.toml` — {domain.description}",
        "",
        *deck_data(domain),
        f"Rigid crank and rocker (one rigid body each), flexible coupler in 4 Beam2 elements, 5 joints "
        f"({domain.model.n_constraints} constraint equations, stabilised Lagrange multipliers), "
        f"h = {domain.solver.dt:g}, {int(round(domain.solver.t_end / domain.solver.dt))} steps: "
        f"reference solve {r.wall_time:.2f} s.",
        "",
        "![Fig. 14](figures/three_bar_fig14.png)",
        "",
        f"Peak coupler mid-span deflection {np.max(np.abs(defl)):.4f} (BENCHMARKS: about 0.019); "
        f"rocker departure from the rigid linkage {np.max(np.abs(departure)):.2e} rad (about 5e-4 with Exudyn); "
        f"max ‖Φ‖ {r.constraint_violation.max():.2e}; crank angle error "
        f"{np.max(np.abs(wrap(crank_angle(r) - prescribed(t)))):.1e} rad; rigid limit {rigid_err:.1e} rad.",
        "",
        "![histories](figures/three_bar_histories.png)",
        "",
        "### Convergence with the time step",
        "",
    ] + step_lines + ["", "![dt study](figures/three_bar_dt.png)", ""]

    return lines, checks


def crosscheck_section(out: Path, quick: bool, figures: Path) -> tuple[list[str], list[Check]]:
    """Every deck in models/ in both engines (issue: the cross-check harness), compared."""
    from crosscheck.harness import run
    from crosscheck.reactions import reaction_comparison

    lines = ["## 3. Cross-check with Exudyn", "",
             "Every deck is translated item by item into Exudyn 1.13 (`crosscheck/exudyn_model.py`) and solved "
             "with its generalized-α solver; both results files are compared by `crosscheck.compare` against the "
             "tolerances each deck states in `[crosscheck]`. Constraint drift and energies of both engines are "
             "measured with the reference's definitions.", ""]
    checks = []
    runs = [(deck, 1) for deck in sorted(MODELS.glob("*.toml"))]
    if not quick:
        runs.append((MODELS / "three_bar.toml", 8))
    for deck, refine in runs:
        t_end = 3.0 if quick and deck.stem == "three_bar" else None
        cmp = run(deck, out / f"crosscheck_{deck.stem}_{refine}", refine=refine, t_end=t_end, figures=figures)
        lines += cmp["markdown"]
        if deck.stem == "three_bar" and refine == 1:  # the crank torque and pin A's force, both engines
            lines += ["Joint reactions (Exudyn's joint sensors against the reference's multipliers):", ""]
            lines += reaction_comparison(cmp["reference"], cmp["exudyn"], path=figures / "three_bar_reactions.png")["markdown"] + [""]
        for v in cmp["verdicts"]:
            checks.append(Check(f"Exudyn cross-check {deck.stem}" + (f" ×{refine}" if refine > 1 else "")
                                + f": {v.observable}", f"Exudyn, relative to {v.relative_to}", v.measure,
                                v.tolerance, v.reason.replace("|", "/")))
    return lines, checks


def main(args=None) -> int:
    quick = bool(getattr(args, "quick", False))
    reports = Path(getattr(args, "out", None) or REPORTS)
    out = reports / "_runs"
    figures = reports / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    lines, checks = rollup_section(out, quick, figures)
    for section in (three_bar_section, crosscheck_section):
        more_lines, more_checks = section(out, quick, figures)
        lines, checks = lines + more_lines, checks + more_checks
    failed = [c for c in checks if not c.passed]
    head = [
        "# flexmbs verification report",
        "",
        "Generated by `flexmbs report`" + (" --quick" if quick else "") + " — do not edit by hand. "
        "Every check names its reference and the reason for its tolerance.",
        "",
        f"**{len(checks) - len(failed)} of {len(checks)} checks pass.**" + (
            "  Failed: " + "; ".join(c.name for c in failed) if failed else ""),
        "",
    ]
    body = head + lines + ["## All checks", ""] + _table(checks)
    body += ["", f"Report generated in {time.perf_counter() - t0:.1f} s."]
    name = "verification_quick.md" if quick else "verification.md"
    (reports / name).write_text("\n".join(body) + "\n", encoding="utf-8")
    from flexmbs.html import markdown_to_html

    (reports / name).with_suffix(".html").write_text(markdown_to_html("\n".join(body), reports), encoding="utf-8")
    print(f"wrote {reports / name}: {len(checks) - len(failed)}/{len(checks)} checks pass")
    for c in failed:
        print(f"FAILED: {c.name}: computed {c.computed:.3e}, tolerance {c.tolerance:.1e}")
    return 1 if failed else 0
