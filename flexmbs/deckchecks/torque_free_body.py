"""Torque-free asymmetric body, the Dzhanibekov flip (docs/benchmarks.md §3): elliptic period, first integrals."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import crossings, history_axes


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import torque_free_flip_period
    from reference.rotation import EulerParameters

    domain = ctx.domain()
    body = domain.node("body")
    J = np.diag(body.inertia).copy()
    w0 = body.angular_velocity.copy()
    T = torque_free_flip_period(J, w0)
    r = ctx.solve(domain, results_file=True)
    k = r.index("body")
    w = r.angular_velocities[:, k]
    ups = crossings(r.time, w[:, 0], direction=+1)
    periods = np.diff(ups)
    L = np.array([EulerParameters(q).matrix() @ (body.inertia @ om) for q, om in zip(r.rotations[:, k], w)])
    kin = r.energy["kinetic"]
    checks = [
        ctx.check("flip_period", f"period of ω vs elliptic closed form ({len(periods)} measured), relative",
                  f"{T:.6f} s", np.max(np.abs(periods - T)) / T if len(periods) else np.nan),
        ctx.check("energy", "max |T − T(0)| / T(0)", "0 (first integral)", np.max(np.abs(kin - kin[0])) / kin[0]),
        ctx.check("momentum", "max |L − L(0)| / |L| (inertial)", "0 (first integral)",
                  np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0])),
    ]
    fig, axes = history_axes(plt, 2)
    for i in range(3):
        axes[0].plot(r.time, w[:, i], label=f"ω{i + 1} (I{i + 1} = {J[i]:g} kg m²)")
    for j, tu in enumerate(ups[:1]):
        for n in range(len(ups)):
            axes[0].axvline(tu + n * T, color="k", ls=":", lw=0.7, label="closed-form period" if n == 0 else None)
    axes[0].set_ylabel("body angular\nvelocity [rad/s]")
    axes[0].legend(fontsize=7, loc="lower right")
    axes[1].semilogy(r.time[1:], np.maximum(np.abs(kin[1:] - kin[0]) / kin[0], 1e-17), label="|ΔT| / T")
    axes[1].semilogy(r.time[1:], np.maximum(np.linalg.norm(L[1:] - L[0], axis=1) / np.linalg.norm(L[0]), 1e-17),
                     label="|ΔL| / |L|")
    axes[1].set_ylabel("first integrals,\nrelative change [–]")
    axes[1].legend(fontsize=7)
    axes[0].set_title("Torque-free body spun about its intermediate axis (Dzhanibekov flip)", fontsize=10)
    lines = [ctx.figure(fig, "torque_free_body.png", "Dzhanibekov flip"), "",
             f"Elliptic closed form: period of the body angular velocity {T:.6f} s; measured "
             f"{', '.join(f'{p:.6f}' for p in periods)} s.", ""]
    return lines, checks
