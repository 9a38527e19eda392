"""``flexmbs plot RESULTS.h5``: time histories, any observable, constraint drift, energies, an animation; model drawings.

Works on any results file honouring the contract (either engine).  The
drawing of a configuration (:func:`configuration`) is the one used everywhere:
beams as polylines through their nodes, a rigid body as segments through its
named points and the joint points it carries (a rigid bar is its segment),
the flexible beams' deflection from their chord optionally magnified — the
report's model sketches, its Fig. 14 and ``plot --animate`` all draw with it.
"""

from __future__ import annotations

import tempfile
import textwrap
from pathlib import Path

import numpy as np

WHAT = ("--node LABEL (position and velocity histories), --observable EXPR (any observable, docs/observables.md), "
        "--path EXPR (an arc-length run's load factor, or --load EXPR, against an observable), "
        "--drift (constraint violation), --energy, --animate NAME.gif, --mode K (a mode as a ParaView animation)")


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Lay out, save and close a figure; return its path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _rotation_matrix(q) -> np.ndarray:
    from reference.rotation import EulerParameters

    return EulerParameters(q).matrix()


def geometry(domain) -> dict:
    """What to draw of each rigid body: body-frame offsets of its named points and joint points.

    Returns ``{label: (k, 3) offsets}`` (from the centre of mass, body frame at
    t = 0), in drawing order; a body with nothing attached gets no entry (drawn
    as a dot).
    """
    shapes = {}
    for node in domain.nodes:
        if node.mass <= 0.0:
            continue
        pts = [p for name, p in node.points.items() if name != "centre"]
        pts += [j.point for j in domain.joints if node in (j.body_i, j.body_j)]
        if not pts:
            continue
        A0 = _rotation_matrix(node.rotation)
        offs = []
        for p in pts:
            o = A0.T @ (np.asarray(p, dtype=float) - node.position)
            if not any(np.allclose(o, q, atol=1e-12) for q in offs):
                offs.append(o)
        if len(offs) == 1:
            offs.insert(0, np.zeros(3))
        shapes[node.label] = np.array(offs)
    return shapes


def chains(domain) -> dict:
    """``{beam: [node labels in order]}`` from the domain's elements (labels ``BEAM/i``).

    Unlike :func:`beam_groups` this follows the connectivity, so a node shared by
    two beams (``start_node``/``end_node``) is drawn in both.
    """
    label_of = {n.id: n.label for n in domain.nodes}
    out = {}
    for e in domain.elements:
        beam = e.label.rpartition("/")[0] or e.label
        ids = [label_of[i] for i in e.nodes]
        chain = out.setdefault(beam, [])
        chain.extend(ids if not chain else ids[1:] if chain[-1] == ids[0] else ids)
    return out


def beam_groups(labels) -> dict:
    """``{beam: [label of node 0, 1, …]}`` from the ``BEAM:i`` labels of a results file."""
    groups = {}
    for label in labels:
        head, _, tail = label.rpartition(":")
        if head and tail.isdigit():
            groups.setdefault(head, []).append((int(tail), label))
    return {b: [lbl for _, lbl in sorted(v)] for b, v in groups.items() if len(v) > 1}


def configuration(results, i: int, shapes: dict | None = None, magnify: float = 1.0,
                  beams: dict | None = None) -> list[tuple[str, np.ndarray]]:
    """Polylines ``(label, (k, 3) points)`` of every body at output ``i``.

    Flexible beams: the nodes, with their deviation from the chord of the end
    nodes multiplied by ``magnify`` (as the paper's Fig. 14 shows the coupler).
    Rigid bodies: their ``shapes`` offsets turned by the body's rotation;
    without a shape, the centre of mass alone.  ``beams`` (from :func:`chains`)
    gives the beams' node order; by default it is read from the ``BEAM:i`` labels.
    """
    shapes = shapes or {}
    lines, in_beam = [], set()
    if not beams or any(lbl not in results.labels for chain in beams.values() for lbl in chain):
        beams = beam_groups(results.labels)
    for beam, members in beams.items():
        idx = [results.index(lbl) for lbl in members]
        P = results.positions[i, idx]
        if magnify != 1.0:
            s = np.linspace(0.0, 1.0, len(idx))[:, None]
            chord = P[0] + s * (P[-1] - P[0])
            P = chord + magnify * (P - chord)
        lines.append((beam, P))
        in_beam.update(idx)
    for k, label in enumerate(results.labels):
        if k in in_beam:
            continue
        c = results.positions[i, k]
        if label in shapes:
            lines.append((label, c + shapes[label] @ _rotation_matrix(results.rotations[i, k]).T))
        else:
            lines.append((label, c[None, :]))
    return lines


def plane(results) -> tuple[int, int]:
    """The two inertial axes along which the motion spreads most (the drawing plane)."""
    P = results.positions.reshape(-1, 3)
    spread = P.max(axis=0) - P.min(axis=0)
    a, b = sorted(np.argsort(spread)[::-1][:2])
    return int(a), int(b)


