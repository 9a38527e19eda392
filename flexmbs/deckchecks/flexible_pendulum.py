"""Flexible pendulum falling from the horizontal (docs/benchmarks.md §3): energy conservation, drift."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import energy_error, energy_panel


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    domain = ctx.domain()
    r = ctx.solve(domain, results_file=True)
    checks = [ctx.check("energy", "|Δ(W_gravity − T − U)| / peak T", "0 (conservative)", energy_error(r)),
              ctx.check("drift", "max ‖Φ‖ [m]", "0", np.max(r.constraint_violation))]
    # deflection of the tip from the chord's direction of the first element: how much the beam bends
    p0, p1, pt = (r.position(domain.nodes[k].label) for k in (0, 1, -1))
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    chord = (p1 - p0) / np.linalg.norm(p1 - p0, axis=1)[:, None]
    rel = pt - p0
    bend = np.linalg.norm(rel - np.sum(rel * chord, axis=1)[:, None] * chord, axis=1) / L
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.6, 4.0))
    times = np.arange(0.0, min(r.time[-1], 1.0) + 1e-9, 0.1)
    norm = Normalize(times[0], times[-1])
    for t in times:
        i = int(np.argmin(np.abs(r.time - t)))
        ax.plot(r.positions[i, :, 0], r.positions[i, :, 2], "o-", ms=2, color=plt.get_cmap("viridis")(norm(t)))
    ax.plot(0, 0, "ko", mfc="white", ms=8)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    fig.colorbar(ScalarMappable(norm=norm, cmap="viridis"), ax=ax, label="time t [s]", shrink=0.8)
    ax.set_title("First swing, every 0.1 s", fontsize=9)
    energy_panel(bx, r)
    bx.set_xlabel("time t [s]")
    twin = bx.twinx()
    twin.plot(r.time, bend, "r:", label="tip offset from the root tangent / L")
    twin.set_ylabel("bending: tip offset / L [–]", color="r")
    twin.legend(fontsize=7, loc="center right")
    bx.set_title("Energies and bending", fontsize=9)
    lines = [ctx.figure(fig, "flexible_pendulum.png", "flexible pendulum"), "",
             f"Peak tip offset from the root tangent {bend.max():.3f} L; energy balance {energy_error(r):.1e} of the "
             f"peak kinetic energy over {r.time[-1]:g} s.", ""]
    return lines, checks
