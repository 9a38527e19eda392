"""Rigid slider-crank at constant crank speed (docs/benchmarks.md §3): closed-form kinematics, energy."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import energy_error, energy_panel, history_axes


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    domain = ctx.domain()
    drive = next(j for j in domain.joints if j.kind == "rotation_drive")
    A = next(j for j in domain.joints if j.label == "A").point
    B = next(j for j in domain.joints if j.label == "B").point
    O = drive.point
    rc, lr = float(np.linalg.norm(A - O)), float(np.linalg.norm(B - A))
    theta0 = float(np.arctan2(A[1] - O[1], A[0] - O[0]))
    r = ctx.solve(domain, results_file=True)
    theta = theta0 + np.array([drive.time_function.integral(s) for s in r.time])
    closed = O[0] + rc * np.cos(theta) + np.sqrt(lr**2 - (rc * np.sin(theta)) ** 2)
    x = r.position("slider")[:, 0]
    checks = [ctx.check("slider_position", "max |x_B − closed form| [m]", "position analysis", np.max(np.abs(x - closed))),
              ctx.check("energy", "|Δ(W_drive − T)| / peak T", "0 (the drive is the only input)", energy_error(r))]
    fig, axes = history_axes(plt, 3)
    axes[0].plot(r.time, x, label="slider x (reference engine)")
    axes[0].plot(r.time, closed, "k:", label="closed form r cos θ + √(l² − r² sin² θ)")
    axes[0].set_ylabel("slider position\nx_B [m]")
    axes[0].legend(fontsize=7)
    axes[1].plot(r.time, 1e6 * (x - closed))
    axes[1].set_ylabel("x_B − closed\nform [µm]")
    energy_panel(axes[2], r)
    axes[0].set_title(f"Slider-crank, crank {rc:g} m, rod {lr:g} m, driven at constant speed", fontsize=10)
    lines = [ctx.figure(fig, "slider_crank.png", "slider-crank"), "",
             f"Max slider position error {np.max(np.abs(x - closed)):.2e} m over {r.time[-1]:g} s; "
             f"max ‖Φ‖ {np.max(r.constraint_violation):.2e} m.", ""]
    return lines, checks
