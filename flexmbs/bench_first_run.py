"""``flexmbs bench --first-run``: what a user waits for the first result of a deck, beside a warm rerun.

Each deck runs as a user runs it, ``flexmbs run DECK --no-vtk --backend auto`` in a process of its own, twice: first with an
empty numba cache (``NUMBA_CACHE_DIR`` a new temporary folder: every kernel the run needs is compiled), then
again with the cache the first run left (the warm rerun: kernels loaded, not compiled).  The times are whole
processes (interpreter start, imports, reading the deck, the run, the results file), so the first run's excess
over the warm rerun is the compilation a first run pays.  With ``--backend auto`` (the decks' results on the compiled default are bit for bit those of the earlier engine) a short
job runs on the plain NumPy path and compiles nothing; a long explicit one compiles (``backend:`` line of
``flexmbs run``).  A cold compilation takes minutes on a small machine, so this section runs only when asked for;
the machine's load average is printed with the table (the compile times scale with it).  docs/benchmarks.md
("First run") holds a measured table.

Run alone: ``python -m flexmbs.bench_first_run [DECK …]``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from flexmbs.bench_common import ROOT

BEAM3 = ("cantilever_large_deflection (beam3)", ROOT / "models" / "cantilever_large_deflection.toml",
         {"element": "beam3"}, ["--dt", "1e-4"])
"""Issue 36's fifth run: the large-deflection cantilever with ``element = "beam3"`` (the deck's 20 elements), at
dt = 1e-4 s (the deck's 1.6e-4 s is above beam3's critical step)."""

ISSUE_RUNS = [(name, ROOT / "models" / f"{name}.toml", {}, [])
              for name in ("three_bar", "embedded_beam_static", "cantilever_modes", "lee_frame")] + [BEAM3]
"""The five runs of issue 36's first-run target."""


def _deck_with(deck: Path, beam_keys: dict, folder: Path) -> Path:
    """A copy of ``deck`` in ``folder`` whose ``[[beams]]`` tables all carry ``beam_keys`` (e.g. the element
    family), written after each table's ``section`` line: ``flexmbs run`` takes the deck as a user writes it."""
    if not beam_keys:
        return deck
    lines, inside = [], False
    for line in deck.read_text(encoding="utf-8").splitlines():
        lines.append(line)
        if line.startswith("["):
            inside = line.strip() == "[[beams]]"
        elif inside and line.startswith("section ="):
            lines += [f'{key} = "{value}"' for key, value in beam_keys.items()]
    copy = folder / deck.name
    copy.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return copy


def _run(deck: Path, arguments: list, out: Path, cache: Path) -> tuple[float, str]:
    """Wall time [s] of one ``flexmbs run`` process and its ``backend:`` line ("" if it printed none)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "flexmbs", "run", str(deck), "--no-vtk", "--backend", "auto", "--out", str(out),
                           *arguments], capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"flexmbs run {deck.name} failed: {(done.stderr or done.stdout)[-500:]}")
    line = next((x for x in done.stdout.splitlines() if x.startswith("backend: ")), "")
    return wall, line


def first_and_warm(deck: Path, beam_keys: dict | None = None, arguments: list | None = None) -> tuple:
    """``(first run [s], warm rerun [s], backend line)`` of ``deck`` from an empty numba cache (module
    docstring)."""
    with tempfile.TemporaryDirectory(prefix="flexmbs_first_run_") as tmp:
        folder = Path(tmp)
        path = _deck_with(deck, beam_keys or {}, folder)
        first, line = _run(path, arguments or [], folder / "first", folder / "numba")
        warm, _ = _run(path, arguments or [], folder / "warm", folder / "numba")
    return first, warm, line


def table(runs) -> list[str]:
    """The first-run table of ``runs`` ``[(label, deck, beam keys, run arguments)]``, with the load averages
    before and after (markdown)."""
    before = os.getloadavg()
    rows = []
    for label, deck, keys, arguments in runs:
        first, warm, line = first_and_warm(deck, keys, arguments)
        backend = line.removeprefix("backend: ").split(" ", 1)[0] or "compiled"
        rows.append(f"| {label} | {backend} | {first:.1f} | {warm:.1f} | {first - warm:.1f} |")
        print(rows[-1], flush=True)
    after = os.getloadavg()
    return ["**First run** (`flexmbs run DECK --no-vtk --backend auto`, whole process; empty numba cache, then the warm rerun; "
            f"load average {before[0]:.1f} before, {after[0]:.1f} after, {os.cpu_count()} cores):", "",
            "| deck | backend | first run [s] | warm rerun [s] | first − warm [s] |", "|---|---|---|---|---|",
            *rows, ""]


def every_deck() -> list:
    """Every deck of ``models/`` as it is, then issue 36's beam3 run."""
    return [(deck.stem, deck, {}, []) for deck in sorted((ROOT / "models").glob("*.toml"))] + [BEAM3]


def main(names: list[str]) -> int:
    runs = [run for run in ISSUE_RUNS if not names or run[0].split(" ")[0] in names]
    print("\n".join(table(runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
