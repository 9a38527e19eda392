"""The cross-check of a deck with reduced beams: flexmbs's reduced run against Exudyn's ``ObjectFFRFreducedOrder``.

Both engines run the same reduced body: :func:`run` reads the deck once, takes each reduced beam's
:class:`~reference.reduced.body.ReducedBody` (its modes and invariants, :mod:`reference.io.deck_reduce`), runs the
deck on flexmbs's reference path and the same bodies in Exudyn (:mod:`crosscheck.exudyn_reduced`), and judges the
deck's ``[crosscheck]`` tables whose observable is ``midspan_deflection:BEAM`` of a reduced beam (the mesh nodes
Exudyn reports are the reduced beam's; other observables need the full translation,
:mod:`crosscheck.harness`).  A deck without such a table is judged by :func:`default_checks`: every reduced beam's
mid-span deflection within 1 % of its peak, the target of issue 39.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.compare import Verdict, pointwise
from crosscheck.exudyn_model import Unsupported
from crosscheck.exudyn_reduced import midspan_deflection, solve

TOLERANCE = 0.01
"""The default table's tolerance, relative to the peak deflection (issue 39: the Exudyn cross-check of the reduced
three-bar within 1 % of the peak): both engines integrate one set of equations, so what differs is the time
integration (central difference or generalized-α in flexmbs, Exudyn's generalized-α) and the joints' rows."""


def is_reduced(path) -> bool:
    """Whether the deck at ``path`` marks a ``[[beams]]`` entry ``reduce`` (``flexmbs crosscheck`` then runs
    :func:`run`)."""
    from reference.io.deck_reader import read_toml

    beams = read_toml(Path(path))[1].get("beams", [])
    return any(isinstance(beam, dict) and "reduce" in beam for beam in beams)


def bodies_of(path, overrides: dict | None = None) -> tuple:
    """``(domain, bodies)``: the Domain of the deck at ``path`` and its reduced bodies, label →
    :class:`~reference.reduced.body.ReducedBody` (:func:`reference.io.deck_reduce.reduced_body`)."""
    from reference.io.deck import load_deck
    from reference.io.deck_reduce import collecting, reduced_body

    with collecting() as found:
        read = load_deck(path, overrides)
    return read.domain, {label: reduced_body(reduction) for label, reduction in found.items()}


def default_checks(bodies: dict) -> dict:
    """One table per reduced beam: its mid-span deflection within :data:`TOLERANCE` of the peak."""
    return {f"{label}_deflection": {"observable": f"midspan_deflection:{label}", "tolerance": TOLERANCE,
                                    "relative_to": "peak",
                                    "reason": "the same reduced body in both engines (crosscheck.reduced_crosscheck)"}
            for label in bodies}


def judged(checks: dict, bodies: dict) -> dict:
    """The tables of ``checks`` this comparison judges (observable ``midspan_deflection:BEAM`` of a reduced beam),
    name → ``(spec, beam)``; a ValueError of one line for a table it cannot judge."""
    out = {}
    for name, spec in checks.items():
        kind, _, beam = str(spec.get("observable", "")).partition(":")
        if kind != "midspan_deflection" or beam not in bodies or spec.get("relative_to", "peak") != "peak":
            raise Unsupported(f"[crosscheck.{name}]: the reduced cross-check judges midspan_deflection:BEAM of a "
                              f"reduced beam ({', '.join(bodies)}) relative to its peak; run the others through "
                              "flexmbs crosscheck on the full deck")
        out[name] = (spec, beam)
    return out


def verdicts(checks: dict, reference, exudyn: dict) -> list:
    """One :class:`~crosscheck.compare.Verdict` per table (:func:`judged`): ``‖d_flexmbs − d_Exudyn‖`` over the
    output times (Exudyn's interpolated onto flexmbs's), its maximum relative to the peak of ``‖d_flexmbs‖``."""
    from reference.observables import parse

    out = []
    for name, (spec, beam) in checks.items():
        a = parse(spec["observable"], reference).evaluate(reference)
        b = midspan_deflection(exudyn["positions"][beam])
        b = np.stack([np.interp(reference.time, exudyn["time"], c) for c in b.T], axis=1)
        diff = pointwise(a - b)
        out.append(Verdict(name, spec["observable"], float(diff.max()), float(np.sqrt(np.mean(diff ** 2))),
                           float(pointwise(a).max()), float(spec["tolerance"]), "peak", str(spec.get("reason", ""))))
    return out


def run(path, t_end: float | None = None, overrides: dict | None = None) -> dict:
    """Cross-check the deck at ``path`` (module docstring), to ``t_end`` (default the deck's).

    Returns ``verdicts`` (list of :class:`~crosscheck.compare.Verdict`), ``reference`` (flexmbs's
    :class:`~reference.io.results.Results`), ``exudyn`` (:func:`crosscheck.exudyn_reduced.solve`'s dict) and
    ``bodies``.

    Raises
    ------
    crosscheck.exudyn_model.Unsupported
        One line: a deck without reduced beams, a table this comparison cannot judge, or a model the
        translation refuses.
    """
    from reference.io.deck import load_deck

    overrides = {**(overrides or {}), **({"t_end": t_end} if t_end else {})}
    domain, bodies = bodies_of(path, overrides)
    if not bodies:
        raise Unsupported(f"{path}: no [[beams]] entry carries reduce; cross-check the deck with flexmbs crosscheck")
    read = load_deck(path, overrides)
    checks = judged(read.crosscheck or default_checks(bodies), bodies)
    exudyn = solve(domain, bodies)
    reference = read.solve()
    return {"verdicts": verdicts(checks, reference, exudyn), "reference": reference, "exudyn": exudyn,
            "bodies": bodies}
