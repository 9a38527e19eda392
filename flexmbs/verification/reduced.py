"""The report's section "Reduced bodies" (issue 39): the issue's checks of the reduced flexible bodies.

Each check runs decks of ``models/`` (or a variant written next to the report's runs, :func:`variant`) on the
reference path, where reduced bodies run:

- the modes of ``models/cantilever_modes.toml`` reduced to 6 fixed-interface modes at the clamp against the full
  mesh's (the reduction of a linear model is exact in its kept modes);
- ``models/three_bar_reduced.toml`` against ``models/three_bar.toml`` (the coupler's mid-span deflection, 1 % of
  its peak over 10 s; over 0.5 s in ``--quick``), and against Exudyn's ``ObjectFFRFreducedOrder`` built from the
  same modes and invariants (:mod:`crosscheck.exudyn_reduced`);
- ``models/rotating_blade_reduced.toml``, the spin-up, with and without stiffening against the full beam (the
  stiffened tip within 2 % of the peak tip deflection; the unstiffened model's divergence stated) — not in
  ``--quick``.

:func:`report_section` returns the section's lines and its check rows, ``(name, reference, computed, tolerance,
why)`` each (the report's :class:`flexmbs.report.Check`).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

MODELS = Path(__file__).resolve().parents[2] / "models"
DECKS = ("three_bar_reduced.toml", "rotating_blade_reduced.toml")
"""The decks this section runs (the report's per-deck sections leave them out)."""
QUICK_HORIZON = 0.5
"""The three-bar's horizon in ``--quick`` [s] (the reference path's explicit reduced run costs ~30 ms a step)."""
FULL_HORIZON = 2.0
"""The three-bar's horizon in the full report [s] (the reduced run costs ~15 s a simulated second): the
third-order reduced coupler within 1 % of the full beam (0.14 % measured; 0.92 % at 10 s, docs/benchmarks.md)."""


def variant(deck: Path, folder: Path, name: str, reduce: str | None = None, drop_reduce: bool = False) -> Path:
    """A copy of ``deck`` in ``folder`` as ``name``.toml: the first ``[[beams]]`` entry given ``reduce`` (its inline
    table's text, on the reference path: a backend line the deck has is replaced), or every ``reduce`` line dropped
    with the backend line (the full beam, compiled)."""
    text = deck.read_text(encoding="utf-8")
    if drop_reduce:
        text = re.sub(r"(?m)^(reduce|backend) = .*\n", "", text)
    if reduce is not None:
        text = re.sub(r"(?m)^(section = .*\n)", rf"\1reduce = {reduce}\n", text, count=1)
        text = re.sub(r"(?m)^backend = .*\n", "", text)
        text = re.sub(r"(?m)^\[solver\]\n", '[solver]\nbackend = "reference"\n', text, count=1)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def modes_check(folder: Path):
    """The clamped-free beam reduced with 6 modes: its frequencies against the full mesh's."""
    from reference.io.deck import load_deck

    deck = MODELS / "cantilever_modes.toml"
    reduced = variant(deck, folder, "cantilever_modes_reduced", '{ modes = 6, interfaces = ["beam:start"] }')
    f_red = load_deck(reduced, {"solver.modes": 6}).solve().data("modes/frequency")
    f_full = load_deck(deck, {"solver.backend": "reference"}).solve().data("modes/frequency")[:6]
    error = float(np.abs(f_red / f_full - 1).max())
    lines = [f"Clamped-free beam (`models/cantilever_modes.toml`, 32 elements) reduced to 6 fixed-interface modes at "
             f"its clamp: frequencies {', '.join(f'{f:.6g}' for f in f_red)} Hz, the full mesh's "
             f"{', '.join(f'{f:.6g}' for f in f_full)} Hz (the first three bending modes among them).", ""]
    return lines, [("reduced cantilever: 6 kept frequencies", "the full mesh's modes", error, 1e-6,
                         "the reduction of a linear model is exact in its kept modes; 1e-6 leaves room for the eigen-solver's round-off "
                         "(the shift-invert solver's digits)")]


def deflection_gap(a, b, beam: str = "coupler") -> tuple[float, float]:
    """``max‖d_a − d_b‖ / max‖d_a‖`` of the mid-span deflections of ``beam`` in two results on the same output
    times, and the peak ``max‖d_a‖`` [m]."""
    from reference.observables import parse

    da = parse(f"midspan_deflection:{beam}", a).evaluate(a)
    db = parse(f"midspan_deflection:{beam}", b).evaluate(b)
    peak = float(np.linalg.norm(da, axis=1).max())
    return float(np.linalg.norm(da - db, axis=1).max()) / peak, peak


def three_bar_checks(folder: Path, horizon: float):
    """The reduced three-bar against the full beam and against Exudyn's reduced body, to ``horizon`` [s].

    The check against the full beam takes the modes' second- and third-order stiffness (``reduce.second_order``,
    ``reduce.third_order``): the coupler's axial force, up to 7 % of its Euler load, and its shortening by its own
    bending change its bending stiffness in the full beam, which linear modes leave out; the linear modes' gap is
    stated beside it, measured (docs/benchmarks.md, reduced bodies)."""
    from crosscheck.exudyn_reduced import solve as solve_exudyn
    from crosscheck.reduced_crosscheck import bodies_of, default_checks, judged, verdicts
    from reference.io.deck import load_deck

    deck = MODELS / "three_bar_reduced.toml"
    reduced = load_deck(deck, {"t_end": horizon}).solve()
    third = load_deck(deck, {"t_end": horizon, "beams.1.reduce.second_order": True,
                             "beams.1.reduce.third_order": True}).solve()
    full = load_deck(MODELS / "three_bar.toml", {"t_end": horizon}).solve()
    linear, peak = deflection_gap(full, reduced)
    gap, _ = deflection_gap(full, third)
    domain, bodies = bodies_of(deck, {"t_end": horizon})
    (verdict,) = verdicts(judged(default_checks(bodies), bodies), reduced, solve_exudyn(domain, bodies))
    lines = [f"Three-bar, coupler reduced (4 Beam2, 2 interfaces, 4 modes; `models/three_bar_reduced.toml`) over "
             f"{horizon:g} s: peak mid-span deflection {peak:.4e} m (full beam); reduced against full "
             f"{gap:.2e} of the peak with the modes' second- and third-order stiffness, {linear:.2e} with linear "
             f"modes (over 10 s: 0.92 % and 8.7 %; 1.7 % with the second order alone: the linear modes lack the effect "
             f"of the axial force and of the coupler's own shortening on its bending stiffness); Exudyn's "
             f"`ObjectFFRFreducedOrder` (same modes and invariants) against flexmbs's reduced run "
             f"{verdict.measure:.2e} of the peak. Mode counts 2 to 18, modes named by number and the modes' modal "
             f"derivatives (`reduce.modal_derivatives`: over 10 s 0.89 %, 0.091 % and 1.6e-6 with 2, 4 and 8 "
             f"modes): docs/benchmarks.md.",
             ""]
    return lines, [
        (f"reduced three-bar, third-order modes: coupler deflection ({horizon:g} s)",
         "full geometrically exact coupler", gap, 0.01,
         "the reduced coupler with the second- and third-order modal stiffness follows the full beam's mid-span "
         "deflection within 1 % of its peak (a drift grows with time: 0.92 % at 10 s, measured)"),
        (f"reduced three-bar in Exudyn ({horizon:g} s)", "Exudyn ObjectFFRFreducedOrder", verdict.measure, 0.01,
         "the same reduced body in both engines: only the time integration and round-off differ (measured below 1e-5 of the peak)")]


def tip_in_hub(results, hub: str = "blade:start", tip: str = "blade:end") -> np.ndarray:
    """The tip's position relative to the hub node, in the hub node's frame (n_t, 3) [m]: its lead-lag deflection
    is the component along the hub frame's y."""
    from reference.reduced.craig_bampton import rotation_matrices

    A = rotation_matrices(np.asarray(results.rotation(hub), dtype=float))
    return np.einsum("tba,tb->ta", A, results.position(tip) - results.position(hub))


def spinup_checks(folder: Path):
    """The spin-up: the reduced blade with and without stiffening against the full beam (lead-lag tip deflection),
    run by flexmbs and, with flexmbs's modes and stress stiffness, by Exudyn (:mod:`crosscheck.exudyn_spinup`)."""
    from crosscheck.exudyn_spinup import spinup
    from reference.io.deck import load_deck
    from reference.errors import SolverDiverged

    deck = MODELS / "rotating_blade_reduced.toml"
    full = tip_in_hub(load_deck(variant(deck, folder, "rotating_blade_full", drop_reduce=True)).solve())[:, 1]
    peak = float(np.abs(full).max())
    try:
        gap = float(np.abs(tip_in_hub(load_deck(deck).solve())[:, 1] - full).max()) / peak
        ran = f"flexmbs's stiffened reduced blade within {gap:.2e} of that peak"
    except SolverDiverged as exc:
        gap, ran = float("inf"), f"flexmbs's stiffened reduced run stopped ({str(exc).splitlines()[0]})"
    exudyn = float(np.abs(spinup(deck, stiffening=True)["lag"] - full).max()) / peak
    loose = float(np.abs(spinup(deck, stiffening=False, t_end=10.0)["lag"]).max()) / peak
    lines = [f"Spin-up (`models/rotating_blade_reduced.toml`, 0 → 6 rad/s in 15 s, 8 elements, 8 modes): peak "
             f"lead-lag tip deflection {peak:.4e} m (full beam); {ran}; Exudyn's reduced blade with flexmbs's modes "
             f"and stress stiffness within {exudyn:.2e}. Without stiffening the linear modes soften past "
             f"Ω = 3.52 rad/s: by 10 s the tip deflection is {loose:.3g} × the full beam's peak (Exudyn).", ""]
    why = "the centrifugal stress stiffness restores what linear modes lose to the spin: the stiffened reduced blade follows the full beam within 2 % of the peak tip deflection"
    return lines, [("reduced spin-up, stiffened: tip deflection", "full geometrically exact blade", gap, 0.02, why),
                   ("reduced spin-up in Exudyn, stiffened", "full geometrically exact blade", exudyn, 0.02, why)]


def report_section(quick: bool, out: Path) -> tuple[list[str], list]:
    """The section's Markdown lines and its check rows (module docstring); ``out`` holds the deck variants."""
    folder = Path(out) / "reduced"
    lines = ["## Reduced bodies", "",
             "A beam marked `reduce` becomes a floating frame plus Craig–Bampton modes from the project's own "
             "linearisation (`reference/reduced/`), run on the reference path. Checks: the kept modes "
             "exact; the reduced three-bar against the full beam and against Exudyn's reduced body; the spin-up "
             "with geometric stiffening" + (" (not in --quick)." if quick else "."), ""]
    checks = []
    parts = [modes_check, lambda f: three_bar_checks(f, QUICK_HORIZON if quick else FULL_HORIZON)]
    if not quick:
        parts.append(spinup_checks)
    for part in parts:
        more, found = part(folder)
        lines += more
        checks += found
    return lines, checks
