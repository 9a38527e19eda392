"""Lateral–torsional buckling of a tip-loaded cantilever (``algorithm = "buckling"``): the critical load against
the bifurcation of the Kirchhoff rod and the closed form with the pre-buckling factor; the order of convergence."""

from __future__ import annotations

import numpy as np


def stiffnesses(domain) -> tuple[float, float, float, float, float]:
    """``(A, B, C, L, P)``: in-plane (EI2), lateral (EI3) and torsional (GJ) stiffness [N m²], the length [m]
    and the tip load at ``t_end`` [N] (load factor 1)."""
    sec = domain.elements[0].formulation.section
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    P = float(sum(np.linalg.norm(load.vector) * load.time_function(domain.solver.t_end) for load in domain.loading))
    return sec.EI2, sec.EI3, sec.GJ, L, P


def critical_load(results, P: float) -> float:
    """The lowest buckling load factor times the tip load at ``t_end`` [N]."""
    return P * float(results.data("buckling/load_factor")[0])


def evaluate(ctx):
    from flexmbs.verification import analytic

    domain = ctx.domain()
    A, B, C, L, P = stiffnesses(domain)
    exact = analytic.lateral_buckling_cantilever(A, B, C, L)
    closed = analytic.lateral_buckling_closed_form(A, B, C, L)
    classical = 4.0126 * np.sqrt(B * C) / L**2
    P_cr = critical_load(ctx.solve(domain, results_file=True), P)
    checks = [ctx.check("rod_bifurcation", "critical tip load, relative error", "bifurcation of the Kirchhoff rod",
                        abs(P_cr / exact - 1.0)),
              ctx.check("closed_form", "critical tip load, relative error", "4.0126 √(BC)/L² / √((1 − B/A)(1 − C/A))",
                        abs(P_cr / closed - 1.0))]
    lines = ["| critical tip load [N] | value | flexmbs relative to it |", "|---|---|---|",
             f"| flexmbs, {len(domain.elements)} Beam2 elements | {P_cr:.6f} | |",
             f"| rod bifurcation from the planar elastica | {exact:.6f} | {P_cr / exact - 1:+.2e} |",
             f"| closed form with the pre-buckling factor | {closed:.6f} | {P_cr / closed - 1:+.2e} |",
             f"| classical 4.0126 √(BC)/L² (A → ∞) | {classical:.6f} | {P_cr / classical - 1:+.2e} |", ""]
    if not ctx.quick:
        lines += convergence(ctx, P, exact)
    return lines, checks


def convergence(ctx, P: float, exact: float) -> list[str]:
    """The critical load on the deck's mesh and two refinements against the rod's bifurcation; the order from the
    differences of successive meshes (it needs no limit) and the Richardson limit of second order."""
    loads = [critical_load(ctx.solve(ctx.domain(refine=r), f"×{r}"), P) for r in (1, 2, 4)]
    e = [p / exact - 1.0 for p in loads]
    order = np.log2((loads[0] - loads[1]) / (loads[1] - loads[2]))
    limit = loads[2] + (loads[2] - loads[1]) / 3.0
    n = len(ctx.domain().elements)
    return ["**Convergence** against the rod's bifurcation (order: log₂ of the ratio of successive differences):", "",
            f"| {n} elements | {2 * n} | {4 * n} | order | second-order limit |", "|---|---|---|---|---|",
            f"| {e[0]:+.2e} | {e[1]:+.2e} | {e[2]:+.2e} | {order:.2f} | {limit / exact - 1:+.2e} |", "",
            "The limit differs from the inextensible, unshearable rod's bifurcation by the model's finite EA "
            "and GA and the secant geometric stiffness (docs/formulation.md §11).", ""]
