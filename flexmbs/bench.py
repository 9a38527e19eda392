"""``flexmbs bench``: solve times of the reference engine and of Exudyn, side by side.

Both engines solve the same dynamic problem from the same deck data, with the
same load history and time step, in one process, one after the other; each is
warmed up once (numba compilation, Exudyn's first-call set-up) and then timed
``repeat`` times; the table shows the median solve times and their ratio.
Only the solve is timed (model building excluded) on both sides.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def time_reference(deck: Path, repeat: int) -> tuple[float, int]:
    from reference.domain import Domain

    domain = Domain.from_deck(deck)
    domain.solve()  # warm-up: numba compiles (or loads its cache)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        domain.solve()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), int(round(domain.solver.t_end / domain.solver.dt))


def time_exudyn(deck: Path, repeat: int) -> tuple[float, int]:
    """Exudyn on the same deck through the generic translation (crosscheck.exudyn_model)."""
    from crosscheck.exudyn_model import solve
    from reference.domain import Domain

    solve(Domain.from_deck(deck), t_end=20 * Domain.from_deck(deck).solver.dt)  # warm-up
    times, steps = [], 0
    for _ in range(repeat):
        out = solve(Domain.from_deck(deck))
        times.append(out["wall_time"])
        steps = out["steps"]
    return statistics.median(times), steps


CASES = {
    "embedded beam roll-up (12 Beam2, 10,000 steps)": ROOT / "models" / "embedded_beam.toml",
    "three-bar mechanism (4 Beam2 + 2 rigid, 5 joints, 50,000 steps)": ROOT / "models" / "three_bar.toml",
}


def main(args=None) -> int:
    repeat = getattr(args, "repeat", 3) or 3
    rows = []
    print(f"flexmbs bench: median of {repeat} timed solves after one warm-up, same process, same data")
    for name, deck in CASES.items():
        t_ref, n_ref = time_reference(deck, repeat)
        t_exu, n_exu = time_exudyn(deck, repeat)
        rows.append((name, t_ref, n_ref, t_exu, n_exu))
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'reference [s]':>13}  {'Exudyn [s]':>10}  {'ratio':>6}  steps (ref/Exudyn)")
    for name, t_ref, n_ref, t_exu, n_exu in rows:
        print(f"{name:<{width}}  {t_ref:13.4f}  {t_exu:10.4f}  {t_ref / t_exu:6.3f}  {n_ref}/{n_exu}")
    print("ratio = reference time / Exudyn time (target ≤ 0.3)")
    return 0
