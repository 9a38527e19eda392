"""Reactions of one deck in two engines, side by side: a figure and a table of numbers.

:func:`reaction_comparison` takes two results (any engines), a few observables
(``reference/observables.py``; typically joint reactions), and draws each over time
for both engines with their difference, returning the Markdown lines of a
table: peak, largest and RMS difference, both relative to the peak.
``THREE_BAR`` names the three-bar's crank torque and the force of pin A (on
the coupler), the reactions the report shows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from reference.observables import parse

THREE_BAR = ("reaction_moment.z:crank drive", "reaction_force.norm:A")


def _on(t_to, t_from, values):
    return np.interp(t_to, t_from, values)


def reaction_comparison(a, b, observables=THREE_BAR, path=None, names=("reference", "Exudyn")) -> dict:
    """Compare scalar observables of results ``a`` and ``b``; write a figure to ``path`` (optional).

    Returns ``{"rows": [...], "markdown": [...], "figure": path}``; each row holds the
    observable, its description, the peak |a|, the max and RMS of |a − b| over ``a``'s times.
    """
    rows = []
    series = []
    for text in observables:
        obs = parse(text, a)
        va = obs.evaluate(a)
        if va.ndim != 1:
            raise ValueError(f"{text}: give a scalar (a component or .norm) to compare over time")
        vb = _on(a.time, b.time, parse(text, b).evaluate(b))
        diff = np.abs(va - vb)
        peak = float(np.max(np.abs(va)))
        rows.append({"observable": text, "description": obs.describe(), "unit": obs.unit, "peak": peak,
                     "max_difference": float(np.max(diff)), "rms_difference": float(np.sqrt(np.mean(diff**2)))})
        series.append((obs, va, vb))
    markdown = [f"| observable | peak ({names[0]}) | max difference | RMS difference | max / peak |",
                "|---|---|---|---|---|"]
    for r in rows:
        markdown.append(f"| {r['description']} | {r['peak']:.4g} {r['unit']} | {r['max_difference']:.3g} | "
                        f"{r['rms_difference']:.3g} | {r['max_difference'] / r['peak']:.2%} |")
    figure = None
    if path is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(len(series), 1, figsize=(6.4, 2.6 * len(series)), sharex=True, squeeze=False)
        for ax, (obs, va, vb) in zip(axes[:, 0], series):
            ax.plot(a.time, va, label=names[0])
            ax.plot(a.time, vb, "--", label=names[1])
            ax.plot(a.time, va - vb, ":", label="difference")
            ax.set_ylabel(f"{obs.text}\n[{obs.unit}]", fontsize=8)
            ax.set_title(obs.describe(), fontsize=8)
            ax.legend(fontsize=7)
        axes[-1, 0].set_xlabel("t [s]")
        fig.tight_layout()
        figure = Path(path)
        figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(figure, dpi=120)
        plt.close(fig)
        markdown += ["", f"![reactions](figures/{figure.name})"]
    return {"rows": rows, "markdown": markdown, "figure": figure}
