"""What the sections of ``flexmbs bench`` share: the repository root, a target and the closing summary of
the targets, the work–precision cases, the time at matched accuracy and the backend the timed runs take.

:mod:`flexmbs.bench` runs the sections (:mod:`flexmbs.bench_scaling`, :mod:`flexmbs.bench_throughput`,
:mod:`flexmbs.bench_modes`, :mod:`flexmbs.bench_adaptive`, :mod:`flexmbs.bench_large` …); each section imports
what it shares from here, never from the command's module or from another section's, so that the benchmark
modules import one another in one direction only.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

COMPILED = "compiled"
"""The backend every timed flexmbs run of the bench takes (``[solver] backend``): the bench measures the numba
kernels' warm speed, which ``"auto"`` would give to the plain NumPy path for a short job."""


@dataclass
class Target:
    """A benchmark's target: the measured ``value`` of ``what`` meets it when ``value ≤ limit``
    (a NaN never does); ``fmt`` formats both numbers."""

    what: str
    value: float
    limit: float
    fmt: str = "{:.3g}"

    @property
    def met(self) -> bool:
        return bool(self.value <= self.limit)

    @property
    def mark(self) -> str:
        """``MET`` or ``MISSED``, the word that ends the benchmark's line."""
        return "MET" if self.met else "MISSED"

    def describe(self) -> str:
        """``what: value (target ≤ limit)``."""
        return f"{self.what}: {self.fmt.format(self.value)} (target ≤ {self.fmt.format(self.limit)})"


def target_summary(targets: list[Target]) -> tuple[list[str], int]:
    """The closing lines of ``flexmbs bench`` — how many targets were met, then every missed one — and
    the exit status (1 when a target was missed)."""
    missed = [t for t in targets if not t.met]
    if not missed:
        return [f"targets: all {len(targets)} met"], 0
    return ([f"targets: {len(targets) - len(missed)} of {len(targets)} met, {len(missed)} MISSED:"]
            + [f"  MISSED  {t.describe()}" for t in missed]), 1


WP_CASES = {
    # name: deck, t_end [s], output interval [s], implicit steps, explicit steps (fractions of the
    # critical step), reference step
    "three-bar (4 Beam2)": ("three_bar.toml", 4.0, 1e-2, [2e-2, 1e-2, 5e-3, 2e-3, 1e-3], [0.8, 0.4, 0.2], 2.5e-4),
    "steel three-bar (4 Beam2)": ("steel_three_bar.toml", 1.0, 2e-3, [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4], [0.8, 0.4],
                                  1e-5),
}
"""Work–precision cases (output intervals as the decks': 100 and 500 per second); the explicit
steps are fractions of the mesh's critical step."""

MATCHED = 1e-3
"""Matched accuracy of the work–precision table: 0.1 % of the peak coupler deflection."""


def matched_time(rows, target: float = MATCHED):
    """Solve time at the error ``target``: log–log interpolation between the two runs that
    bracket it; ``(time, how)``, time None when no run reaches it."""
    rows = sorted(rows, key=lambda r: -r[0])
    for (_, w0, e0), (_, w1, e1) in zip(rows, rows[1:]):
        if e0 > target >= e1:
            s = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(w0) + s * (np.log(w1) - np.log(w0)))), "interpolated"
    ok = [r for r in rows if r[2] <= target]
    if ok:
        return min(r[1] for r in ok), f"largest step already within (dt = {ok[0][0]:g})"
    return None, "not reached"
