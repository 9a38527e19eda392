"""Heavy symmetric top in steady precession (docs/benchmarks.md §3): closed-form rate, no nutation, first integrals."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import energy_error, energy_panel, history_axes, inertia_about


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import steady_precession_rate
    from reference.rotation import EulerParameters

    domain = ctx.domain()
    top = domain.node("top")
    pivot = domain.joints[0].point
    r0 = top.position - pivot
    l = float(np.linalg.norm(r0))
    axis0 = EulerParameters(top.rotation).matrix()[:, 2]
    tilt0 = float(np.arccos(axis0[2]))
    C = float(top.inertia[2, 2])
    A = inertia_about(top, np.cross(axis0, [0.0, 0.0, 1.0])) + top.mass * l**2
    omega3 = float(top.angular_velocity[2])
    Omega = steady_precession_rate(top.mass, 9.81, l, A, C, omega3, tilt0)
    r = ctx.solve(domain, results_file=True)
    c = r.position("top") - pivot
    azimuth = np.unwrap(np.arctan2(c[:, 1], c[:, 0]))
    rate = (azimuth[-1] - azimuth[0]) / (r.time[-1] - r.time[0])
    tilt = np.arccos(np.clip(c[:, 2] / np.linalg.norm(c, axis=1), -1, 1))
    w3 = r.angular_velocities[:, r.index("top"), 2]
    checks = [ctx.check("precession_rate", "mean precession rate, relative error", f"Ω = {Omega:.6f} rad/s", rate / Omega - 1),
              ctx.check("nutation", "max |tilt − θ0| [rad]", "0 (steady precession)", np.max(np.abs(tilt - tilt0))),
              ctx.check("energy", "|Δ(W_gravity − T)| / T", "0 (conservative)", energy_error(r)),
              ctx.check("spin", "max |ω3 − ω3(0)| / ω3", "0 (first integral)", np.max(np.abs(w3 - omega3)) / abs(omega3))]
    fig, axes = history_axes(plt, 3)
    axes[0].plot(r.time, azimuth, label="reference engine")
    axes[0].plot(r.time, azimuth[0] + Omega * r.time, "k:", label=f"closed form Ω t, Ω = {Omega:.4f} rad/s")
    axes[0].set_ylabel("precession\nangle [rad]")
    axes[0].legend(fontsize=7)
    axes[1].plot(r.time, 1e3 * (tilt - tilt0))
    axes[1].set_ylabel("tilt − 30°\n[mrad]")
    energy_panel(axes[2], r)
    axes[0].set_title("Heavy symmetric top: precession and nutation", fontsize=10)
    lines = [ctx.figure(fig, "heavy_top.png", "top histories"), "",
             f"A = {A:.4f} kg m² (transverse, about the tip), C = {C:g} kg m², l = {l:g} m, θ0 = "
             f"{np.degrees(tilt0):.1f}°, ω3 = {omega3:g} rad/s: slow steady precession Ω = {Omega:.6f} rad/s; "
             f"measured {rate:.6f} rad/s.", ""]
    return lines, checks
