"""``flexmbs view RESULTS``: one self-contained HTML file that shows a results file in 3D, offline.

The page turns, pans and zooms the model, scrubs its time with a slider and plays it, picks a mode of a
modes or buckling file, and colours the beam elements by a section force or moment.  Its viewer is
``flexmbs/view.js`` (Canvas 2D on a software canvas, orthographic projection), written into the page with
the data: no library, no network request.  It was chosen over k3d and pyvista by measurement
(docs/benchmarks.md §8): pyvista's standalone export has no time axis, k3d's page carries its whole
library with every view, and a page of many views (the report, the gallery) would exceed the browsers'
limit on live WebGL contexts.

What is drawn comes from the results file and the deck it carries (its elements): the points and
polylines of ParaView's output (:class:`reference.io.vtk.Layout`: beam nodes, the inner points of
curved elements placed by the element's own interpolation, rigid bodies as segments from the centre to
their named points), each polyline segment drawn as a tube (or a line); every rigid body also gets its
body axes (red, green, blue: e₁, e₂, e₃, each 8 % of the model's size).  A point at body-frame offset
s from its node is at ``x + A(q) s``.

The scene (the JSON in the page) holds

- ``box`` (2, 3): the bounding box of every point of every frame [m]; ``points`` P, ``segments`` (2 S)
  point pairs, ``kinds`` (S,): the element's index (≥ 0, into ``elements``), −1 a rigid body, −2, −3, −4
  its axes e₁, e₂, e₃;
- ``sequences``: the motion (``times`` [s]; an arc-length path's load factors, ``unit`` λ) and, for a modes
  or buckling file, one per mode over one period of :func:`reference.io.mode_animation.mode_history`
  (``times``: the phase; amplitude as ``flexmbs plot --mode``: the largest displacement 10 % of the model
  size; ``loop``, shown first at a quarter period, ``start``), then its static path when it has more than
  one record.  ``duration``: seconds one playing of the sequence takes at 1× (the motion: its own time; a
  mode: 2 s a period).  ``positions``: the points
  of every frame quantised to 16 bits on the box (at most 1/131,070 of the box's side off), stored as
  differences from the previous frame (modulo 2¹⁶) and compressed with zlib, then base64; the page
  inflates it with the browser's ``DecompressionStream``.  ``colours``: per section component (axial
  force N₁, shear forces N₂, N₃, torque M₁, bending moments M₂, M₃; section frame, docs/results.md) the
  elements' values of every frame in 8 bits on ``[−scale, scale]``, ``scale`` the largest magnitude.
"""

from __future__ import annotations

import base64
import html
import json
import math
import zlib
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).with_name("view.js")
"""The viewer, written into every page."""
COMPONENTS = (("N1", "section_forces", 0, "axial force N₁ [N]"), ("N2", "section_forces", 1, "shear force N₂ [N]"),
              ("N3", "section_forces", 2, "shear force N₃ [N]"), ("M1", "section_moments", 0, "torque M₁ [N m]"),
              ("M2", "section_moments", 1, "bending moment M₂ [N m]"),
              ("M3", "section_moments", 2, "bending moment M₃ [N m]"))
"""The colour choices: key, results attribute, component, label."""
AXES = 0.08
"""Length of a rigid body's drawn axes, as a fraction of the model's size (the box diagonal at t = 0)."""
MODE_FRAMES = 48
"""Frames per period of a mode."""
EMBEDDED_FRAMES = 200
"""At most this many frames in a view that the report and the docs embed (every k-th output)."""


class ViewError(OSError):
    """A results file that cannot be viewed: one line naming the file and the fix (``flexmbs view``, exit 2)."""


def _b64(data: bytes) -> str:
    return base64.b64encode(zlib.compress(data, 6)).decode("ascii")


def _rows(n: int, max_frames: int | None) -> np.ndarray:
    """Output indices shown: all, or every k-th so that at most ``max_frames`` remain (the last one kept)."""
    if not max_frames or n <= max_frames:
        return np.arange(n)
    every = math.ceil((n - 1) / (max_frames - 1)) if max_frames > 1 else n
    return np.unique(np.r_[np.arange(0, n, every), n - 1])


