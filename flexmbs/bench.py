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

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ROLLUP_DECK = ROOT / "models" / "embedded_beam.toml"


def rollup_parameters(domain) -> dict:
    """The embedded-beam data of a loaded deck, as the Exudyn model builder takes them."""
    section = domain.elements[0].formulation.section
    xs = np.array([n.position for n in domain.nodes])
    return dict(
        L=float(np.linalg.norm(xs[-1] - xs[0])), n_elements=len(domain.elements), EA=section.EA,
        GA=section.GA2, GJ=section.GJ, EI=section.EI2, rhoA=section.rhoA,
        rhoJ=(section.rhoJ1, section.rhoJ2, section.rhoJ3), damping=domain.solver.damping,
        dt=domain.solver.dt, t_end=domain.solver.t_end, output_every=domain.solver.output_every,
    )


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


def time_exudyn_rollup(deck: Path, repeat: int) -> tuple[float, int]:
    from crosscheck.exudyn_rollup import solve_rollup_exudyn
    from reference.domain import Domain

    params = rollup_parameters(Domain.from_deck(deck))
    solve_rollup_exudyn(**{**params, "t_end": 20 * params["dt"]})  # warm-up
    times, steps = [], 0
    for _ in range(repeat):
        out = solve_rollup_exudyn(**params)
        times.append(out["wall_time"])
        steps = out["steps"]
    return statistics.median(times), steps


def time_exudyn_three_bar(deck: Path, repeat: int) -> tuple[float, int]:
    from crosscheck.exudyn_three_bar import solve_three_bar_exudyn
    from reference.domain import Domain

    domain = Domain.from_deck(deck)
    params = dict(dt=domain.solver.dt, t_end=domain.solver.t_end, output_every=domain.solver.output_every)
    solve_three_bar_exudyn(**{**params, "t_end": 20 * params["dt"]})  # warm-up
    times, steps = [], 0
    for _ in range(repeat):
        out = solve_three_bar_exudyn(**params)
        times.append(out["wall_time"])
        steps = out["steps"]
    return statistics.median(times), steps


THREE_BAR_DECK = ROOT / "models" / "three_bar.toml"
CASES = {
    "embedded beam roll-up (12 Beam2, 10,000 steps)": (ROLLUP_DECK, time_reference, time_exudyn_rollup),
    "three-bar mechanism (4 Beam2 + 2 rigid, 5 joints, 50,000 steps)": (THREE_BAR_DECK, time_reference,
                                                                         time_exudyn_three_bar),
}


def main(args=None) -> int:
    repeat = getattr(args, "repeat", 3) or 3
    rows = []
    print(f"flexmbs bench: median of {repeat} timed solves after one warm-up, same process, same data")
    for name, (deck, ref_fn, exu_fn) in CASES.items():
        t_ref, n_ref = ref_fn(deck, repeat)
        t_exu, n_exu = exu_fn(deck, repeat)
        rows.append((name, t_ref, n_ref, t_exu, n_exu))
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'reference [s]':>13}  {'Exudyn [s]':>10}  {'ratio':>6}  steps (ref/Exudyn)")
    for name, t_ref, n_ref, t_exu, n_exu in rows:
        print(f"{name:<{width}}  {t_ref:13.4f}  {t_exu:10.4f}  {t_ref / t_exu:6.3f}  {n_ref}/{n_exu}")
    print("ratio = reference time / Exudyn time (target ≤ 0.3)")
    return 0
