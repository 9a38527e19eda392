"""``flexmbs bench``: the lowest modes of a 10,000-coordinate beam, flexmbs beside Exudyn.

Both engines solve the same model, a clamped cantilever of 1,666 Beam2 elements (9,996 free
coordinates, :func:`crosscheck.exudyn_modes.timing_cantilever`), for its 20 lowest constrained
modes with sparse shift-invert Lanczos, in the same process.  flexmbs' time is the whole
analysis (:func:`reference.algorithms.linearization.lowest_modes`: the matrices from the derived tangents,
the null-space reduction, the eigen-solve), Exudyn's its eigen call alone
(:func:`crosscheck.exudyn_modes.exudyn_modes_timing`; most of it is Exudyn's dense handling of
the clamped coordinates, its Lanczos iteration takes ~0.3 s of ~4–9 s).  The two elements
differ in their mass (flexmbs lumps it, Exudyn's is consistent), so the frequencies agree to
that discretisation difference (1.8e-5 for the 20th mode on this mesh), printed next to the times.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

ELEMENTS = 1666
MODES = 20


def modes_timing(repeat: int = 3, targets: list | None = None, elements: int = ELEMENTS, n: int = MODES) -> list[str]:
    """Time both engines on the cantilever; append its two targets (≤ 2 s, ≤ 0.5 × Exudyn)
    to ``targets``; return the printed lines."""
    from crosscheck.exudyn_modes import exudyn_modes_timing, timing_cantilever
    from flexmbs.bench_common import Target
    from reference.algorithms.linearization import lowest_modes

    domain = timing_cantilever(elements)
    model, state = domain.initialization(), domain.initial_conditions()
    lowest_modes(model, state, n)  # warm-up: the kernels are compiled or loaded
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        ours = lowest_modes(model, state, n)[0]
        times.append(time.perf_counter() - t0)
    theirs, t_exudyn = exudyn_modes_timing(elements, n)
    t_ours = statistics.median(times)
    spread = float(np.max(np.abs(ours / theirs - 1.0)))
    absolute = Target(f"{n} lowest modes of {6 * elements:,} coordinates, flexmbs [s]", t_ours, 2.0, "{:.3f}")
    ratio = Target(f"{n} lowest modes, flexmbs / Exudyn eigen call", t_ours / t_exudyn, 0.5, "{:.3f}")
    if targets is not None:
        targets += [absolute, ratio]
    return [f"**Modes** ({n} lowest, cantilever of {elements} Beam2, {6 * elements:,} free coordinates), "
            f"median of {repeat}:",
            f"  flexmbs (matrices, reduction, eigen-solve) {t_ours:.3f} s (target ≤ 2 s) {absolute.mark}",
            f"  Exudyn (eigen call alone)                 {t_exudyn:.3f} s; ratio {t_ours / t_exudyn:.3f} "
            f"(target ≤ 0.5) {ratio.mark}",
            f"  frequencies agree within {spread:.1e} (lumped against consistent mass)"]
