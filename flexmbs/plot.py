"""``flexmbs plot RESULTS.h5``: time histories, any observable, constraint drift, energies, an animation; model drawings.

Works on any results file honouring the contract (either engine).  The
drawing of a configuration (:func:`configuration`) is the one used everywhere:
beams as polylines through their nodes, a rigid body as segments through its
named points and the joint points it carries (a rigid bar is its segment),
the flexible beams' deflection from their chord optionally magnified — the
report's model sketches, its Fig. 14 and ``plot --animate`` all draw with it; the animation adds the
springs, dampers, joints and the ground (:func:`animation_figure`), fitted to the whole motion.
"""

from __future__ import annotations

import tempfile
import textwrap
from pathlib import Path

import numpy as np

WHAT = ("--node LABEL (position and velocity histories), --observable EXPR (any observable, docs/observables.md), "
        "--sensitivity EXPR (a static or generalized-α run's sensitivities of an output), "
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


def _figures_asked(args) -> bool:
    """Whether ``args`` ask for a figure (a mode's animated file alone is not one)."""
    return bool(args.node or getattr(args, "observable", None) or getattr(args, "path", None) or args.drift
                or args.energy or args.animate or getattr(args, "sensitivity", None))


def plot_sensitivity(source, text: str, out: Path, plt) -> Path:
    """Figure of the sensitivities of the output ``text`` to every parameter of a static or generalized-α run
    (``/sensitivities/<output>/<parameter>``, docs/results.md) against the load factor or time, one line per
    parameter and component; an output the file has no sensitivities of is refused in one line."""
    import h5py

    with h5py.File(source, "r") as f:
        group = f.get(f"sensitivities/{text.replace('/', '|')}")
        if not isinstance(group, h5py.Group):
            there = [k for k in f.get("sensitivities", {}) if isinstance(f["sensitivities"][k], h5py.Group)]
            raise OSError(f"{source}: no sensitivities of {text!r}; the file has them of "
                          f"{', '.join(map(repr, there)) or 'nothing (the deck has no [sensitivities] table)'}")
        axis = "time" if "sensitivities/time" in f else "load_factor"
        load = np.asarray(f[f"sensitivities/{axis}"])
        curves = {name.replace("|", "/"): np.asarray(group[name]) for name in group}
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for name, values in curves.items():
        values = values.reshape(len(load), -1)
        for k in range(values.shape[1]):
            ax.plot(load, values[:, k], label=name + (f" [{'xyzw'[k]}]" if values.shape[1] > 1 else ""))
    ax.set_xlabel("time t [s]" if axis == "time" else "load factor")
    ax.set_ylabel(f"d({text})/dp")
    ax.legend(fontsize=7)
    ax.set_title(f"sensitivities of {text}", fontsize=10)
    safe = "".join(c if c.isalnum() else "_" for c in text)
    return save_figure(fig, out / f"sensitivity_{safe}.png")


def main(args) -> int:
    mode = getattr(args, "mode", None)
    if not (_figures_asked(args) or mode):
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
    if not _figures_asked(args):
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
    for text in getattr(args, "sensitivity", None) or []:
        written.append(plot_sensitivity(args.results, text, out, plt))
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


def connectors(domain) -> list[tuple[str, str, list]]:
    """What the animation draws besides the bodies: ``(kind, label, ends)`` for every force element and joint.

    ``kind`` is ``"spring"`` (a point-to-point element with a stiffness), ``"damper"`` (one without),
    ``"torsion spring"``, ``"bushing"`` or ``"joint"``; ``ends`` are ``(node label, body-frame offset [m])``
    pairs, the label ``None`` for the ground, whose offset is then the inertial point.  A rotational
    element is drawn at its body i's node, a joint at its point on body i.
    """
    from reference.forces import Bushing, PointToPoint, Rotational

    def end(node, point):
        if node is None:
            return None, np.asarray(point, dtype=float)
        return node.label, _rotation_matrix(node.rotation).T @ (np.asarray(point, dtype=float) - node.position)

    out = []
    for element in domain.force_elements:
        if isinstance(element, PointToPoint):
            kind = "spring" if element.stiffness > 0.0 else "damper"
            out.append((kind, element.label, [end(element.body_i, element.point_i),
                                              end(element.body_j, element.point_j)]))
        elif isinstance(element, Rotational):
            out.append(("torsion spring", element.label, [end(element.body_i, element.body_i.position)]))
        elif isinstance(element, Bushing):
            out.append(("bushing", element.label, [end(element.body_i, element.point), end(element.body_j, element.point)]))
    for joint in domain.joints:
        out.append(("joint", joint.label, [end(joint.body_i, joint.point)]))
    return out


def grounds(domain) -> list[np.ndarray]:
    """Inertial points where the model is held by the ground: joints and force elements with a ground end,
    and fixed (clamped) nodes."""
    from reference.interactions import FixedCoordinates

    points = [np.asarray(c.point, dtype=float) for c in domain.joints if c.body_i is None or c.body_j is None]
    for element in domain.force_elements:
        if element.body_j is None:
            points.append(np.asarray(getattr(element, "point_j", getattr(element, "point", element.body_i.position)),
                                     dtype=float))
    points += [np.asarray(bc.node.position, dtype=float) for bc in domain.boundary_conditions
               if isinstance(bc, FixedCoordinates)]
    unique = []
    for p in points:
        if not any(np.allclose(p, q) for q in unique):
            unique.append(p)
    return unique


def _placed(r, i: int, ends) -> np.ndarray:
    """The inertial points of connector ends at output ``i`` (body-fixed offsets turned with their body)."""
    pts = []
    for label, offset in ends:
        if label is None:
            pts.append(offset)
        else:
            k = r.index(label)
            pts.append(r.positions[i, k] + _rotation_matrix(r.rotations[i, k]) @ offset)
    return np.array(pts)


def _zigzag(P: np.ndarray, Q: np.ndarray, width: float, teeth: int = 6) -> np.ndarray:
    """A spring's zigzag from P to Q in the drawing plane (2D points), ``width`` its amplitude."""
    d = Q - P
    length = float(np.hypot(*d))
    if length <= 0.0:
        return np.array([P, Q])
    n = np.array([-d[1], d[0]]) / length
    s = np.concatenate([[0.0, 0.15], 0.15 + 0.7 * (np.arange(2 * teeth) + 0.5) / (2 * teeth), [0.85, 1.0]])
    side = np.concatenate([[0.0, 0.0], np.where(np.arange(2 * teeth) % 2 == 0, 1.0, -1.0), [0.0, 0.0]])
    return P + s[:, None] * d + (min(width, 0.25 * length) * side)[:, None] * n


STYLE = {"spring": dict(color="tab:green", lw=1.2), "damper": dict(color="tab:purple", lw=2.0, ls="--"),
         "torsion spring": dict(color="tab:green", ls="none", marker=r"$\circlearrowleft$", ms=14),
         "bushing": dict(color="tab:brown", lw=2.0, marker="s", ms=6, mfc="none"),
         "joint": dict(color="k", ls="none", marker="o", ms=7, mfc="white", mew=1.5, zorder=5)}
"""How the animation draws each kind of connector (matplotlib line properties)."""


def animation_figure(r, domain=None, every: int = 1, magnify: float = 1.0):
    """The animation's figure: ``(fig, artists, draw, frames)``.

    Bodies are drawn by :func:`configuration`; springs as zigzags, dampers dashed, torsion springs and
    joints as markers, bushings as squares (:func:`connectors`), the ground as hatched bases under the
    points it holds (:func:`grounds`).  ``artists`` maps each kind (``"body"``, ``"spring"``, …,
    ``"ground"``) to its matplotlib artists; ``draw(k)`` shows frame ``k`` of ``frames`` (output indices).
    The axes are fitted to the whole motion: their limits are the bounding box of everything drawn over
    all frames plus 5 %, at equal scale, in a figure of the box's proportions.
    """
    import matplotlib.pyplot as plt

    domain = domain_of(r) if domain is None else domain
    shapes, beams = (geometry(domain), chains(domain)) if domain is not None else ({}, None)
    links = connectors(domain) if domain is not None else []
    fixed = grounds(domain) if domain is not None else []
    a, b = plane(r)
    frames = list(range(0, len(r.time), max(int(every), 1)))
    drawn = [configuration(r, i, shapes, magnify, beams) for i in frames]
    placed = [[_placed(r, i, ends) for _, _, ends in links] for i in frames]
    allp = np.concatenate([p for lines in drawn for _, p in lines] + [p for ps in placed for p in ps]
                          + [np.array(fixed).reshape(-1, 3)])
    lo, hi = allp[:, [a, b]].min(axis=0), allp[:, [a, b]].max(axis=0)
    span = max(float((hi - lo).max()), 1e-9)
    base = 0.06 * span  # the ground symbol's half-width, drawn below the held point
    for p in fixed:  # the symbol's corners
        lo = np.minimum(lo, [p[a] - 1.3 * base, p[b] - base])
        hi = np.maximum(hi, [p[a] + base, p[b]])
    pad = 0.05 * np.maximum(hi - lo, 0.1 * span)  # a motion along one line still gets some height
    lo, hi = lo - pad, hi + pad
    ratio = float((hi - lo)[0] / (hi - lo)[1])
    shown = float(np.clip(ratio, 0.4, 2.5))  # the figure's proportions: those of the box, within reason
    if shown != ratio:  # a box too flat for a figure: its short side widened, centred
        centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        half = np.array([half[0], half[0] / shown]) if ratio > shown else np.array([half[1] * shown, half[1]])
        lo, hi = centre - half, centre + half
    legend = 1.6 if len(drawn[0]) <= 8 else 0.0  # room for the legend, right of the axes
    fig, ax = plt.subplots(figsize=(6.0 * min(shown, 1.0) + 1.0 + legend, 6.0 / max(shown, 1.0) + 0.8))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")  # equal scale: the axes box takes the limits' proportions
    ax.set_xlabel(f"{'xyz'[a]} [m]")
    ax.set_ylabel(f"{'xyz'[b]} [m]")
    artists = {"body": [ax.plot([], [], "o-", ms=3, lw=2 if len(p) <= 3 else 1.2, label=label)[0]
                        for label, p in drawn[0]]}
    for kind, label, _ in links:
        artists.setdefault(kind, []).append(ax.plot([], [], **STYLE[kind])[0])
    for p in fixed:
        x, y = p[a], p[b]
        hatch = [[x - base + 0.4 * base * t, y - 0.6 * base, x - base + 0.4 * base * t - 0.3 * base, y - base]
                 for t in range(6)]
        artists.setdefault("ground", []).extend(
            ax.plot([x, x - 0.5 * base, x + 0.5 * base, x], [y, y - 0.6 * base, y - 0.6 * base, y], color="k", lw=1)
            + ax.plot([x - base, x + base], [y - 0.6 * base, y - 0.6 * base], color="k", lw=1.5)
            + [ax.plot([h[0], h[2]], [h[1], h[3]], color="k", lw=0.8)[0] for h in hatch])
    bodies = artists["body"]
    if len(bodies) <= 8:
        ax.legend(bodies, [label for label, _ in drawn[0]], fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    title = ax.set_title("t = 0.000 s")
    fig.tight_layout()
    note = f"; beam deflection ×{magnify:g}" if magnify != 1.0 else ""
    counters = {}

    def draw(k):
        for artist, (_, P) in zip(bodies, drawn[k]):
            artist.set_data(P[:, a], P[:, b])
        counters.clear()
        for (kind, _, _), P in zip(links, placed[k]):
            artist = artists[kind][counters.setdefault(kind, 0)]
            counters[kind] += 1
            xy = P[:, [a, b]]
            if kind == "spring":
                xy = _zigzag(xy[0], xy[1], 0.02 * span)
            artist.set_data(xy[:, 0], xy[:, 1])
        title.set_text(f"t = {r.time[frames[k]]:.3f} s{note}")
        return [x for group in artists.values() for x in group]

    return fig, artists, draw, frames


def animate(r, path: Path, every: int = 1, magnify: float = 1.0, progress=None, domain=None) -> Path:
    """A GIF of the motion in its plane of largest extent (:func:`animation_figure`)."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    fig, _, draw, frames = animation_figure(r, domain, every, magnify)

    def frame(k):
        drawn = draw(k)
        if progress is not None:
            progress((k + 1) / len(frames), r.time[frames[k]])
        return drawn

    FuncAnimation(fig, frame, frames=len(frames)).save(path, writer=PillowWriter(fps=20))
    plt.close(fig)
    return path
