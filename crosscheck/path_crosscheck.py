"""``flexmbs crosscheck`` on an arc-length deck: the pre-limit path against Exudyn's static solver.

Exudyn has no arc-length method (load stepping only), so the comparison stops short of the first limit point:

* flexmbs traces the deck's path (``algorithm = "arc_length"``) and finds its first critical load factor λc;
* Exudyn's static solver steps the same loads (the load factor is its time, the deck's time functions follow it)
  from 0 to ``FRACTION`` × λc in :data:`STEPS` equal steps, with its geometrically exact beam
  (``ObjectBeamGeometricallyExact``, linear interpolation like Beam2) on a mesh of :data:`REFINE` × the deck's
  elements per beam — converged meshes of two element families, since Exudyn has no beam3 or beam2_se3;
* at every flexmbs point of the rising branch below that load the positions of the named nodes (``[[nodes]]``:
  the same material points in both meshes, unlike ``BEAM:i``) are compared with Exudyn's, interpolated in the load factor by a cubic
  spline through its dense steps.  Judged: the largest distance over the model size against :data:`TOLERANCE`.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from crosscheck.exudyn_model import Unsupported

FRACTION = 0.9
"""Exudyn's load steps end at this fraction of the first critical load factor (its Newton turns singular at it)."""
STEPS = 30
"""Exudyn's equal load steps from 0 to ``FRACTION`` × λc."""
REFINE = 1
"""Exudyn's elements per deck element (a deck of another family needs about 8 × beam3's elements to converge alike)."""
TOLERANCE = 5e-4
"""Judged largest position difference over the model size (the diagonal of the initial bounding box).  The two
discretisations differ by their mesh errors: on Lee's frame (``models/lee_frame.toml``: beam3, 5 elements per leg;
Exudyn's linear beam with 40) measured 6.1e-5, and 9.9e-4 with Exudyn's mesh halved (``refine = 4``: its second-order
error dominates) — the bound is the converged mesh's difference with a margin for the deck's own mesh error."""


def is_path(domain) -> bool:
    """Whether the deck's algorithm traces an equilibrium path (arc length)."""
    from reference.algorithms import ArcLength

    return isinstance(domain.algorithm(), ArcLength)


def exudyn_domain(deck, overrides: dict, refine: int, load_factor: float, steps: int):
    """The deck for Exudyn: every flexible beam as Beam2 at ``refine`` × its elements, the static algorithm from
    0 to ``load_factor`` in ``steps`` steps."""
    from reference.algorithms import SolverSettings
    from reference.io.deck import load_deck

    beams = tomllib.loads(Path(deck).read_text(encoding="utf-8")).get("beams", [])
    families = {f"beams.{i}.element": "beam2" for i, beam in enumerate(beams) if not beam.get("rigid", False)}
    domain = load_deck(deck, overrides={**overrides, **families, "refine": refine}).domain
    domain.solver = SolverSettings(algorithm="static", dt=load_factor / steps, t_end=load_factor, load_steps=steps)
    return domain


def run(deck, out, overrides: dict | None = None, refine: int = REFINE, progress=None, exudyn_progress=None) -> dict:
    """Trace the deck in flexmbs (``out/results_reference.h5``), step Exudyn's static solver to ``FRACTION`` × its
    first critical load factor (``out/results_exudyn.h5``) and compare.  ``overrides`` go to both decks (e.g.
    ``{"solver.max_points": 40}`` for a shorter path that still passes the first critical point); ``refine``
    multiplies Exudyn's elements (over the deck's, and its ``refine`` override).

    Returns a dict: ``critical`` (λc), ``load_factor`` (Exudyn's last), ``points`` (flexmbs points compared),
    ``nodes`` (their labels), ``difference`` (largest distance / size), ``size``, ``passed``, ``lines``,
    ``reference`` and ``exudyn`` (the results), ``exudyn_wall``.
    """
    from scipy.interpolate import CubicSpline

    from crosscheck.exudyn_model import solve as solve_exudyn
    from reference.io.deck import load_deck, warm_up

    overrides = dict(overrides or {})
    read = load_deck(deck, overrides=overrides or None)
    if not is_path(read.domain):
        raise Unsupported("not an arc-length deck")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    warm_up(deck, read.domain.solver.dt)
    ref = read.solve(results_path=out / "results_reference.h5", progress=progress)
    critical = np.asarray(ref.data("path/critical_load_factor"), dtype=float)
    lam = np.asarray(ref.data("path/load_factor"), dtype=float)
    if not len(critical) or not critical[0] > 0.0:
        raise Unsupported("the path has no critical point at a positive load factor: nothing bounds Exudyn's "
                          "load steps; compare a static deck instead")
    target = FRACTION * float(critical[0])
    ex_domain = exudyn_domain(deck, overrides, refine * int(overrides.get("refine", 1)), target, STEPS)
    ex = solve_exudyn(ex_domain, results_path=out / "results_exudyn.h5", progress=exudyn_progress)
    exr = ex["results"]
    first = int(np.argmax(np.diff(lam) <= 0.0)) if np.any(np.diff(lam) <= 0.0) else len(lam) - 1
    points = np.flatnonzero((np.arange(len(lam)) <= first) & (lam <= exr.time[-1]))
    nodes = [label for label in ref.labels if label in exr.labels and ":" not in label]  # the same material points
    x0 = ref.positions[0]
    size = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
    worst, where = 0.0, ("", 0.0)
    for label in nodes:
        spline = CubicSpline(exr.time, exr.position(label), axis=0)
        d = np.linalg.norm(ref.position(label)[points] - spline(lam[points]), axis=1)
        if d.max() / size > worst:
            worst, where = float(d.max() / size), (label, float(lam[points][int(np.argmax(d))]))
    passed = bool(worst <= TOLERANCE)
    lines = [f"flexmbs: arc length, {len(read.domain.elements)} elements ({read.domain.elements[0].formulation.family}),"
             f" first critical load factor {critical[0]:.6g}, solve {ref.wall_time:.2f} s; Exudyn {ex['exudyn_version']}:"
             f" {ex['algorithm']} to {target:.6g} ({FRACTION:g} of it), {len(ex_domain.elements)} elements "
             f"(ObjectBeamGeometricallyExact), solve {ex['wall_time']:.2f} s.",
             f"{len(points)} flexmbs points on the rising branch up to {target:.6g}, nodes {', '.join(nodes)}: largest "
             f"position difference {worst:.2e} of the size {size:.4g} (node {where[0]}, load factor {where[1]:.4g}); "
             f"tolerance {TOLERANCE:g}: {'pass' if passed else 'FAIL'}"]
    return {"critical": float(critical[0]), "load_factor": float(exr.time[-1]), "points": len(points), "nodes": nodes,
            "difference": worst, "size": size, "passed": passed, "lines": lines, "reference": ref, "exudyn": exr,
            "exudyn_wall": ex["wall_time"]}
