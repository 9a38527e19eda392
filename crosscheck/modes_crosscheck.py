"""``flexmbs crosscheck`` on a modes deck: flexmbs' frequencies against Exudyn's eigen-solve of the same deck.

A modes deck has no time history to compare: the command solves the deck (``algorithm = "modes"``, about the
reference or the static equilibrium) and calls :func:`crosscheck.exudyn_modes.modes` on the same model twice:

* **Exudyn's stiffness with flexmbs' lumped mass** (``sparse=True, lumped_mass=True``; a deck with joints:
  the dense variant with the joints' reaction stiffness, ``joint_reactions=True``, and Exudyn's mass): the two
  elements' stiffness matrices are the same about an unstressed straight state (3e-11), so with the same mass
  the frequencies must agree — this comparison is judged, within :data:`TOLERANCE`;
* **Exudyn as it is** (its consistent beam mass): shown, not judged.  Exudyn's frequencies lie above by about
  ``(kh)²/12`` for a bending wave of wavenumber k on elements of length h (the module docstring of
  :mod:`crosscheck.exudyn_modes`), the difference between a consistent and a lumped mass.

Linear buckling and modes about a steady rotation are refused in one line (Exudyn has neither in this
translation).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.exudyn_model import Unsupported

TOLERANCE = 1e-3
"""Judged relative difference of each frequency (0.1 %).  With the same mass and stiffness the
two solves differ by the eigen-solvers' accuracy and the geometric stiffness of a pre-stress (second order in
the element size, the module docstring of :mod:`crosscheck.exudyn_modes`): measured 3.5e-12 on
``models/cantilever_modes.toml`` (its consistent-mass frequencies: +2.0e-4 to +1.8e-2)."""


def refusal(domain) -> str | None:
    """Why a linearised deck cannot be cross-checked here (None if it can)."""
    solver = domain.solver
    if solver.algorithm == "buckling":
        return ("linear buckling is not cross-checked: Exudyn has no linear buckling; compare a static load path "
                "with an imperfection in both engines instead")
    if solver.about == "rotation":
        return ("modes about a steady rotation are not cross-checked: Exudyn linearises about a state at rest, not in "
                "a spinning frame; the deck's checks compare with the published rotating-beam tables")
    return None


def run(deck, out, refine: int = 1, progress=None) -> dict:
    """Solve the modes deck in flexmbs (``out/results_reference.h5``) and in Exudyn; returns ``flexmbs``,
    ``same_mass``, ``consistent`` (frequencies [Hz] of the non-zero modes, the first n of each), ``variant``
    (what the judged Exudyn solve was), ``differences`` (judged, relative) and ``lines`` (the table)."""
    from crosscheck.exudyn_modes import modes
    from reference.io.deck import load_deck

    overrides = {"refine": refine}
    read = load_deck(deck, overrides=overrides)
    problem = refusal(read.domain)
    if problem:
        raise Unsupported(problem)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    r = read.solve(results_path=out / "results_reference.h5", progress=progress)
    elastic = np.asarray(r.data("modes/kind")) != "zero"
    mine = np.asarray(r.data("modes/frequency"))[elastic]
    n, about = len(mine), read.domain.solver.about
    zero = len(elastic) - n
    ex_domain = load_deck(deck, overrides=overrides).domain
    if ex_domain.joints:
        same = modes(ex_domain, n + zero, about, joint_reactions=True)
        variant = "Exudyn's matrices with the joints' reaction stiffness (dense), Exudyn's mass"
    else:
        same = modes(ex_domain, n + zero, about, sparse=True, lumped_mass=True)
        variant = "Exudyn's stiffness with flexmbs' lumped mass (sparse)"
    consistent = modes(load_deck(deck, overrides=overrides).domain, n + zero, about)
    same_f, cons_f = (np.sort(m.frequency)[zero:zero + n] for m in (same, consistent))
    differences = same_f / mine - 1.0
    lines = [f"{'mode':>4}  {'flexmbs [Hz]':>13}  {'Exudyn, same mass':>17}  {'difference':>10}  "
             f"{'Exudyn as is':>13}  {'difference':>10}"]
    lines += [f"{k + 1:>4}  {mine[k]:>13.6g}  {same_f[k]:>17.6g}  {differences[k]:>+10.2e}  {cons_f[k]:>13.6g}  "
              f"{cons_f[k] / mine[k] - 1:>+10.2e}" for k in range(n)]
    lines.append(f"same mass: {variant}; as is: Exudyn's consistent beam mass, its frequencies higher by about "
                 "(kh)²/12 for a bending wave of wavenumber k on elements of length h (not judged)")
    return {"flexmbs": mine, "same_mass": same_f, "consistent": cons_f, "variant": variant,
            "differences": differences, "lines": lines, "reference": r}