class _Points:
    """The drawn points of a configuration: :class:`reference.io.vtk.Layout`'s, and each rigid body's axis tips."""

    def __init__(self, domain):
        from reference.io.vtk import Layout

        self.domain, self.layout = domain, Layout(domain)
        lay = self.layout
        size = float(np.linalg.norm(np.ptp(lay.p0, axis=0))) or 1.0
        bodies = [body.id for body in lay.rigid]
        self.nodes = np.r_[lay.node_of_point, np.repeat(np.array(bodies, dtype=np.int64), 3)].astype(np.int64)
        self.offsets = np.r_[lay.offsets, np.tile(AXES * size * np.eye(3), (len(bodies), 1))].reshape(-1, 3)
        segments, kinds = [], []
        for cell, line in enumerate(lay.lines):
            kind = cell if cell < lay.n_elements else -1
            pairs = [(a, b) for a, b in zip(line[:-1], line[1:])]
            segments += pairs
            kinds += [kind] * len(pairs)
        segments += [(v, v) for v in lay.vertices]  # a body drawn as its centre: a dot
        kinds += [-1] * len(lay.vertices)
        centre = {}  # a body's first point is its centre of mass (Layout), its named points follow
        for k, node in enumerate(lay.node_of_point[:lay.node_points]):
            centre.setdefault(int(node), k)
        for b, body in enumerate(bodies):
            first = lay.n_points + 3 * b
            segments += [(centre[body], first + axis) for axis in range(3)]
            kinds += [-2, -3, -4]
        self.segments, self.kinds = np.array(segments, dtype=np.int64).reshape(-1, 2), kinds

    def of(self, X: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """The points (k, P, 3) of k configurations: node positions X (k, N, 3), Euler parameters Q (k, N, 4)."""
        from reference.io.vtk import rotation_matrices

        out = np.asarray(X, dtype=float)[:, self.nodes]
        off = np.any(self.offsets != 0.0, axis=1)  # beam nodes sit on their node: no rotation to apply
        A = rotation_matrices(np.asarray(Q, dtype=float)[:, self.nodes[off]])
        out[:, off] += np.einsum("kpij,pj->kpi", A, self.offsets[off])
        if self.layout.curves:
            for k in range(len(out)):
                self.layout.curve_points(np.asarray(X[k], dtype=float), np.asarray(Q[k], dtype=float), out[k])
        return out


def _modes(path, points: _Points) -> list[dict]:
    """One sequence per mode (or buckling shape) of the file, over one period."""
    import h5py

    from reference.io.mode_animation import SHAPES, amplitude, mode_history, read_mode
    from reference.io.vtk import Layout

    with h5py.File(path, "r") as f:
        dataset = next((name for name in SHAPES if name in f), None)
        count = f[dataset].shape[0] if dataset else 0
        kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in f["modes/kind"][()]] \
            if "modes/kind" in f else []
    out = []
    for k in range(1, count + 1):
        mode = read_mode(path, k)
        a = amplitude(Layout(points.domain, mode["x0"], mode["q0"]), mode["q0"], mode["shape"])  # plot --mode's
        history = mode_history(mode, a, MODE_FRAMES)
        if mode["dataset"] == "modes/shape":
            kind = f", {kinds[k - 1]}" if k <= len(kinds) and kinds[k - 1] != "elastic" else ""
            name = f"mode {k}: {mode['value']:.4g} Hz{kind}"
        else:
            name = f"buckling mode {k}: load factor {mode['value']:.4g}"
        out.append({"name": name, "times": np.arange(MODE_FRAMES) / MODE_FRAMES, "unit": "phase", "loop": True,
                    "start": MODE_FRAMES // 4,  # shown first: the largest deflection, a quarter period on
                    "duration": 2.0, "points": points.of(history.positions, history.rotations), "colours": {}})
    return out


