"""Torsion-spring double pendulum in its first mode: period and mode shape against the linearised
2 × 2 eigenproblem, conservation of energy with springs."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import crossings, energy_error, energy_panel, history_axes


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import torsion_double_pendulum_modes

    domain = ctx.domain()
    k1, k2 = (fe.stiffness for fe in domain.force_elements)
    up = domain.node("upper")
    omegas, modes = torsion_double_pendulum_modes(up.mass, 0.5, 9.81, k1, k2)
    r = ctx.solve(domain, results_file=True)
    theta = {b: 2 * np.arctan2(r.rotation(b)[:, 2], r.rotation(b)[:, 0]) for b in ("upper", "lower")}
    period = np.mean(np.diff(crossings(r.time, theta["upper"], direction=+1)))
    T1 = 2 * np.pi / omegas[0]
    ratio = theta["lower"].max() / theta["upper"].max()
    checks = [ctx.check("first_period", "first-mode period, relative error", f"T1 = {T1:.6f} s", abs(period / T1 - 1)),
              ctx.check("mode_shape", "amplitude ratio θ2/θ1, relative error", f"{modes[1, 0]:.6f}",
                        abs(ratio / modes[1, 0] - 1)),
              ctx.check("energy", "|Δ(W_gravity − T − U_springs)| / peak T", "0 (conservative)", energy_error(r))]
    fig, axes = history_axes(plt, 2)
    for b in theta:
        axes[0].plot(r.time, 1e3 * theta[b], label=f"{b} bar")
    axes[0].set_ylabel("angle about y [mrad]")
    axes[0].legend(fontsize=7)
    axes[0].set_title("Torsion-spring double pendulum started in its first mode", fontsize=10)
    energy_panel(axes[1], r)
    lines = [ctx.figure(fig, "torsion_double_pendulum.png", "torsion double pendulum"), "",
             f"Linearised modes: ω = {omegas[0]:.6f} and {omegas[1]:.6f} rad/s; measured first-mode period "
             f"{period:.6f} s against {T1:.6f} s; amplitude ratio {ratio:.6f} against {modes[1, 0]:.6f}.", ""]
    return lines, checks
