"""Cantilever in free vibration, first mode (docs/benchmarks.md §3): Euler–Bernoulli frequency, energy."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import crossings, history_axes


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import cantilever_first_frequency

    domain = ctx.domain()
    sec = domain.elements[0].formulation.section
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    w1 = cantilever_first_frequency(L, sec.EI2, sec.rhoA)
    r = ctx.solve(domain, results_file=True)
    tip = domain.nodes[-1].label
    z = r.position(tip)[:, 2]
    ups = crossings(r.time, z, direction=+1)
    measured = 2 * np.pi / np.diff(ups)
    e = r.energy
    E = e["kinetic"] + e["strain"]
    checks = [ctx.check("frequency", f"first frequency vs Euler–Bernoulli ({len(measured)} periods), relative",
                        f"{w1:.6f} rad/s", np.max(np.abs(measured / w1 - 1)) if len(measured) else np.nan),
              ctx.check("energy", "max |Δ(T + U)| / (T + U)(0)", "0 (conservative)", np.max(np.abs(E - E[0])) / E[0])]
    fig, axes = history_axes(plt, 2)
    axes[0].plot(r.time, 1e3 * z, label="tip deflection (reference engine)")
    amp = np.max(np.abs(z))
    axes[0].plot(r.time, 1e3 * amp * np.sin(w1 * r.time), "k:", lw=0.8, label=f"amplitude × sin(ω1 t), ω1 = {w1:.4f} rad/s")
    axes[0].set_ylabel("tip deflection\nz [mm]")
    axes[0].legend(fontsize=7, loc="lower left")
    axes[1].plot(r.time, e["kinetic"], label="kinetic T")
    axes[1].plot(r.time, e["strain"], label="strain U")
    axes[1].plot(r.time, E, "k--", label="T + U")
    axes[1].set_ylabel("energy [J]")
    axes[1].legend(fontsize=7)
    axes[0].set_title("Cantilever started in its first mode: free vibration", fontsize=10)
    lines = [ctx.figure(fig, "cantilever_vibration.png", "cantilever vibration"), "",
             f"Euler–Bernoulli ω1 = 1.87510² √(EI/(ρA L⁴)) = {w1:.6f} rad/s; measured "
             f"{', '.join(f'{m:.6f}' for m in measured)} rad/s ({(measured.mean() / w1 - 1) * 100:+.3f} %: "
             "shear, rotary inertia and the lumped 20-element mesh each lower it slightly).", ""]
    return lines, checks
