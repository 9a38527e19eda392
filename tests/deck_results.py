"""Run every model deck and compare its results array by array with another checkout's.

A refactoring of the engine must leave every result as it was: ``save`` runs each
``models/*.toml`` to its ``t_end`` and stores every dataset of its results file in
one ``.npz`` per deck; ``compare`` reads two such folders and prints, per deck and
dataset, whether the arrays are identical bit for bit or their largest difference
relative to the dataset's largest magnitude.

    python tests/deck_results.py save OUT [DECK ...]
    python tests/deck_results.py compare OLD NEW [--tolerance 1e-12]

Run ``save`` from each checkout (e.g. a ``git worktree`` of the earlier commit) with
that checkout's ``reference`` on the path; exit status 1 when a dataset differs by
more than the tolerance or is missing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _datasets(path: Path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiub":
                out[name] = obj[()]
        f.visititems(visit)
        out["@status"] = np.array(str(f.attrs.get("status", "")))
    return out


def save(out: Path, decks: list[str]) -> None:
    sys.path.insert(0, str(ROOT))
    from reference.io.deck import load_deck

    out.mkdir(parents=True, exist_ok=True)
    paths = [Path(d) for d in decks] or sorted((ROOT / "models").glob("*.toml"))
    for deck in paths:
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            h5 = Path(tmp) / "results.h5"
            domain = load_deck(deck).domain
            domain.solve(results_path=h5)
            np.savez(out / f"{deck.stem}.npz", **_datasets(h5))
        print(f"{deck.stem}: {time.perf_counter() - t0:.1f} s", flush=True)


def compare(old: Path, new: Path, tolerance: float) -> int:
    bad = 0
    for a in sorted(old.glob("*.npz")):
        b = new / a.name
        if not b.exists():
            print(f"{a.stem}: missing in {new}")
            bad += 1
            continue
        da, db = np.load(a), np.load(b)
        worst, identical, names = 0.0, 0, sorted(set(da.files) | set(db.files))
        for name in names:
            if name not in da.files or name not in db.files:
                print(f"{a.stem}: {name} only in {'new' if name in db.files else 'old'}")
                bad += 1
                continue
            x, y = da[name], db[name]
            if x.shape != y.shape:
                print(f"{a.stem}: {name} shape {x.shape} against {y.shape}")
                bad += 1
                continue
            if x.dtype.kind in "US" or np.array_equal(x, y, equal_nan=True):
                identical += 1
                if x.dtype.kind in "US" and x != y:
                    print(f"{a.stem}: {name} {x} against {y}")
                    bad += 1
                continue
            scale = max(float(np.nanmax(np.abs(x))), 1e-300)
            rel = float(np.nanmax(np.abs(x - y))) / scale
            worst = max(worst, rel)
            if rel > tolerance:
                print(f"{a.stem}: {name} differs by {rel:.3g} of its largest value")
                bad += 1
        print(f"{a.stem}: {identical}/{len(names)} datasets bit for bit, largest relative difference {worst:.3g}")
    return 1 if bad else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("save")
    s.add_argument("out", type=Path)
    s.add_argument("decks", nargs="*")
    c = sub.add_parser("compare")
    c.add_argument("old", type=Path)
    c.add_argument("new", type=Path)
    c.add_argument("--tolerance", type=float, default=1e-12)
    args = parser.parse_args()
    if args.command == "save":
        save(args.out, args.decks)
        return 0
    return compare(args.old, args.new, args.tolerance)


if __name__ == "__main__":
    sys.exit(main())