def domain_of(results):
    """The deck's Domain, rebuilt from the deck text a results file carries (``None`` if it carries none)."""
    from reference.io.deck import load_deck

    text = results.attrs.get("deck")
    if not text:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / Path(str(results.attrs.get("deck_path") or "deck.toml")).name
        path.write_text(str(text), encoding="utf-8")
        return load_deck(path).domain


def _load(path):
    from reference.io.results import load_results

    if not Path(path).is_file():
        raise OSError(f"{path}: no such results file; give the results.h5 written by `flexmbs run` or `flexmbs crosscheck`")
    try:
        return load_results(path)
    except (OSError, KeyError, ValueError) as exc:
        raise OSError(f"{path}: not a flexmbs results file ({' '.join(str(exc).split())}); give the results.h5 "
                      "written by `flexmbs run` or `flexmbs crosscheck`") from None


def mode_animation(r, path, k: int, out: Path):
    """``--mode K``: mode K of the results file as ``out/NAME_modeK.vtkhdf`` (:mod:`reference.io.mode_animation`;
    no matplotlib); returns ``(file, the animation as Results)``."""
    from reference.io.mode_animation import ModeError, write_mode_vtk

    domain = domain_of(r)
    if domain is None:
        raise OSError(f"{path}: the file carries no deck, so the model's elements are unknown; write it with "
                      "`flexmbs run DECK` (or Deck.solve), which records the deck")
    try:
        file, history = write_mode_vtk(domain, path, k, out)
    except ModeError as exc:  # one line naming the file and the fix: a user error (exit 2)
        raise OSError(str(exc)) from None
    history.attrs.update({key: r.attrs[key] for key in ("deck", "deck_path", "engine") if key in r.attrs})
    value = history.attrs["mode_value"]
    what = (f"{value:.6g} Hz" if history.attrs["mode_dataset"] == "modes/shape" else f"load factor {value:.6g}")
    print(f"wrote {file} (mode {k}: {what}; amplitude {history.attrs['mode_amplitude']:.4g}, the largest displacement "
          "10 % of the model size; one period in ParaView's time steps)")
    return file, history


def main(args) -> int:
    mode = getattr(args, "mode", None)
    if not (args.node or getattr(args, "observable", None) or getattr(args, "path", None) or args.drift
            or args.energy or args.animate or mode):
        raise OSError(f"{args.results}: nothing to plot; choose one or more of {WHAT}")
    if getattr(args, "load", None) and not getattr(args, "path", None):
        raise OSError(f"{args.results}: --load is the load axis of --path; give --path OBSERVABLE too")
    r = _load(args.results)
    if len(r.time) == 0:
        raise OSError(f"{args.results}: the file has no records (status {r.status!r}): its run ended before the "
                      "first output was written; nothing to plot")
    out = Path(args.out or Path(args.results).with_suffix(""))
    out.mkdir(parents=True, exist_ok=True)
    animated = r
    if mode:
        _, animated = mode_animation(r, args.results, mode, out)  # with --animate: the GIF shows the mode
    if not (args.node or getattr(args, "observable", None) or getattr(args, "path", None) or args.drift
            or args.energy or args.animate):
        return 0
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    engine = r.attrs.get("engine", "")
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
        axes[0].set_ylabel("position [m]")
        axes[1].set_ylabel("velocity [m/s]")
        axes[1].set_xlabel("time t [s]")
        axes[0].legend(fontsize=8)
        axes[1].legend(fontsize=8)
        axes[0].set_title(f"node {label} ({engine}); inertial components", fontsize=10)
        written.append(save_figure(fig, out / f"node_{label.replace(':', '_')}.png"))
    if args.drift:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        if np.nanmax(r.constraint_violation) > 0.0:
            ax.semilogy(r.time[1:], r.constraint_violation[1:], label="‖Φ‖ [m]")
            ax.semilogy(r.time[1:], r.velocity_constraint_violation[1:], label="‖B V + Φ_t‖ [m/s]")
            ax.legend(fontsize=8)
        else:
            ax.text(0.5, 0.5, "no constraints in this model", ha="center", transform=ax.transAxes)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("constraint violation")
        ax.set_title(f"constraint drift ({engine})", fontsize=10)
        written.append(save_figure(fig, out / "drift.png"))
    if args.energy:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        for key, values in r.energy.items():
            if np.all(np.isfinite(values)):
                ax.plot(r.time, values, label=key)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("energy [J]")
        ax.legend(fontsize=8)
        ax.set_title(f"energies ({engine})", fontsize=10)
        written.append(save_figure(fig, out / "energy.png"))
    for text in getattr(args, "observable", None) or []:
        written.append(plot_observable(r, text, out, plt))
    for text in getattr(args, "path", None) or []:
        written.append(plot_path(r, args.results, text, out, plt, getattr(args, "load", None)))
    if args.animate:
        from flexmbs.progress import ProgressBar

        bar = ProgressBar(f"animation {args.animate}")
        try:
            written.append(animate(animated, out / args.animate, every=args.every, magnify=args.magnify, progress=bar))
        finally:
            bar.close()
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
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(f"{obs.text} [{obs.unit}]", fontsize=8)
    ax.set_title(textwrap.fill(f"{obs.describe()} ({r.attrs.get('engine', '')})", 80), fontsize=8)
    safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in text)
    return save_figure(fig, out / f"observable_{safe}.png")


