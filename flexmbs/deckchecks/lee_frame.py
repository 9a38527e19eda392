"""Lee's frame (``algorithm = "arc_length"``): the two limit loads against the literature and the converged mesh,
the path against Simo & Vu-Quoc's (1986) digitised curves, and the same frame by displacement control.

The load P is quoted as P L²/EI (L the leg length), the displacements u (horizontal, to the right) and v
(downward) of the load point as in the literature's figures.  A digitised point is compared by its distance to
the computed path (a polyline through the converged points) in the plot's own scales: displacement over L, load
over the published first limit load.
"""

from __future__ import annotations

import numpy as np

LOAD_NODE = "load"

HORIZONTAL = np.array([
    [
        0.10791, 0.21018, 0.45486, 0.89897, 2.1847, 3.5132, 4.8272, 6.6264, 8.3397, 10.667,
        12.551, 14.906, 16.733, 18.903, 21.215, 23.113, 25.382, 27.294, 29.278, 31.247,
        33.716, 36.085, 38.054, 40.352, 42.307, 44.29, 46.002, 48.243, 50.083, 52.024,
        53.879, 55.833, 57.717, 59.543, 61.027, 62.682, 64.123, 65.835, 67.404, 69.216,
        70.685, 72.411, 73.881, 75.521, 77.161, 78.373, 79.727, 80.097, 80.966, 81.835,
        83.29, 85.244, 87.084, 89.353, 91.223, 92.679, 93.821, 94.022, 93.951, 93.495,
        92.655, 91.771, 90.887, 89.974, 89.034, 88.264, 87.552, 87.068, 86.599, 86.343,
        86.201, 86.074, 85.89, 85.82, 85.864, 85.865, 85.938, 86.025, 85.998, 86.071,
        86.129, 86.173, 86.218, 86.419, 86.563, 86.636,
    ],
    [
        0.41781, 3.5139, 6.2357, 8.4544, 10.247, 11.872, 13.251, 14.528, 15.52, 16.461,
        17.002, 17.71, 18.148, 18.263, 18.545, 18.596, 18.646, 18.671, 18.644, 18.501,
        18.294, 18.022, 17.866, 17.607, 17.257, 16.831, 16.443, 16.042, 15.615, 15.021,
        14.581, 13.922, 13.405, 12.824, 12.281, 11.803, 11.415, 10.615, 9.956, 9.0649,
        8.303, 7.3088, 6.3535, 4.882, 3.4234, 1.9779, -0.57703, -1.8931, -3.7899, -5.2352,
        -6.7323, -8.1395, -8.9144, -9.2252, -9.0971, -8.4786, -7.5504, -6.8668, -5.8347, -4.7379,
        -2.8927, -1.6538, -0.19565, 1.0046, 2.7337, 4.037, 5.766, 7.5594, 9.4561, 11.03,
        12.63, 14.242, 16.126, 17.532, 19.274, 20.744, 22.989, 24.679, 26.575, 28.291,
        30.162, 31.968, 33.683, 35.334, 37.128, 39.398,
    ],
])
"""Simo & Vu-Quoc (1986), dead load, digitised: the horizontal displacement u of the load point (first row)
and P L²/EI (second row), in the order of the path."""
VERTICAL = np.array([
    [
        0.26426, 1.4663, 2.5508, 4.0306, 5.3074, 7.5944, 9.5737, 11.325, 14.537, 17.606,
        21.085, 24.057, 27.626, 30.976, 34.384, 37.633, 40.873, 44.355, 47.624, 50.842,
        53.814, 56.547, 59.24, 60.973, 61.263, 60.967, 60.14, 59.054, 58.106, 56.847,
        54.621, 52.956, 51.088, 50.853, 50.66, 50.815, 51.21, 52.067, 53.474, 54.359,
        55.463, 57.573, 59.879, 62.725, 66.678, 70.667, 75.113, 77.886, 81.314, 82.85,
        84.495, 86.75, 87.868, 89.767, 90.946, 91.817, 92.198, 92.721, 93.058, 93.326,
        93.747, 93.997, 94.166, 94.523, 94.74,
    ],
    [
        0.35036, 1.8392, 3.2977, 4.9238, 6.3286, 8.2901, 9.4877, 10.487, 11.813, 13.032,
        14.075, 14.798, 15.589, 16.311, 17.026, 17.717, 18.287, 18.665, 18.761, 18.734,
        18.219, 17.291, 15.584, 13.243, 11.737, 10.37, 8.5517, 6.9786, 5.7417, 4.505,
        1.8557, 0.061623, -1.8774, -2.9547, -4.0932, -5.6524, -6.5011, -7.3275, -8.4983, -8.9578,
        -9.2648, -9.4659, -9.3309, -8.8297, -8.0929, -7.1421, -5.611, -4.7047, -2.6299, -1.3401,
        0.0031028, 2.1557, 3.6447, 6.2715, 9.0748, 12.2, 14.79, 17.273, 19.611, 22.752,
        27.176, 31.104, 35.544, 39.327, 40.167,
    ],
])
"""The same figure's other curve: the downward displacement v of the load point and P L²/EI."""


