"""Modes of a clamped cantilever (``algorithm = "modes"``): bending in both planes against the Timoshenko
frequency equation, torsion and extension against the rod's closed form, the order of convergence."""

from __future__ import annotations

import numpy as np

FAMILIES = ("axial", "bending y", "bending z", "torsion")
"""Mode families of a straight beam along x, by the component that carries a mode's kinetic energy."""


def families(shapes, rhoA: float, rhoJ1: float) -> list[str]:
    """Each mode's family: the largest of ``√ρA |u_x|, √ρA |u_y|, √ρA |u_z|, √ρJ₁ |θ_x|`` over the nodes
    (the mass-weighted amplitudes of a beam along x; bending rotations follow their translations)."""
    weights = np.array([np.sqrt(rhoA)] * 3 + [np.sqrt(rhoJ1)])
    return [FAMILIES[int(np.argmax(np.abs(s[:, :4]).max(axis=0) * weights))] for s in shapes]


def references(sec, L: float, n: int) -> dict:
    """The closed-form frequencies [Hz] of each family (Timoshenko bending: z plane EI2 with GA3 and ρJ2,
    y plane EI3 with GA2 and ρJ3)."""
    from flexmbs.verification import analytic

    hz = 1.0 / (2.0 * np.pi)
    return {"bending z": hz * analytic.timoshenko_cantilever_frequencies(L, sec.EI2, sec.GA3, sec.rhoA, sec.rhoJ2, n),
            "bending y": hz * analytic.timoshenko_cantilever_frequencies(L, sec.EI3, sec.GA2, sec.rhoA, sec.rhoJ3, n),
            "torsion": hz * analytic.rod_frequencies(L, sec.GJ, sec.rhoJ1, n),
            "axial": hz * analytic.rod_frequencies(L, sec.EA, sec.rhoA, n)}


def errors(results, sec, L: float) -> dict:
    """Relative error of every computed mode against its family's closed form, by family (in order)."""
    f = results.data("modes/frequency")
    kind = families(results.data("modes/shape"), sec.rhoA, sec.rhoJ1)
    ref = references(sec, L, len(f))
    out = {}
    for family in FAMILIES:
        mine = f[[k for k, fam in enumerate(kind) if fam == family]]
        out[family] = mine / ref[family][: len(mine)] - 1.0
    return out


def evaluate(ctx):
    from flexmbs.verification.analytic import CANTILEVER_BETA_L

    domain = ctx.domain()
    sec = domain.elements[0].formulation.section
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    r = ctx.solve(domain, results_file=True)
    err = errors(r, sec, L)
    f, kind = r.data("modes/frequency"), families(r.data("modes/shape"), sec.rhoA, sec.rhoJ1)
    ref = references(sec, L, len(f))
    checks = [ctx.check("bending_z", "bending towards z, modes 1–3: max relative error", "Timoshenko frequency equation",
                        np.max(np.abs(err["bending z"][:3]))),
              ctx.check("bending_y", "bending towards y, modes 1–3: max relative error", "Timoshenko frequency equation",
                        np.max(np.abs(err["bending y"][:3]))),
              ctx.check("torsion", "first torsion mode, relative error", "π/(2L) √(GJ/ρJ₁)", abs(err["torsion"][0])),
              ctx.check("axial", "first axial mode, relative error", "π/(2L) √(EA/ρA)", abs(err["axial"][0]))]
    count = {family: 0 for family in FAMILIES}
    lines = ["| mode | family | frequency [Hz] | closed form [Hz] | relative error |", "|---|---|---|---|---|"]
    for k, (fk, fam) in enumerate(zip(f, kind)):
        exact = ref[fam][count[fam]]
        count[fam] += 1
        lines.append(f"| {k + 1} | {fam} {count[fam]} | {fk:.6f} | {exact:.6f} | {fk / exact - 1:+.2e} |")
    eb = [b**2 * np.sqrt(sec.EI2 / (sec.rhoA * L**4)) / (2 * np.pi) for b in CANTILEVER_BETA_L[:3]]
    lines += ["", "Euler–Bernoulli (βL = 1.8751, 4.6941, 7.8548) towards z: " + ", ".join(f"{e:.6f}" for e in eb)
              + " Hz; the Timoshenko frequencies lie below them by the shear and rotary inertia of the section.", ""]
    if not ctx.quick:
        lines += convergence(ctx, sec, L)
    return lines, checks


def convergence(ctx, sec, L: float) -> list[str]:
    """The bending errors on 32, 64 and 128 elements and the observed order."""
    studies = {}
    for refine in (1, 2, 4):
        studies[refine] = errors(ctx.solve(ctx.domain(refine=refine), f"×{refine}"), sec, L)
    lines = ["**Convergence** (relative errors; order log₂ of the ratio of successive errors):", "",
             "| mode | 32 elements | 64 | 128 | order |", "|---|---|---|---|---|"]
    for family in ("bending z", "bending y"):
        for k in range(3):
            e = [studies[r][family][k] for r in (1, 2, 4)]
            lines.append(f"| {family} {k + 1} | {e[0]:+.2e} | {e[1]:+.2e} | {e[2]:+.2e} | "
                         f"{np.log2(abs(e[1] / e[2])):.2f} |")
    return lines + [""]