def _scalar(r, source, text: str, option: str):
    """A scalar observable's history and the parsed observable; a vector one is refused, naming a component."""
    from reference.observables import ObservableError, parse

    try:
        obs = parse(text, r)
        values = obs.evaluate(r)
    except ObservableError as exc:
        raise OSError(f"{source}: {option}: {exc}") from None
    if values.ndim != 1:
        raise OSError(f"{source}: {option} {text!r}: the observable has {values.shape[1]} components; pick one, e.g. "
                      f"'{obs.kind}.z:{','.join(obs.args)}'")
    return values, obs


def plot_path(r, source, text: str, out: Path, plt, load: str | None = None) -> Path:
    """The equilibrium path of an arc-length run: the load factor (``/path/load_factor``) against a scalar
    observable or a component (``position.z:apex``), the unstable points (negative eigenvalues) drawn
    hollow, the limit and bifurcation points marked on the load factor they were interpolated to.
    ``load``: a scalar observable drawn in place of the load factor (``prescribed_reaction:push``, the
    reaction of a static run under displacement control; any run), its unstable points those of
    ``/stability/negative_eigenvalues`` when there is no ``/path``."""
    values, obs = _scalar(r, source, text, "--path")
    if load is None:
        lam = r.data("path/load_factor")
        if not np.all(np.isfinite(lam)):
            raise OSError(f"{source}: no /path/load_factor: --path plots the results of an arc_length run (or give "
                          "--load, e.g. the reaction of a prescribed displacement)")
        count, events, ylabel = r.data("path/negative_eigenvalues"), r.data("path/critical_load_factor"), "load factor λ"
    else:
        lam, load_obs = _scalar(r, source, load, "--load")
        count = r.data("path/negative_eigenvalues")
        if not np.all(np.isfinite(count)):
            count = r.data("stability/negative_eigenvalues")
        events, ylabel = [], f"{load_obs.text} [{load_obs.unit}]"
    unstable = count > 0
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(values, lam, "-", lw=0.8, color="C0")
    ax.plot(values[~unstable], lam[~unstable], "o", ms=3, color="C0", label="stable")
    ax.plot(values[unstable], lam[unstable], "o", ms=3, mfc="none", color="C3", label="unstable")
    for level, kind in zip(events, r.data("path/critical_kind") if len(events) else []):
        ax.axhline(level, lw=0.6, ls="--" if kind == "limit point" else ":", color="k")
        ax.annotate(f"{kind} {level:.5g}", (ax.get_xlim()[0], level), fontsize=7, va="bottom")
    ax.set_xlabel(f"{obs.text} [{obs.unit}]", fontsize=8)
    ax.set_ylabel(ylabel, fontsize=8 if load else None)
    ax.legend(fontsize=8)
    ax.set_title(textwrap.fill(f"equilibrium path ({r.attrs.get('engine', '')})", 80), fontsize=8)
    safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in text)
    return save_figure(fig, out / f"path_{safe}.png")


def animate(r, path: Path, every: int = 1, magnify: float = 1.0, progress=None) -> Path:
    """A GIF of the motion in its plane of largest extent: every body drawn by :func:`configuration`."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    domain = domain_of(r)
    shapes, beams = (geometry(domain), chains(domain)) if domain is not None else ({}, None)
    a, b = plane(r)
    frames = list(range(0, len(r.time), max(int(every), 1)))
    drawn = [configuration(r, i, shapes, magnify, beams) for i in frames]
    allp = np.concatenate([p for lines in drawn for _, p in lines])
    fig, ax = plt.subplots(figsize=(5.4, 5.4))
    ax.set_aspect("equal")
    spread = max(float(np.ptp(allp[:, a])), float(np.ptp(allp[:, b])), 1e-9)
    pad = 0.05 * spread
    ax.set_xlim(allp[:, a].min() - pad, allp[:, a].max() + pad)
    ax.set_ylim(allp[:, b].min() - pad, allp[:, b].max() + pad)
    ax.set_xlabel(f"{'xyz'[a]} [m]")
    ax.set_ylabel(f"{'xyz'[b]} [m]")
    artists = [ax.plot([], [], "o-", ms=3, lw=2 if len(p) <= 3 else 1.2, label=label)[0] for label, p in drawn[0]]
    if len(artists) <= 8:
        ax.legend(fontsize=7, loc="upper right")
    title = ax.set_title("")
    note = f"; beam deflection ×{magnify:g}" if magnify != 1.0 else ""

    def draw(k):
        for artist, (_, P) in zip(artists, drawn[k]):
            artist.set_data(P[:, a], P[:, b])
        title.set_text(f"t = {r.time[frames[k]]:.3f} s{note}")
        if progress is not None:
            progress((k + 1) / len(frames), r.time[frames[k]])
        return artists

    FuncAnimation(fig, draw, frames=len(frames)).save(path, writer=PillowWriter(fps=20))
    plt.close(fig)
    return path
