"""``make bench``: work–precision across element families.

For the static roll-up, the static 45° bend and the three-bar mechanism's coupler, each element
family on a series of meshes: the error against an analytic or converged reference, the degrees of
freedom and the warm solve time (every mesh is solved once, then timed :data:`REPEAT` times and the
fastest kept: numba's compilation and the model's set-up are excluded).  The references:

* roll-up (models/embedded_beam_static.toml to k = 1, the half circle, 4 load steps): the elastica's
  tip, a circular arc (:func:`flexmbs.verification.analytic.elastica_tip`), exact;
* 45° bend (Bathe & Bolourchi 1979, P = 600, :func:`flexmbs.verification.families.bend_domain`):
  no closed form; ``beam3`` in :data:`BEND_REFERENCE` elements (fourth order: its own error is
  far below the table's, and the table prints the finest beam3 rows' change to show it);
* three-bar coupler (models/three_bar.toml, generalized-α at h = 2e-3 to t = 4 s, the spin-up
  and two seconds of steady crank speed): the coupler's mid-span deflection history against
  ``beam3`` in :data:`COUPLER_REFERENCE` elements at the same step, so the error is the
  spatial one alone.

Errors are the tip's distance (the deflection's largest difference over the run) over the
length of the beam (10 m, 100 m, 5 m).  The target: at 1e-6 L on the roll-up or the
45° bend the best family is at least 10 times cheaper in wall time than Beam2.

:func:`coupler_crosscheck` is the three-bar with a beam3 coupler against Exudyn over the full 10 s,
on converged meshes (:mod:`crosscheck.harness`).
"""

from __future__ import annotations

import functools
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1e-6
"""The error [fraction of the length] of the target."""
BEND_REFERENCE = 128
COUPLER_REFERENCE = 32
COUPLER = {"dt": 2e-3, "t_end": 4.0}

MESHES = {
    "roll-up": {"beam2": (16, 64, 256, 1024), "beam2_se3": (2, 4, 8), "beam3": (4, 8, 16, 32, 64)},
    "45° bend": {"beam2": (8, 32, 128, 512), "beam2_se3": (8, 32, 128, 512), "beam3": (2, 4, 8, 16, 32)},
    "three-bar coupler": {"beam2": (4, 8, 16, 32), "beam2_se3": (4, 8, 16, 32), "beam3": (2, 4, 8)},
}
"""Meshes (element counts) per study and family (the helicoid is exact on the roll-up from 2 elements on)."""
QUICK_MESHES = {
    "roll-up": {"beam2": (64, 1024), "beam2_se3": (2,), "beam3": (4, 8)},
    "45° bend": {"beam2": (8, 32), "beam2_se3": (8, 32), "beam3": (2, 4)},
    "three-bar coupler": {"beam2": (4, 8), "beam2_se3": (4, 8), "beam3": (2, 4)},
}


def rollup_domain(family: str, n: int):
    from reference.io.deck import load_deck

    return load_deck(ROOT / "models" / "embedded_beam_static.toml",
                            overrides={"beams.0.elements": n, "beams.0.element": family, "solver.t_end": 1.0,
                                       "solver.load_steps": 4, "solver.tolerance": 1e-12}).domain


def coupler_domain(family: str, n: int):
    from reference.io.deck import load_deck

    return load_deck(ROOT / "models" / "three_bar.toml",
                            overrides={"beams.1.elements": n, "beams.1.element": family,
                                       "solver.algorithm": "generalized_alpha", "solver.dt": COUPLER["dt"],
                                       "solver.t_end": COUPLER["t_end"], "solver.output_every": 5}).domain


def _tip(results) -> np.ndarray:
    beam = [lbl for lbl in results.labels if lbl.rpartition(":")[2].isdigit()]
    return results.position(max(beam, key=lambda lbl: int(lbl.rpartition(":")[2])))[-1]


@functools.lru_cache(maxsize=None)
def _bend_reference() -> tuple:
    from flexmbs.verification.families import bend_domain

    return tuple(_tip(bend_domain("beam3", BEND_REFERENCE).solve()))


@functools.lru_cache(maxsize=None)
def _coupler_reference() -> tuple:
    from flexmbs.verification.observables import midspan_deflection

    r = coupler_domain("beam3", COUPLER_REFERENCE).solve()
    return tuple(r.time), tuple(midspan_deflection(r))


def _rollup_error(results) -> float:
    from flexmbs.verification.analytic import elastica_tip

    return float(np.linalg.norm(_tip(results) - elastica_tip(10.0, 1.0)) / 10.0)


def _bend_error(results) -> float:
    return float(np.linalg.norm(_tip(results) - np.array(_bend_reference())) / 100.0)


def _coupler_error(results) -> float:
    from flexmbs.verification.observables import midspan_deflection

    times, ref = (np.array(v) for v in _coupler_reference())
    if len(results.time) != len(times) or not np.allclose(results.time, times, rtol=0, atol=1e-9):
        raise ValueError("the three-bar runs must share their output times")
    return float(np.max(np.abs(midspan_deflection(results) - ref)) / 5.0)


def _bend(family: str, n: int):
    from flexmbs.verification.families import bend_domain

    return bend_domain(family, n)


STUDIES = {"roll-up": (rollup_domain, _rollup_error), "45° bend": (_bend, _bend_error),
           "three-bar coupler": (coupler_domain, _coupler_error)}
"""Study → (domain(family, n), error(results) as a fraction of the length)."""


REPEAT = 3
"""Timed solves per mesh after the first (the fastest is kept: the machine is shared)."""


