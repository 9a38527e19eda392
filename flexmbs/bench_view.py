"""``python -m flexmbs.bench_view``: the interactive views compared (docs/benchmarks.md § Interactive views).

Each candidate draws the same motion — a cantilever of E Beam2 elements carrying a travelling wave, F
output records, coloured by the bending moment — as one standalone HTML page, which is then opened in
headless Chromium with the network cut off (:mod:`flexmbs.browser`).  Measured: the page's size, the
time to write it, the time from navigation to the first drawing (the candidate's own ready signal),
the requests it tried to make outside the file and the console's errors.  Candidates: ``flexmbs view``
(:mod:`flexmbs.view`), k3d (its ``snapshot_type="full"`` page: the library inlined) and pyvista's
``export_html`` (vtk.js through trame; a static scene: it has no time axis, so only the first record
is written).  A candidate whose package is not installed is left out.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from flexmbs.browser import BrowserError, chromium, open_page

ROOT = Path(__file__).resolve().parent.parent
CASES = ((4, 1001), (10, 1000), (10_000, 10), (10_000, 1000))
"""(elements, records) of each case."""


def motion(E: int, F: int):
    """Node positions (F, E+1, 3) of the travelling wave on a unit cantilever along x, and the element
    moments (F, E) [arbitrary units]."""
    x = np.linspace(0.0, 1.0, E + 1)
    t = np.arange(F)[:, None] / F
    pos = np.stack([np.broadcast_to(x, (F, E + 1)), 0.1 * x * np.sin(2 * np.pi * (x - t)),
                    0.05 * x * np.cos(2 * np.pi * (x - t))], axis=-1)
    xm = 0.5 * (x[1:] + x[:-1])
    return pos, np.sin(2 * np.pi * (xm - t))


def results_file(path: Path, E: int, F: int) -> Path:
    """A results file of that motion with the deck it belongs to (``models/cantilever_modes.toml`` meshed
    with E elements): what ``flexmbs view`` reads."""
    deck = (ROOT / "models" / "cantilever_modes.toml").read_text(encoding="utf-8")
    deck = re.sub(r"(?m)^elements = 32", f"elements = {E}", deck)
    pos, moment = motion(E, F)
    with h5py.File(path, "w") as f:
        f.attrs.update({"deck": deck, "deck_path": "cantilever.toml", "status": "completed", "engine": "synthetic"})
        f["time"] = np.arange(F) / F
        f["nodes/label"] = np.array([f"beam:{k}" for k in range(E + 1)], dtype=h5py.string_dtype())
        f["nodes/position"] = pos
        f["nodes/rotation"] = np.broadcast_to([1.0, 0.0, 0.0, 0.0], (F, E + 1, 4))
        f["elements/label"] = np.array([f"beam/{k}" for k in range(E)], dtype=h5py.string_dtype())
        f["elements/section_force"] = np.zeros((F, E, 3))
        f["elements/section_moment"] = np.stack([np.zeros_like(moment), moment, np.zeros_like(moment)], axis=-1)
    return path


def flexmbs_page(work: Path, E: int, F: int) -> tuple[Path, str]:
    from flexmbs.view import write

    return write(results_file(work / "results.h5", E, F), work / "flexmbs.html"), \
        "window.flexmbsViews && window.flexmbsViews[0] && window.flexmbsViews[0].drawn"


def k3d_page(work: Path, E: int, F: int) -> tuple[Path, str]:
    import k3d

    pos, moment = motion(E, F)
    node_moment = np.concatenate([moment[:, :1], 0.5 * (moment[:, 1:] + moment[:, :-1]), moment[:, -1:]], axis=1)
    plot = k3d.plot()
    plot += k3d.line({f"{k / F:.6f}": pos[k].astype(np.float32) for k in range(F)},
                     attribute={f"{k / F:.6f}": node_moment[k].astype(np.float32) for k in range(F)},
                     color_range=[-1.0, 1.0], width=0.01, shader="mesh")
    path = work / "k3d.html"
    path.write_text(plot.get_snapshot(additional_js_code="window.benchReady = true;"), encoding="utf-8")
    return path, "window.benchReady"


def pyvista_page(work: Path, E: int, F: int) -> tuple[Path, str]:
    import pyvista

    pos, moment = motion(E, F)
    line = pyvista.lines_from_points(pos[0])
    line.cell_data["M2"] = moment[0]
    plotter = pyvista.Plotter(off_screen=True)
    plotter.add_mesh(line.tube(radius=0.005), scalars="M2")
    path = work / "pyvista.html"
    plotter.export_html(path)
    plotter.close()
    return path, "document.querySelector('canvas') && document.querySelector('canvas').width > 0"


CANDIDATES = {"flexmbs view": flexmbs_page, "k3d": k3d_page, "pyvista": pyvista_page}


def measure(cases=CASES, candidates=tuple(CANDIDATES), timeout: float = 300.0) -> list[str]:
    """One Markdown table row per candidate and case."""
    rows = ["| candidate | elements | records | page [MB] | writing [s] | load to first drawing [s] | "
            "requests outside the file | console errors |", "|---|---|---|---|---|---|---|---|"]
    for E, F in cases:
        for name in candidates:
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                try:
                    path, ready = CANDIDATES[name](Path(tmp), E, F)
                except ImportError as exc:
                    rows.append(f"| {name} | {E} | {F} | not installed ({exc.name}) | | | | |")
                    continue
                written = time.perf_counter() - t0
                size = path.stat().st_size / 1e6
                try:
                    page = open_page(path, ready=ready, timeout=timeout, screenshot=False)
                    load, requests, errors = f"{page.load_seconds:.2f}", len(page.requests), len(page.errors)
                except BrowserError as exc:
                    load, requests, errors = f"failed: {str(exc)[:80]}", "", ""
                rows.append(f"| {name} | {E:,} | {F:,} | {size:.2f} | {written:.1f} | {load} | {requests} | {errors} |")
                print(rows[-1], flush=True)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m flexmbs.bench_view", description=__doc__.split("\n\n")[0])
    p.add_argument("--candidates", nargs="*", default=list(CANDIDATES), choices=list(CANDIDATES))
    p.add_argument("--case", nargs=2, type=int, action="append", metavar=("ELEMENTS", "RECORDS"),
                   help="a case of its own (repeatable; default the four of CASES)")
    args = p.parse_args(argv)
    if chromium() is None:
        print("no chromium executable: install one (apt-get install chromium)")
        return 1
    rows = measure([tuple(c) for c in args.case] if args.case else CASES, args.candidates)
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
