"""The 45° bend of Bathe & Bolourchi (1979): curved and joined beams.

Checks: the tip position at P = 300, 450 and 600 against the published values of
Simo & Vu-Quoc (1986) (Bathe & Bolourchi 1979 listed beside
them), each within the deck's tolerance of the radius.  The Exudyn cross-check
of the same deck is added by the report.
"""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import at

LOADS = ("tip_300", "tip_450", "tip_600")


def _along(label: str) -> int:
    """Order of a node along the bend: arc1:0 … arc1:7, mid, arc2:1 … arc2:8."""
    if label == "mid":
        return 8
    beam, i = label.split(":")
    return int(i) + (8 if beam == "arc2" else 0)


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    domain = ctx.domain()
    r = ctx.solve(domain, results_file=True)
    tip = "arc2:8"
    radius = float(np.linalg.norm(domain.nodes[-1].position - [0.0, 100.0, 0.0]))
    order = np.argsort([_along(lbl) for lbl in r.labels])

    fig, axes = plt.subplots(1, 2, figsize=(8.4, 3.8))
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz"))):
        ax.plot(r.positions[0][order, i], r.positions[0][order, j], "-", color="gray", label="unloaded")
        for name in LOADS:
            spec = ctx.checks[name]
            k = int(np.argmin(np.abs(r.time - spec["at"])))
            ax.plot(r.positions[k][order, i], r.positions[k][order, j], "o-", ms=2.5, label=f"P = {name[4:]}")
            ax.plot(spec["value"][i], spec["value"][j], "kx", ms=7)
        ax.set_xlabel(f"{names[0]} [length]")
        ax.set_ylabel(f"{names[1]} [length]")
        ax.set_aspect("equal")
    axes[0].legend(fontsize=7)
    fig.suptitle("45° bend (R = 100, 16 elements in two joined arcs): equilibria; × Simo & Vu-Quoc (1986)",
                 fontsize=10)
    lines = [ctx.figure(fig, "curved_cantilever_equilibria.png", "45-degree bend"), "",
             "Tip position at the end of each load hold against the literature (distance / R):", "",
             "| P | tip x | tip y | tip z | Simo & Vu-Quoc 1986 | distance / R |", "|---|---|---|---|---|---|"]
    checks = []
    for name in LOADS:
        spec = ctx.checks[name]
        p = at(r, tip, spec["at"])
        err = float(np.linalg.norm(p - spec["value"]) / radius)
        lines.append(f"| {name[4:]} | {p[0]:.3f} | {p[1]:.3f} | {p[2]:.3f} | {tuple(spec['value'])} | {err:.2e} |")
        checks.append(ctx.check(name, f"tip distance / R at P = {name[4:]}", spec["reference"].replace("|", "/"), err))
    lines += ["", "The bend is two arcs joined at a node whose frame is kept off the tangent (the section-frame "
              "offsets make the joint exact); the deck's notes give the section data and why the published values "
              "spread.", ""]
    return lines, checks
