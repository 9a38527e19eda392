"""Three-bar mechanism (paper §5.2, Figs. 13–14; docs/benchmarks.md §2).

Checks: the rigid limit against the closed-form four-bar position analysis,
the constraint drift and its growth, the energy balance of the driven linkage,
the rocker's departure from the rigid linkage; a time-step study.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from flexmbs.deckchecks import history_axes


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


def quasi_static_deck(deck: Path, path: Path, load_steps: int = 4) -> Path:
    """The three-bar deck solved by the static algorithm (``[solver]`` replaced): the load factor λ ∈ [0, 1]
    is the time, so the crank drive turns the crank quasi-statically by its angle at t = 1 s (0.1875 Ω rad).
    Without inertia or loads the coupler stays unstrained and the rocker angle is the four-bar's position
    analysis: the static solve of a mechanism is its kinematics."""
    text = re.sub(r"\[solver\][^\[]*", f'[solver]\nalgorithm = "static"\nt_end = 1.0\nload_steps = {load_steps}\n\n',
                  deck.read_text())
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def fig14(ctx, domain, r, magnify: float = 50.0) -> str:
    """Paper Fig. 14: successive configurations, coupler deflection magnified, coloured by time."""
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    from flexmbs.plot import configuration, geometry

    shapes = geometry(domain)
    times = np.arange(2.0, 6.0 + 1e-9, 0.25)
    norm = Normalize(times[0], times[-1])
    cmap = plt.get_cmap("viridis")
    fig, ax = plt.subplots(figsize=(6.8, 5.6))
    for tt in times:
        i = int(np.argmin(np.abs(r.time - tt)))
        col = cmap(norm(tt))
        for label, P in configuration(r, i, shapes, magnify):
            if label == "coupler":
                ax.plot([P[0, 0], P[-1, 0]], [P[0, 1], P[-1, 1]], ":", color=col, lw=0.6)
                ax.plot(P[:, 0], P[:, 1], "o-", color=col, ms=2.5, lw=1.2)
            else:
                ax.plot(P[:, 0], P[:, 1], "-", color=col, lw=2.2)
    ax.plot([0, 4], [0, 0], "k^", ms=9)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8, label="time t [s]")
    ax.set_title(f"Three-bar mechanism, t = 2 … 6 s every 0.25 s (paper Fig. 14)\ncoupler deflection from its chord "
                 f"(dotted) magnified ×{magnify:g}; thick: rigid crank and rocker", fontsize=9)
    return ctx.figure(fig, "three_bar_fig14.png", "Fig. 14")


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import fourbar_rocker_angle
    from flexmbs.verification.observables import crank_angle, midspan_deflection, rocker_angle
    from reference.io.deck import load_deck
    from reference.observables import wrap

    domain = ctx.domain()
    drive = next(j for j in domain.joints if j.kind == "rotation_drive")

    def prescribed(t):
        return np.pi / 2 + np.array([drive.time_function.integral(s) for s in t])

    r = ctx.solve(domain, results_file=True)
    t = r.time
    departure = wrap(rocker_angle(r) - fourbar_rocker_angle(prescribed(t)))
    defl = midspan_deflection(r)
    e = r.energy
    balance = e["external_work"] - e["kinetic"] - e["strain"]
    rigid = load_deck(rigid_coupler_deck(ctx.deck, ctx.out / "three_bar_rigid.toml")).domain
    rr = ctx.solve(rigid, "rigid coupler")
    rigid_err = np.max(np.abs(wrap(rocker_angle(rr) - fourbar_rocker_angle(prescribed(rr.time)))))
    second = int(round(1.0 / (domain.solver.dt * domain.solver.output_every)))
    growth = r.constraint_violation[-second:].max() / r.constraint_violation[1:second].max()
    checks = [
        ctx.check("rigid_limit", "rigid limit: rocker angle vs closed form [rad]", "four-bar position analysis", rigid_err),
        ctx.check("constraint_drift", "flexible: max ‖Φ‖ [m]", "0", r.constraint_violation.max()),
        ctx.check("drift_growth", "flexible: ‖Φ‖ growth (last s / first s) − 1", "≤ 1 (not growing)", max(growth - 1.0, 0.0)),
        ctx.check("energy_balance", "energy balance W_drive − (T + U) / peak T", "0",
                  np.max(np.abs(balance)) / e["kinetic"].max()),
        ctx.check("rocker_departure", "rocker departure from the rigid linkage [rad]", "≈ 5e-4 (Exudyn)",
                  np.max(np.abs(departure))),
    ]
    lines = [fig14(ctx, domain, r), "",
             f"Peak coupler mid-span deflection {np.max(np.abs(defl)):.4f} m (docs/benchmarks.md §2: about 0.019); "
             f"rocker departure from the rigid linkage {np.max(np.abs(departure)):.2e} rad (about 5e-4 with Exudyn); "
             f"max ‖Φ‖ {r.constraint_violation.max():.2e} m; crank angle error "
             f"{np.max(np.abs(wrap(crank_angle(r) - prescribed(t)))):.1e} rad; rigid limit {rigid_err:.1e} rad.", ""]

    fig, axes = history_axes(plt, 3)
    axes[0].plot(t, 1e3 * defl)
    axes[0].set_ylabel("coupler mid-span\ndeflection [mm]")
    axes[1].plot(t, 1e3 * departure)
    axes[1].set_ylabel("rocker − rigid\nlinkage [mrad]")
    axes[2].semilogy(t[1:], r.constraint_violation[1:], label="‖Φ‖ [m]")
    axes[2].semilogy(t[1:], np.maximum(np.abs(balance[1:]) / e["kinetic"].max(), 1e-16), label="|W − T − U| / peak T [–]")
    axes[2].set_ylabel("drift, energy\nbalance")
    axes[2].legend(fontsize=8)
    axes[0].set_title("Three-bar mechanism: histories (reference engine)", fontsize=10)
    lines += [ctx.figure(fig, "three_bar_histories.png", "histories"), ""]

    return lines + _step_convergence(ctx, r, plt), checks


def _step_convergence(ctx, r, plt) -> list:
    """The deck's run against runs at smaller steps: the table, the observed order, the figure."""
    from flexmbs.verification.observables import midspan_deflection, rocker_angle
    from reference.observables import wrap

    dts = [2e-4, 1e-4] if ctx.quick else [2e-4, 1e-4, 5e-5, 2.5e-5]
    runs = {dts[0]: r}
    for dt in dts[1:]:
        runs[dt] = ctx.solve(ctx.domain(dt=dt), f"dt={dt:g}")
    finest = runs[dts[-1]]
    lines = ["### Convergence with the time step", "",
              "| dt [s] | max rocker difference to finest [rad] | max deflection difference to finest [m] |", "|---|---|---|"]
    rocker_diffs, defl_diffs = [], []
    for dt in dts[:-1]:
        rocker_diffs.append(float(np.max(np.abs(wrap(rocker_angle(runs[dt]) - rocker_angle(finest))))))
        defl_diffs.append(float(np.max(np.abs(midspan_deflection(runs[dt]) - midspan_deflection(finest)))))
        lines.append(f"| {dt:g} | {rocker_diffs[-1]:.3e} | {defl_diffs[-1]:.3e} |")
    orders = [np.log2(a / b) for a, b in zip(defl_diffs[:-1], defl_diffs[1:])]
    if orders:
        lines += ["", "Observed order of the deflection history in the step: " + ", ".join(f"{o:.2f}" for o in orders)
                  + " (central differences: 2; the difference to the finest run slightly inflates the last one)."]
    fig, ax = plt.subplots(figsize=(5.0, 3.8))
    ax.loglog(dts[:-1], defl_diffs, "o-", label="coupler deflection [m]")
    ax.loglog(dts[:-1], rocker_diffs, "s-", label="rocker angle [rad]")
    ax.loglog(dts[:-1], defl_diffs[0] * (np.array(dts[:-1]) / dts[0]) ** 2, "k--", lw=0.8, label="slope 2")
    ax.set_xlabel("time step dt [s]")
    ax.set_ylabel("max difference to the finest run")
    ax.legend(fontsize=8)
    ax.set_title("Three-bar: convergence with the time step", fontsize=10)
    lines += ["", ctx.figure(fig, "three_bar_dt.png", "dt study"), ""]
    return lines
