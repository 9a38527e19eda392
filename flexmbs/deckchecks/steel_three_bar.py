"""Steel three-bar: generalized-α at 400 explicit steps against the explicit scheme, same mesh."""

from __future__ import annotations

import time

import numpy as np

from flexmbs.deckchecks import history_axes


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification import observables as ob

    t_end = 0.25 if ctx.quick else 2.0
    runs = {}
    for algorithm, dt in (("generalized_alpha", 1e-3), ("staggered_central_difference", 2.5e-6)):
        d = ctx.domain(t_end=t_end)
        d.solver.algorithm, d.solver.dt, d.solver.output_every = algorithm, dt, int(round(1e-3 / dt))
        d.solve(t_end=10 * dt)  # warm-up: compilation
        t0 = time.perf_counter()
        r = d.solve()
        runs[algorithm] = (r, time.perf_counter() - t0)
    (ga, t_ga), (ex, t_ex) = runs["generalized_alpha"], runs["staggered_central_difference"]
    d = ctx.domain(t_end=t_end)  # the implicit run once more, into the results file of the report's 3D view
    d.solver.algorithm, d.solver.dt, d.solver.output_every = "generalized_alpha", 1e-3, 1
    ctx.solve(d, "", results_file=True)
    dg, de = ob.midspan_deflection(ga), ob.midspan_deflection(ex)
    peak = float(np.max(np.abs(de)))
    diff = float(np.max(np.abs(dg - de))) / peak
    checks = [ctx.check("explicit_agreement", "max |deflection difference| / peak", "explicit, dt = 2.5e-6 s", diff),
              ctx.check("speedup", "20 t(generalized-α) / t(explicit)", f"explicit {t_ex:.2f} s", 20 * t_ga / t_ex)]
    fig, axes = history_axes(plt, 2)
    axes[0].plot(ex.time, 1e6 * de, label="explicit, h = 2.5e-6 s")
    axes[0].plot(ga.time, 1e6 * dg, "--", label="generalized-α, h = 1e-3 s")
    axes[0].set_ylabel("mid-span\ndeflection [µm]")
    axes[0].legend(fontsize=7)
    axes[1].plot(ga.time, 1e6 * (dg - de))
    axes[1].set_ylabel("difference [µm]")
    axes[0].set_title("Steel three-bar: implicit and explicit, same mesh", fontsize=10)
    lines = [ctx.figure(fig, "steel_three_bar.png", "steel coupler deflection"), "",
             f"{t_end:g} s of the spin-up: explicit {t_ex:.2f} s ({int(round(t_end / 2.5e-6))} steps), generalized-α "
             f"{t_ga:.3f} s ({int(round(t_end / 1e-3))} steps), {t_ex / t_ga:.0f} times faster; peak deflection "
             f"{peak:.3e} m, largest difference {diff:.2%} of it. The full 12 s run and the work–precision "
             "comparison with Exudyn are in `flexmbs bench`.", ""]
    return lines, checks