def scene(path, max_frames: int | None = None, title: str | None = None, height: int = 480, domain=None) -> dict:
    """The scene of the results file ``path`` (the module docstring's format), as a JSON-ready dict.

    Parameters
    ----------
    path : path
        A results file that carries its deck (``flexmbs run``, ``Deck.solve``).
    max_frames : int, optional
        Show every k-th output so that at most this many frames remain (the report's and the docs'
        embedded views); default: every output.
    title : str, optional
        The view's title (default: the deck's name).
    height : int
        The drawing's height [CSS px].
    domain : reference.domain.Domain, optional
        The model the file was written for, when the file does not carry its deck (``Domain.solve``).

    Raises
    ------
    ViewError
        A missing or unreadable file, one without records, or one that carries no deck.
    """
    from flexmbs.plot import domain_of
    from reference.io.results import load_results

    if not Path(path).is_file():
        raise ViewError(f"{path}: no such results file; give the results.h5 written by `flexmbs run` or "
                        "`flexmbs modes`")
    try:
        r = load_results(path)
        n = len(r.time)
    except (OSError, KeyError, ValueError) as exc:
        raise ViewError(f"{path}: not a flexmbs results file ({' '.join(str(exc).split())}); give the results.h5 "
                        "written by `flexmbs run` or `flexmbs modes`") from None
    if n == 0:
        raise ViewError(f"{path}: the file has no records (status {r.status!r}): its run ended before the first "
                        "output; nothing to show")
    domain = domain_of(r) if domain is None else domain
    if domain is None:
        raise ViewError(f"{path}: the file carries no deck, so the model's elements are unknown; write it with "
                        "`flexmbs run DECK` (or Deck.solve), which records the deck")
    if len(domain.nodes) != len(r.labels):
        raise ViewError(f"{path}: the file has {len(r.labels)} nodes, its deck's model {len(domain.nodes)}: the file "
                        "does not belong to the deck it carries; run the deck again")
    points = _Points(domain)
    sequences = _modes(path, points)
    linearised = bool(sequences)
    if not linearised or n > 1:  # a modes file's path to its configuration, when it has one
        rows = _rows(n, max_frames)
        times = np.asarray(r.time, dtype=float)[rows]
        colours = {}
        for key, attribute, component, label in COMPONENTS:
            values = np.asarray(getattr(r, attribute), dtype=float)
            if values.ndim != 3 or values.shape[1] == 0:
                continue
            values = values[rows, :, component]
            scale = float(np.nanmax(np.abs(values), initial=0.0))
            if not np.isfinite(scale) or scale == 0.0:
                continue
            level = np.rint(127.5 + 127.5 * np.nan_to_num(values) / scale)
            colours[key] = {"label": label, "scale": scale, "data": np.clip(level, 0, 255).astype(np.uint8)}
        unit = "λ" if domain.algorithm().name == "arc_length" else "s"  # an arc-length path's record: its load factor
        motion = {"name": "static path" if linearised else "", "times": times, "unit": unit, "loop": False, "start": 0,
                  "duration": max(float(times[-1] - times[0]), 1e-9) if len(times) > 1 else 1.0,
                  "points": points.of(r.positions[rows], r.rotations[rows]),
                  "colours": colours}
        sequences = ([motion] + sequences) if not linearised else (sequences + [motion])
    allp = np.concatenate([s["points"].reshape(-1, 3) for s in sequences])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    out = []
    for s in sequences:
        q = np.rint((s["points"] - lo) / span * 65535.0).astype("<u2")
        q[1:] = np.diff(q, axis=0)  # differences modulo 2¹⁶: the page adds them up again
        out.append({"name": s["name"], "times": [float(f"{t:.6g}") for t in s["times"]], "unit": s["unit"],
                    "loop": s["loop"], "start": s["start"], "duration": s["duration"], "positions": _b64(q.tobytes()),
                    "colours": {k: {"label": c["label"], "scale": c["scale"], "data": _b64(c["data"].tobytes())}
                                for k, c in s["colours"].items()}})
    return {"title": title or domain.name, "kind": "modes" if linearised else "motion", "height": int(height),
            "box": [lo.tolist(), (lo + span).tolist()], "points": len(points.nodes),
            "segments": points.segments.ravel().tolist(), "kinds": points.kinds,
            "elements": list(r.element_labels) or [e.label for e in domain.elements], "sequences": out}


def division(data: dict) -> str:
    """The view's ``<div>``, the scene in it as JSON; :func:`script` draws every such ``<div>`` of a page."""
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return f'<div class="flexmbs-view"><script type="application/json">{text}</script></div>'


def script() -> str:
    """The viewer as a ``<script>`` element: once per page, after the views (a repeat draws only new ones)."""
    return f"<script>{SCRIPT.read_text(encoding='utf-8')}</script>"


def fragment(data: dict) -> str:
    """The view's ``<div>`` and the viewer's script, on one line (a Markdown page's raw HTML)."""
    return division(data) + script()


def from_page(text: str) -> str:
    """The ``<div>`` of the view in a page written by :func:`page` (the report and the docs embed the views
    that ``flexmbs report`` wrote, and the script once)."""
    start = text.index('<div class="flexmbs-view">')
    return text[start:text.index("</script></div>", start) + len("</script></div>")]


def page(data: dict) -> str:
    """A whole HTML page of one view."""
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'><title>"
            f"{html.escape(data['title'])} (flexmbs view)</title></head>"
            "<body style='font-family:system-ui,sans-serif;margin:1em'>"
            f"{fragment(data)}</body></html>\n")


def iframe(data: dict, height: int | None = None) -> str:
    """The page as an ``<iframe srcdoc>`` (Markdown, notebooks): on one line, its own document."""
    tall = (height or data.get("height", 480)) + 70
    return (f'<iframe class="flexmbs-view-frame" style="width:100%;height:{tall}px;border:0" '
            f'srcdoc="{html.escape(page(data), quote=True)}"></iframe>')


def write(path, out=None, max_frames: int | None = None, title: str | None = None, domain=None) -> Path:
    """Write the view of the results file ``path`` to ``out`` (default: beside it, ``NAME.html``); return it.
    ``max_frames``, ``title``, ``domain``: as :func:`scene`."""
    out = Path(out) if out else Path(path).with_suffix(".html")
    text = page(scene(path, max_frames=max_frames, title=title, domain=domain))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return out


class Show:
    """A view for Jupyter: displayed inline (an ``<iframe srcdoc>``), e.g. ``Show("out/x/results.h5")``."""

    def __init__(self, path, max_frames: int | None = 400, title: str | None = None, height: int = 420):
        self.html = iframe(scene(path, max_frames=max_frames, title=title, height=height))

    def _repr_html_(self) -> str:
        return self.html


def main(args) -> int:
    """``flexmbs view RESULTS [--out FILE.html] [--max-frames N]``."""
    out = write(args.results, args.out, max_frames=args.max_frames)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB); open it in a browser (it works offline)")
    return 0
