"""``flexmbs bench``: the cost of parameter sensitivities, measured side by side with the run without them.

The static embedded-beam roll-up (models/embedded_beam_static.toml, 12 Beam2 elements, 20 load steps) on the
reference path: the run alone (:meth:`reference.domain.Domain.solve`, ``backend = "reference"``) against
:func:`reference.io.deck_sensitivities.static_sensitivities` with 10 parameters (the torque's scale and nine
section entries) and the tip's position as output, everything included (reading the deck, the models with the
parameters' derivatives, the run, one factorisation per load step and a back-substitution per parameter).  Issue
40's target: at most 1.5× the run without them.  CPU time (``time.process_time``); the two runs alternate
(interleaved, so that a change of the machine's load falls on both), the ratio is that of the medians of
``repeat`` runs each, and the load average over the measurement is printed beside it.
The same for generalized-α: the three-bar (models/three_bar.toml on generalized-α, 0.5 s in steps of 10 ms)
alone against :func:`reference.io.deck_sensitivities.dynamic_sensitivities` with the coupler's EI2 and its
mid-span deflection; issue 40's target: at most 2×.
"""

from __future__ import annotations

import os
import statistics
import time

DECK = "models/embedded_beam_static.toml"
PARAMETERS = ["loads[0].moment"] + [f"sections.rollup.{k}" for k in
                                    ("EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ1", "rhoJ2")]
OVERRIDES = {"solver.backend": "reference"}
ALPHA = {"solver.algorithm": "generalized_alpha", "t_end": 0.5, "dt": 1e-2, "solver.output_every": 1,
         "solver.backend": "reference"}


def _cpu(call) -> float:
    t0 = time.process_time()
    call()
    return time.process_time() - t0


def _side_by_side(without, with_, repeat: int) -> tuple[float, float]:
    """Median CPU times [s] of ``without`` and ``with_``, run alternately ``repeat`` times each after one
    warm-up of each (imports, the generated functions' NumPy twins)."""
    without(), with_()
    times = [(_cpu(without), _cpu(with_)) for _ in range(repeat)]
    return statistics.median(a for a, _ in times), statistics.median(b for _, b in times)


def sensitivity_timing(repeat: int = 5, targets: list | None = None) -> list[str]:
    """Time the static run with and without 10 parameters and the generalized-α run with and without 1, side by
    side; append the targets (ratios ≤ 1.5 and ≤ 2) to ``targets``; return the printed lines."""
    from flexmbs.bench_common import ROOT, Target
    from reference.io.deck import load_deck
    from reference.io.deck_sensitivities import dynamic_sensitivities, static_sensitivities

    path, three_bar = ROOT / DECK, ROOT / "models" / "three_bar.toml"
    load = os.getloadavg()[0]
    t_plain, t_sens = _side_by_side(
        lambda: load_deck(path, overrides=OVERRIDES).domain.solve(),
        lambda: static_sensitivities(path, PARAMETERS, ["position:beam:end"], OVERRIDES), repeat)
    a_plain, a_sens = _side_by_side(
        lambda: load_deck(three_bar, overrides=ALPHA).domain.solve(),
        lambda: dynamic_sensitivities(three_bar, ["sections.coupler.EI2"], ["midspan_deflection:coupler"], ALPHA),
        repeat)
    load = 0.5 * (load + os.getloadavg()[0])
    ratio = Target("static run with 10 sensitivity parameters / without", t_sens / t_plain, 1.5, "{:.2f}")
    ratio_alpha = Target("generalized-α run with 1 sensitivity parameter / without", a_sens / a_plain, 2.0, "{:.2f}")
    if targets is not None:
        targets += [ratio, ratio_alpha]
    return [f"**Sensitivities** (reference path), CPU time, median of {repeat} interleaved runs, load average "
            f"{load:.1f} on {os.cpu_count()} cores:",
            f"  static roll-up (12 Beam2, 20 load steps): without {t_plain:.3f} s, with 10 parameters {t_sens:.3f} s: "
            f"ratio {t_sens / t_plain:.2f} (target ≤ 1.5) {ratio.mark}",
            f"  three-bar on generalized-α (50 steps): without {a_plain:.3f} s, with 1 parameter {a_sens:.3f} s: "
            f"ratio {a_sens / a_plain:.2f} (target ≤ 2) {ratio_alpha.mark}"]


if __name__ == "__main__":
    print("\n".join(sensitivity_timing()))
