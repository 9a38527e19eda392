"""Embedded beam rolled up by an end torque (paper §5.1, Figs. 11–12; docs/benchmarks.md §1).

Checks: the tip against the elastica at the paper's load factors *and* at every
output of the whole run (the acceptance criterion is about the whole history),
the closure at k = 2, the exact planarity, the energy balance, and the order of
convergence with the mesh.
"""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import at


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import elastica_tip, polygon_tip

    domain = ctx.domain()
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    n0 = len(domain.elements)
    r = ctx.solve(domain, results_file=True)
    tip = domain.nodes[-1].label
    ks = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0]

    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for k in ks:
        i = int(np.argmin(np.abs(r.time - k)))
        ax.plot(r.positions[i, :, 0], r.positions[i, :, 2], "o-", ms=3, lw=1.2, label=f"k = {k:g}")
        th = k * np.pi / L * np.linspace(0, L, 200)
        ax.plot(L * np.sin(th) / (k * np.pi), L * (1 - np.cos(th)) / (k * np.pi), "k:", lw=0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("Successive deflections of the embedded beam (paper Fig. 12)\n"
                 f"{n0} Beam2 elements; dotted: elastica arcs (closed form)", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    lines = [ctx.figure(fig, "rollup_fig12.png", "Fig. 12"), "",
             "Tip position against the elastica (closed form: x = L sin t/t, z = L(1 − cos t)/t, t = kπ) and "
             "against the converged discrete answer (a regular polygon of unstrained chords):", "",
             "| k | x/L | z/L | closed form x/L | closed form z/L | error / L | polygon error / L |",
             "|---|---|---|---|---|---|---|"]
    checks = []
    for k in ks:
        p, ex = at(r, tip, k), elastica_tip(L, k)
        err = np.linalg.norm(p - ex) / L
        perr = np.linalg.norm(p - polygon_tip(L, n0, k)) / L
        lines.append(f"| {k:g} | {p[0] / L:.6f} | {p[2] / L:.6f} | {ex[0] / L:.6f} | {ex[2] / L:.6f} | {err:.2e} | {perr:.2e} |")
        checks.append(ctx.check("tip_vs_elastica", f"tip error / L at k = {k:g}", "elastica", err))

    hist_lines, hist_checks = _history(ctx, r, L, n0, tip, plt)
    lines += hist_lines
    checks += hist_checks
    checks.append(ctx.check("closes_at_k2", "|tip| / L at k = 2 (closed circle)", "0", np.linalg.norm(at(r, tip, 2.0)) / L))
    checks.append(ctx.check("out_of_plane", "max |y| over all nodes and times [m]", "0 exactly",
                            np.abs(r.positions[:, :, 1]).max()))
    e = r.energy
    balance = np.max(np.abs(e["external_work"] - e["strain"] - e["kinetic"] - e["dissipated"])) / e["external_work"][-1]
    checks.append(ctx.check("energy_balance", "energy balance W − (U + T + D), relative to W", "0", balance))

    conv_lines, conv_checks = _convergence(ctx, domain, r, L, n0, ks, plt)
    return lines + conv_lines, checks + conv_checks


def _history(ctx, r, L, n0, tip, plt):
    """The tip against the elastica and the converged polygon at every output: checks, text, figure."""
    from flexmbs.verification.analytic import elastica_tip, polygon_tip

    checks, lines = [], []
    # the claim is about the whole quasi-static history: every output, not only the sampled k
    ex_all = np.array([elastica_tip(L, k) for k in r.time])
    errs = np.linalg.norm(r.position(tip) - ex_all, axis=1) / L
    pol_all = np.array([polygon_tip(L, n0, k) for k in r.time])
    perrs = np.linalg.norm(r.position(tip) - pol_all, axis=1) / L
    worst = int(np.argmax(errs))
    checks.append(ctx.check("tip_vs_elastica", f"max tip error / L over the whole history ({len(r.time)} outputs)",
                            "elastica", errs[worst]))
    disc = np.linalg.norm(pol_all - ex_all, axis=1) / L
    lines += ["", f"**Over the whole history** (every output, Δk = {r.time[1] - r.time[0]:g}) the tip error reaches "
              f"{100 * errs[worst]:.3f} % L at k = {r.time[worst]:.2f} — close to the 0.5 % L criterion, and larger "
              "than at any of the paper's sampled k (table above), which miss this early peak. It is the dynamic lag: "
              "at small k the torque rises from rest and the beam trails the static answer; the tip's distance to the "
              f"converged 12-element polygon (the lag alone) is {100 * perrs[worst]:.3f} % L there, while the "
              f"discretisation error (polygon − elastica) is at most {100 * disc.max():.3f} % L over the run "
              f"(k = {r.time[int(np.argmax(disc))]:.2f}).", ""]
    fig, ax = plt.subplots(figsize=(6.4, 3.4))
    ax.plot(r.time, 100 * errs, label="tip − elastica (total)")
    ax.plot(r.time, 100 * perrs, "--", label="tip − converged 12-element polygon (dynamic lag)")
    ax.plot(r.time, 100 * disc, ":", label="polygon − elastica (discretisation)")
    ax.axhline(100 * ctx.tolerance("tip_vs_elastica")[0], color="r", lw=0.8, label="tolerance")
    ax.set_xlabel("load factor k (= time t) [–]")
    ax.set_ylabel("tip error / L [%]")
    ax.legend(fontsize=7)
    ax.set_title("Roll-up: tip error over the whole history", fontsize=10)
    lines += [ctx.figure(fig, "rollup_history.png", "tip error history"), ""]

    return lines, checks


def _convergence(ctx, domain, r, L, n0, ks, plt):
    """The order of convergence with the mesh, on the differences between successive meshes."""
    from flexmbs.verification.analytic import elastica_tip

    checks, lines = [], []
    refinements = [1, 2] if ctx.quick else [1, 2, 4, 8]
    runs = {n0: (domain, r)}
    for rf in refinements[1:]:
        d = ctx.domain(refine=rf)
        runs[rf * n0] = (d, ctx.solve(d, f"×{rf}"))
    ns = sorted(runs)
    diffs = [max(np.linalg.norm(at(runs[a][1], runs[a][0].nodes[-1].label, k) - at(runs[b][1], runs[b][0].nodes[-1].label, k))
                 for k in ks) / L for a, b in zip(ns[:-1], ns[1:])]
    errs_n = [max(np.linalg.norm(at(runs[n][1], runs[n][0].nodes[-1].label, k) - elastica_tip(L, k)) for k in ks) / L
              for n in ns]
    orders = [np.log2(d1 / d2) for d1, d2 in zip(diffs[:-1], diffs[1:])]
    lines += ["### Convergence with the mesh", "",
              "The step halves with the element length (the critical step does). Raw tip errors contain a "
              "mesh-independent dynamic lag, so the order is measured on differences between successive meshes "
              "(docs/benchmarks.md §1).", "",
              "| elements | Δk | max tip error / L (vs elastica) | max difference to next mesh / L | observed order |",
              "|---|---|---|---|---|"]
    for i, n in enumerate(ns):
        diff = f"{diffs[i]:.3e}" if i < len(diffs) else "—"
        order = f"{orders[i - 1]:.3f}" if 0 < i < len(diffs) else "—"
        lines.append(f"| {n} | {runs[n][0].solver.dt:g} | {errs_n[i]:.3e} | {diff} | {order} |")
    if orders:
        checks.append(ctx.check("convergence_order", f"2 − observed order ({ns[0]}→{ns[-1]} elements)", "≤ 0.1",
                                max(0.0, 2.0 - min(orders))))
    fig, ax = plt.subplots(figsize=(5.4, 4.0))
    ax.loglog(ns, errs_n, "o-", label="max tip error vs elastica")
    if diffs:
        ax.loglog(ns[:-1], diffs, "s-", label="difference to the next mesh")
        ax.loglog(ns[:-1], diffs[0] * (np.array(ns[:-1]) / ns[0]) ** -2.0, "k--", lw=0.8, label="slope −2")
    ax.set_xlabel("number of elements [–]")
    ax.set_ylabel("tip error / L [–]")
    ax.legend(fontsize=8)
    ax.set_title("Roll-up: tip error against the number of elements", fontsize=10)
    lines += ["", ctx.figure(fig, "rollup_convergence.png", "convergence"), ""]
    return lines, checks
