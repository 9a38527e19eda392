"""Large deflection of a cantilever under a dead tip load (docs/benchmarks.md §3): elliptic closed form,
Bisshopp & Drucker's published value, energy balance."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import at

PUBLISHED = {1.0: 0.30172}
"""Bisshopp & Drucker (1945), tip deflection / L at P L²/EI = 1."""


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import cantilever_large_deflection

    domain = ctx.domain()
    sec = domain.elements[0].formulation.section
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    load = domain.loading[0]
    P0 = float(np.linalg.norm(load.vector))
    r = ctx.solve(domain, results_file=True)
    tip = domain.nodes[-1].label
    holds = [(4.0, 1.0), (8.0, 2.0)]
    lines = ["| P L²/EI | t [s] | tip x/L | tip deflection/L | closed form x/L | closed form δ/L | error / L |",
             "|---|---|---|---|---|---|---|"]
    checks = []
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.0, 3.8), gridspec_kw={"width_ratios": [1.2, 1]})
    for t, level in holds:
        alpha = P0 * level * L**2 / sec.EI2
        x, dz, _ = cantilever_large_deflection(alpha)
        p = at(r, tip, t)
        err = np.linalg.norm(p - np.array([x * L, 0.0, -dz * L])) / L
        lines.append(f"| {alpha:g} | {t:g} | {p[0] / L:.5f} | {-p[2] / L:.5f} | {x:.5f} | {dz:.5f} | {err:.2e} |")
        checks.append(ctx.check("tip", f"tip vs elastica at P L²/EI = {alpha:g}, / L", "elliptic closed form", err))
        if alpha in PUBLISHED:
            checks.append(ctx.check("published", f"tip deflection at P L²/EI = {alpha:g}, / L",
                                    f"Bisshopp & Drucker: {PUBLISHED[alpha]}", abs(-p[2] / L - PUBLISHED[alpha])))
        i = int(np.argmin(np.abs(r.time - t)))
        ax.plot(r.positions[i, :, 0], r.positions[i, :, 2], "o-", ms=3, label=f"P L²/EI = {alpha:g} (t = {t:g} s)")
        ax.plot([x * L], [-dz * L], "kx", ms=9)
    e = r.energy
    balance = np.max(np.abs(e["external_work"] - e["strain"] - e["kinetic"] - e["dissipated"])) / e["external_work"][-1]
    checks.append(ctx.check("energy", "W − (U + T + D), relative to W", "0", balance))
    ax.plot([0, L], [0, 0], "k:", lw=0.8)
    ax.plot([], [], "kx", label="closed-form tip (elastica)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Deformed shapes at the end of each hold", fontsize=9)
    z = r.position(tip)[:, 2]
    bx.plot(r.time, -z / L, label="tip deflection / L")
    for t, level in holds:
        bx.axhline(cantilever_large_deflection(P0 * level * L**2 / sec.EI2)[1], color="k", ls=":", lw=0.8)
    bx.set_xlabel("time t [s]")
    bx.set_ylabel("tip deflection δ / L [–]")
    bx.set_title("Settling to the static answer (dotted)", fontsize=9)
    lines = [ctx.figure(fig, "cantilever_large_deflection.png", "large deflection"), ""] + lines + [""]
    return lines, checks