def scales(domain) -> tuple[float, float]:
    """``(L, factor)``: the leg length and the factor from the load factor λ to P L²/EI (the section's EI2,
    the deck's load at ``t_end``)."""
    knee = domain.node("knee").position
    L = float(np.linalg.norm(knee - domain.node("column:0").position))
    EI = domain.elements[0].formulation.section.EI2
    P = sum(np.linalg.norm(load.vector) * load.time_function(domain.solver.t_end) for load in domain.loading)
    return L, float(P) * L**2 / EI


def path(results, L: float, factor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(P L²/EI, u, v)`` at every converged point: u the horizontal, v the downward displacement of the load point."""
    x = results.position(LOAD_NODE)
    return results.data("path/load_factor") * factor, x[:, 0] - x[0, 0], x[0, 2] - x[:, 2]


def distances(points: np.ndarray, displacement: np.ndarray, load: np.ndarray, L: float, P1: float) -> np.ndarray:
    """Distance of each digitised point (2, n) to the polyline ``(displacement, load)`` in the scales (1/L, 1/P1)."""
    p = np.c_[points[0] / L, points[1] / P1]
    a = np.c_[displacement[:-1] / L, load[:-1] / P1]
    ab = np.c_[displacement[1:] / L, load[1:] / P1] - a
    t = np.clip(((p[:, None, :] - a[None]) * ab[None]).sum(-1) / (ab * ab).sum(-1)[None], 0.0, 1.0)
    return np.linalg.norm(a[None] + t[..., None] * ab[None] - p[:, None, :], axis=-1).min(axis=1)


def first_peak(points: np.ndarray) -> float:
    """The largest load of a digitised curve before its load first turns negative: its first limit load."""
    return float(points[1, :int(np.argmax(points[1] < 0.0))].max())


def displacement_control(ctx, domain, stop: float):
    """The deck by displacement control of the load point's height (``control = "position.z:load"``), steps of
    0.005 × the model size, to ``z < stop``.  v grows through the first limit point and turns back after it (a
    snap-back in v); u, which grows through both, starts almost flat (du/dλ = 0.06 at λ = 0, the deck's unit
    load): a fixed first step of u (0.85) asks for a load step of about 14 and lands on the branch of negative
    loads (measured: λ = −4.4 after ten points)."""
    node = domain.node(LOAD_NODE).id
    domain.solver.control = (node, 2, f"position.z:{LOAD_NODE}")
    domain.solver.arc_length = 0.005
    domain.solver.max_points = 400
    # the reference path, as the deck's own run: the run stops at ``stop`` long before max_points, which auto's
    # estimate counts (400 points: over its 15 s, so auto would compile the arc length for beam3, minutes cold)
    domain.solver.backend = "reference"
    domain.solver.stop_when = (node, 2, "<", stop, f"position.z:{LOAD_NODE} < {stop:g}")
    return ctx.solve(domain, "displacement control", results_file=True)


def pushed(ctx, domain, depth: float, steps: int = 60):
    """The frame without its load, the load point pushed down by ``depth`` in ``steps`` equal static steps
    (a ``[[prescribed_displacements]]`` boundary condition along −z): its reaction, the force that holds the
    point there, is the load of the equilibrium path — a third method, on the static algorithm."""
    from reference.algorithms import SolverSettings
    from reference.interactions import Ramp

    domain.loading.clear()
    domain.add_joint("prescribed_displacement", LOAD_NODE, None, domain.node(LOAD_NODE).position,
                     axis=(0.0, 0.0, -1.0), time_function=Ramp(0.0, 1.0, 0.0, depth), label="push")
    domain.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=steps, dt=1.0 / steps,
                                   backend=domain.solver.backend)
    return ctx.solve(domain, "prescribed displacement", results_file=True)


def exudyn_refine(domain) -> int:
    """Exudyn's elements per deck element: 1 for a Beam2 mesh (the same elements), else the converged-mesh
    refinement of the cross-check (:data:`crosscheck.harness.CONVERGED_REFINE`: Exudyn has no beam3, and its
    linear beam on 5 elements per leg is 1.5e-2 of the size off the path, measured against Beam2 on that mesh)."""
    from crosscheck.exudyn_model import EXUDYN_ELEMENTS
    from crosscheck.harness import CONVERGED_REFINE

    return 1 if all(e.formulation.family in EXUDYN_ELEMENTS for e in domain.elements) else CONVERGED_REFINE


def exudyn_lines(ctx, checks: list) -> list[str]:
    """Exudyn's static solver on the path up to 0.9 of the first limit load (:mod:`crosscheck.path_crosscheck`),
    judged against the arc-length points at the same loads."""
    from importlib.util import find_spec

    if find_spec("exudyn") is None:
        return ["Exudyn cross-check skipped: exudyn is not installed.", ""]
    from crosscheck.path_crosscheck import STEPS, TOLERANCE, run

    refine = exudyn_refine(ctx.domain())
    c = run(ctx.deck, ctx.out / "lee_frame_crosscheck", refine=refine)
    ctx.timings.append(("lee_frame (cross-check run)", "Exudyn", STEPS, c["exudyn_wall"]))
    mesh = "same mesh" if refine == 1 else f"its linear beam on {refine} × the deck's elements"
    checks.append(ctx.check("exudyn_prelimit", "largest position difference / model size",
                            f"Exudyn static solver, {mesh}", c["difference"]))
    return ["**Exudyn cross-check** (`flexmbs crosscheck models/lee_frame.toml`; Exudyn has load stepping only, so "
            f"up to {c['load_factor'] / c['critical']:.1f} of the first limit load): " + " ".join(c["lines"])
            + f" (the module's own bound {TOLERANCE:g}).", ""]


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.interpolate import CubicSpline

    domain = ctx.domain()
    L, factor = scales(domain)
    r = ctx.solve(domain, results_file=True)
    P, u, v = path(r, L, factor)
    critical = r.data("path/critical_load_factor") * factor
    kinds = list(r.data("path/critical_kind"))
    published = ctx.checks["first_limit_schweizerhof_wriggers"]["value"]
    converged = ctx.checks["second_limit_converged"]["value"]
    peak = 0.5 * (first_peak(HORIZONTAL) + first_peak(VERTICAL))
    du = distances(HORIZONTAL, u, P, L, published)
    dv = distances(VERTICAL, v, P, L, published)
    both = np.r_[du, dv]
    limits = [k for k, kind in enumerate(kinds) if kind == "limit point"]
    P1, P2 = (critical[limits[0]], critical[limits[1]]) if len(limits) >= 2 else (np.nan, np.nan)
    checks = [ctx.check("first_limit_schweizerhof_wriggers", "first limit load, relative error",
                        "18.5 EI/L² (Schweizerhof & Wriggers 1986)", abs(P1 / published - 1.0)),
              ctx.check("first_limit_simo_vu_quoc", "first limit load, relative error",
                        f"digitised peak {peak:.3f} (Simo & Vu-Quoc 1986)", abs(P1 / peak - 1.0)),
              ctx.check("second_limit_converged", "second limit load, relative error",
                        f"{converged} (beam3, 20 elements per leg)", abs(P2 / converged - 1.0)),
              ctx.check("path_rms", "RMS distance of the digitised points", "Simo & Vu-Quoc (1986), digitised",
                        float(np.sqrt(np.mean(both**2)))),
              ctx.check("path_max", "largest distance of a digitised point", "Simo & Vu-Quoc (1986), digitised",
                        float(both.max()))]
    n = len(domain.elements)
    family = domain.elements[0].formulation.family
    lines = [f"Arc length (Riks, docs/formulation.md §12), {n} {family} elements: {len(P) - 1} converged points to "
             f"P L²/EI = {P[-1]:.1f} (the end of the published path), solve {r.wall_time:.2f} s; "
             f"{int(r.data('path/iterations').sum())} Newton iterations.", "",
             "| limit load P L²/EI | flexmbs | reference | relative |", "|---|---|---|---|",
             f"| first (a maximum) | {P1:.4f} | 18.5, Schweizerhof & Wriggers (1986) | {P1 / published - 1:+.2e} |",
             f"| | | {peak:.3f}, Simo & Vu-Quoc (1986), digitised peak | {P1 / peak - 1:+.2e} |",
             f"| second (a minimum) | {P2:.4f} | {converged}, beam3 with 20 elements per leg | "
             f"{P2 / converged - 1:+.2e} |", "",
             f"Digitised path (Simo & Vu-Quoc 1986, {HORIZONTAL.shape[1]} + {VERTICAL.shape[1]} points): distance to "
             f"the computed path in the plot's scales (u/L, v/L and P/18.5 EI/L²): RMS {np.sqrt(np.mean(both**2)):.2e}, "
             f"largest {both.max():.2e} (u curve {du.max():.2e}, v curve {dv.max():.2e}).", ""]
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.8), sharey=True)
    marks = [int(np.argmin(np.abs(P[:-1] - c) + np.abs(P[1:] - c))) for c in critical[limits]]
    for ax, disp, ref, name in ((axes[0], u, HORIZONTAL, "horizontal u"), (axes[1], v, VERTICAL, "vertical v (down)")):
        ax.plot(disp, P, "-", lw=1.2, color="C0", label="flexmbs, arc length")
        ax.plot(ref[0], ref[1], "o", ms=3, mfc="none", color="k", label="Simo & Vu-Quoc (1986), digitised")
        ax.plot(disp[marks], critical[limits], "s", ms=6, color="C3", label="limit points (interpolated)")
        ax.set_xlabel(f"{name} of the load point")
        ax.axhline(0.0, color="gray", lw=0.5)
    if not ctx.quick:
        turn = int(np.argmax(np.diff(v) < 0.0))  # v's first turning point (its snap-back)
        dc = displacement_control(ctx, ctx.domain(), float(r.position(LOAD_NODE)[0, 2] - 0.95 * v[turn]))
        Pd, ud, vd = path(dc, L, factor)
        cd = dc.data("path/critical_load_factor") * factor
        same = float(abs(cd[0] - P1) / P1) if len(cd) else np.inf
        # the arc-length points against a cubic spline through the denser displacement-control points, v from
        # 0.05 L to the end of that run
        along = CubicSpline(vd, Pd)
        inside = (v >= 0.05 * L) & (v <= vd[-1]) & (np.arange(len(v)) <= turn)
        gap = float(np.max(np.abs(P[inside] - along(v[inside]))) / P1)
        checks.append(ctx.check("displacement_control", "first limit load: difference / P1",
                                "arc length, the same discrete frame", same))
        checks.append(ctx.check("displacement_control_path", "arc-length points off the displacement-control path / P1",
                                "cubic spline through the displacement-control points", gap))
        bc = pushed(ctx, ctx.domain(), float(vd[-1]))
        xb = bc.position(LOAD_NODE)
        Pb = bc.data("joints/prescribed_reaction")[:, 0] * L**2 / domain.elements[0].formulation.section.EI2
        vb = xb[0, 2] - xb[:, 2]
        off = float(np.max(np.abs(Pb[vb >= 0.05 * L] - along(vb[vb >= 0.05 * L]))) / P1)
        checks.append(ctx.check("prescribed_displacement_path",
                                "reactions of the pushed load point off the displacement-control path / P1",
                                "cubic spline through the displacement-control points", off))
        axes[1].plot(vb[::3], Pb[::3], "+", ms=5, color="C2", label="[[prescribed_displacements]], static")
        axes[0].plot(ud[::4], Pd[::4], "x", ms=4, color="C1", label="displacement control of v (every fourth point)")
        axes[1].plot(vd[::4], Pd[::4], "x", ms=4, color="C1")
        lines += [f"**Displacement control** of v (`control = \"position.z:load\"`, {len(Pd) - 1} points to v = "
                  f"{vd[-1]:.1f}, solve {dc.wall_time:.2f} s): its first limit load {cd[0] if len(cd) else np.nan:.6f} "
                  f"differs from the arc length's by {same:.1e} P1; the {int(inside.sum())} arc-length points from "
                  f"v = 0.05 L to {vd[-1]:.1f} lie within {gap:.1e} P1 of a cubic spline through the "
                  "displacement-control points. v turns back after the first limit point (a snap-back in v), so "
                  "displacement control of v ends there; u, which grows through both limit points, starts almost "
                  "flat, and a fixed first step of it jumps to the branch of negative loads: the second limit point "
                  "is the arc length's alone here.", "",
                  f"**Prescribed displacement**: the frame without its load, its load point pushed down to v = "
                  f"{vb[-1]:.1f} in {len(vb) - 1} static steps (`[[prescribed_displacements]]`, a boundary "
                  f"condition; solve {bc.wall_time:.2f} s): the reactions lie within {off:.1e} P1 of the same "
                  "spline.", ""]
        lines += exudyn_lines(ctx, checks)
    axes[0].set_ylabel("P L²/EI")
    axes[0].legend(fontsize=7)
    fig.suptitle("Lee's frame: load against the load point's displacements; limit points marked", fontsize=10)
    lines += [ctx.figure(fig, "lee_frame_path.png", "Lee's frame equilibrium path"), ""]
    return lines, checks
