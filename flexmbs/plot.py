"""``flexmbs plot RESULTS.h5``: time histories, any observable, constraint drift, energies and an animation.

Works on any results file honouring the contract (either engine).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np


def main(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reference.io.results import load_results

    r = load_results(args.results)
    out = Path(args.out or Path(args.results).with_suffix(""))
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for label in args.node or []:
        try:
            r.index(label)  # a label or BEAM:start / BEAM:end
        except KeyError:
            raise KeyError(f"{args.results}: no node {label!r}; nodes are e.g. {', '.join(r.labels[:6])}") from None
        fig, axes = plt.subplots(2, 1, figsize=(6.4, 5.0), sharex=True)
        for k, comp in enumerate("xyz"):
            axes[0].plot(r.time, r.position(label)[:, k], label=comp)
            axes[1].plot(r.time, r.velocity(label)[:, k], label=f"v{comp}")
        axes[0].set_ylabel("position")
        axes[1].set_ylabel("velocity")
        axes[1].set_xlabel("t")
        axes[0].legend(fontsize=8)
        axes[0].set_title(f"{label} ({r.attrs.get('engine', '')})", fontsize=10)
        written.append(save_figure(fig, out / f"node_{label.replace(':', '_')}.png"))
    if args.drift:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        ax.semilogy(r.time[1:], np.maximum(r.constraint_violation[1:], 1e-17), label="‖Φ‖")
        ax.semilogy(r.time[1:], np.maximum(r.velocity_constraint_violation[1:], 1e-17), label="‖B V + Φ_t‖")
        ax.set_xlabel("t")
        ax.legend(fontsize=8)
        written.append(save_figure(fig, out / "drift.png"))
    if args.energy:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        for key, values in r.energy.items():
            if np.all(np.isfinite(values)):
                ax.plot(r.time, values, label=key)
        ax.set_xlabel("t")
        ax.legend(fontsize=8)
        written.append(save_figure(fig, out / "energy.png"))
    for text in getattr(args, "observable", None) or []:
        written.append(plot_observable(r, text, out, plt))
    if args.animate:
        written.append(animate(r, out / args.animate, every=args.every))
    for path in written:
        print(f"wrote {path}")
    return 0


def plot_observable(r, text: str, out: Path, plt) -> Path:
    """Figure of one observable (``reference/observables.py``) over time: a scalar, the components of a
    vector, or every node's displacement for ``position:*``."""
    from reference.observables import parse

    obs = parse(text, r)
    values = obs.evaluate(r)
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    if values.ndim == 1:
        ax.plot(r.time, values)
    elif values.ndim == 2:
        names = {4: ["q0", "q1", "q2", "q3"]}.get(values.shape[1], ["1", "2", "3"] if "section" in obs.kind
                                                  else ["x", "y", "z"])
        for k in range(values.shape[1]):
            ax.plot(r.time, values[:, k], label=names[k])
        ax.legend(fontsize=8)
    else:
        ax.plot(r.time, np.linalg.norm(values - values[:1], axis=2), lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{obs.text} [{obs.unit}]", fontsize=8)
    ax.set_title(textwrap.fill(f"{obs.describe()} ({r.attrs.get('engine', '')})", 80), fontsize=8)
    safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in text)
    return save_figure(fig, out / f"observable_{safe}.png")


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Lay out, save and close a figure; return its path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def animate(r, path: Path, every: int = 1) -> Path:
    """A GIF of the motion projected on the plane of largest extent (nodes joined per beam)."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    P = r.positions
    spread = P.reshape(-1, 3).max(axis=0) - P.reshape(-1, 3).min(axis=0)
    a, b = np.argsort(spread)[::-1][:2]
    groups = {}
    for k, label in enumerate(r.labels):
        groups.setdefault(label.rsplit(":", 1)[0], []).append(k)
    fig, ax = plt.subplots(figsize=(5.0, 5.0))
    ax.set_aspect("equal")
    pad = 0.05 * spread.max()
    ax.set_xlim(P[:, :, a].min() - pad, P[:, :, a].max() + pad)
    ax.set_ylim(P[:, :, b].min() - pad, P[:, :, b].max() + pad)
    lines = [ax.plot([], [], "o-", ms=3)[0] for _ in groups]
    title = ax.set_title("")
    frames = list(range(0, len(r.time), max(int(every), 1)))

    def draw(i):
        for line, idx in zip(lines, groups.values()):
            line.set_data(P[i, idx, a], P[i, idx, b])
        title.set_text(f"t = {r.time[i]:.3f}")
        return lines

    FuncAnimation(fig, draw, frames=frames).save(path, writer=PillowWriter(fps=20))
    plt.close(fig)
    return path