def run_mesh(study: str, family: str, n: int, timed: bool = True) -> dict:
    """One mesh: error, degrees of freedom (6 per node of the model) and, ``timed``, the warm solve time [s]
    (the fastest of :data:`REPEAT` solves of the same domain after a first one that compiles)."""
    build, error = STUDIES[study]
    d = build(family, n)
    r = d.solve()
    walls = []
    for _ in range(REPEAT if timed else 0):
        t0 = time.perf_counter()
        r = d.solve()
        walls.append(time.perf_counter() - t0)
    wall = min(walls, default=math.nan)
    return {"study": study, "family": family, "n": n, "dofs": 6 * len(d.nodes), "error": error(r), "wall": wall}


def work_precision(quick: bool = False, timed: bool = True) -> list[dict]:
    """Every mesh of :data:`MESHES` (``quick``: :data:`QUICK_MESHES`), one row dict each."""
    meshes = QUICK_MESHES if quick else MESHES
    return [run_mesh(study, family, n, timed) for study, per in meshes.items() for family, ns in per.items()
            for n in ns]


def cheapest(rows: list[dict], target: float = TARGET):
    """The smallest warm time [s] of a row whose error is at most ``target``, or ``None``."""
    walls = [r["wall"] for r in rows if r["error"] <= target]
    return min(walls) if walls else None


def target_lines(rows: list[dict], target: float = TARGET) -> tuple[list[str], float]:
    """Per study with a length target (roll-up, 45° bend): the cheapest run at ``target`` of each family and
    Beam2's time over the best family's; returns the lines and the larger ratio (a lower bound where
    Beam2 does not reach the target: its finest mesh's time)."""
    lines, best_ratio = [], math.nan
    for study in ("roll-up", "45° bend"):
        per = {f: [r for r in rows if r["study"] == study and r["family"] == f] for f in MESHES[study]}
        walls = {f: cheapest(rs, target) for f, rs in per.items() if rs}
        others = {f: w for f, w in walls.items() if f != "beam2" and w is not None}
        if not others or "beam2" not in per:
            continue
        best = min(others, key=others.get)
        beam2, bound = walls.get("beam2"), ""
        if beam2 is None:
            finest = max(per["beam2"], key=lambda r: r["n"])
            beam2, bound = finest["wall"], (f" at least (Beam2 does not reach it: {finest['error']:.1e} L at "
                                            f"{finest['n']} elements)")
        ratio = beam2 / others[best]
        best_ratio = ratio if math.isnan(best_ratio) else max(best_ratio, ratio)
        lines.append(f"- {study} at {target:g} L: {best} {others[best] * 1e3:.2f} ms, Beam2 {beam2 * 1e3:.1f} ms: "
                     f"{ratio:.0f}× cheaper{bound}")
    return lines, best_ratio


def table(rows: list[dict]) -> list[str]:
    """Markdown lines: every run, then the target lines."""
    lines = ["### Work–precision across element families", "",
             f"Warm solve times (each mesh solved once, then the fastest of {REPEAT} timed solves). Error over the "
             "length: roll-up against "
             "the elastica (exact), 45° bend against beam3 in "
             f"{BEND_REFERENCE} elements, three-bar coupler (mid-span deflection, generalized-α h = {COUPLER['dt']:g} to "
             f"t = {COUPLER['t_end']:g} s) against beam3 in {COUPLER_REFERENCE} elements at the same step.", "",
             "| study | family | elements | dofs | error / L | solve [s] |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['study']} | {r['family']} | {r['n']} | {r['dofs']} | {r['error']:.2e} | {r['wall']:.4f} |"
              for r in rows]
    found, _ = target_lines(rows)
    return lines + ["", *found, ""]


def figure(rows: list[dict], path: Path) -> Path:
    """Error against degrees of freedom and against solve time, one row of panels per study."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    studies = list(dict.fromkeys(r["study"] for r in rows))
    fig, axes = plt.subplots(len(studies), 2, figsize=(9.0, 2.9 * len(studies)), squeeze=False)
    for (ax_n, ax_t), study in zip(axes, studies):
        for family in dict.fromkeys(r["family"] for r in rows):
            sel = [r for r in rows if r["study"] == study and r["family"] == family]
            err = [max(r["error"], 1e-16) for r in sel]
            ax_n.loglog([r["dofs"] for r in sel], err, "o-", label=family)
            ax_t.loglog([r["wall"] for r in sel], err, "o-", label=family)
        for ax in (ax_n, ax_t):
            if study != "three-bar coupler":
                ax.axhline(TARGET, color="k", lw=0.6, ls=":")
            ax.set_ylabel(f"{study}\nerror / L", fontsize=8)
        ax_n.set_xlabel("degrees of freedom", fontsize=8)
        ax_t.set_xlabel("warm solve time [s]", fontsize=8)
        ax_n.legend(fontsize=7)
    fig.suptitle("Work–precision across element families (dotted: 1e-6 L)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def coupler_crosscheck(out: Path, t_end: float | None = None) -> tuple[list[str], float]:
    """``flexmbs crosscheck models/three_bar.toml --element beam3`` (10 s): the beam3 coupler (4 elements)
    against Exudyn's own beam refined ×8, the deck's refine-8 tables judging (converged meshes).  Returns
    the Markdown lines (the harness's report: a verdict per table) and the largest verdict's measure over
    its tolerance (≤ 1: every table passes)."""
    from crosscheck.harness import run

    cmp = run(ROOT / "models" / "three_bar.toml", out, t_end=t_end, element="beam3")
    worst = max((v.measure / v.tolerance for v in cmp["verdicts"]), default=math.nan)
    return ["### Three-bar with a beam3 coupler against Exudyn (converged meshes)", "", *cmp["markdown"]], worst
