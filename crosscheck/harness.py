"""``flexmbs crosscheck``: one deck in both engines, compared, with a Markdown report and figures.

:func:`run` is the three steps: :func:`run_engines` (the reference, warm, and Exudyn on
the same deck), :func:`compare_runs` (the deck's ``[crosscheck]`` tables at this
refinement, or the default comparison) and :func:`render` (``crosscheck.md`` and the
figure).  The reference's printed solve time is warm: a two-step solve of the deck
(:func:`reference.io.deck.warm_up`) loads or compiles its kernels first; Exudyn's is
its solve call alone.

A model with elements of a family Exudyn has no counterpart for (``beam3``,
``beam2_se3``; :data:`crosscheck.exudyn_model.EXUDYN_ELEMENTS`) is cross-checked
on *converged meshes* (:func:`exudyn_overrides`): Exudyn runs the deck with those
beams as its own two-node beam, refined until converged, and the judged tables are
the deck's refined ones, whose tolerances are written for two answers near the
converged one.  Nodes are paired by label and initial position
(:func:`crosscheck.compare.compare`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.compare import compare, pointwise
from crosscheck.exudyn_model import EXUDYN_ELEMENTS, Unsupported, preflight
from crosscheck.exudyn_model import solve as solve_exudyn
from reference.observables import default_crosscheck, parse, wrap


class NoCheckAtRefine(ValueError):
    """The deck's ``[crosscheck]`` tables judge no run at the refinement asked for."""


def run(deck, out, refine: int = 1, exudyn_dt: float | None = None, t_end: float | None = None,
        progress=None, figures=None, exudyn_progress=None, element: str | None = None) -> dict:
    """Run ``deck`` with the reference and with Exudyn, compare, write ``out/crosscheck.md``.

    Returns the comparison dict (:func:`crosscheck.compare.compare`) with ``default``
    (no ``[crosscheck]`` table), ``markdown`` (the report's lines), ``figure``, the two
    results (``reference``, ``exudyn``), ``exudyn_wall`` and ``converged`` (Exudyn's refinement
    in a converged-mesh comparison, else ``None``).  The parameters are those
    of :func:`run_engines`; ``figures`` is the figure's folder (default ``out``).  At a
    refinement no table names the verdicts are empty (a convergence study reads the
    comparison's other numbers); the command refuses it first (:func:`check_refine`).
    """
    runs = run_engines(deck, out, refine, exudyn_dt, t_end, progress, exudyn_progress, element)
    cmp = compare_runs(runs)
    lines, figure = render(runs, cmp, out, figures)
    cmp.update(default=runs["default"], markdown=lines, figure=figure, reference=runs["reference"],
               exudyn=runs["exudyn"], exudyn_wall=runs["exudyn_run"]["wall_time"], converged=runs["converged"])
    return cmp


def check_refine(deck, refine: int, element: str | None = None) -> None:
    """Raise :class:`NoCheckAtRefine`, listing the deck's refinements, when its ``[crosscheck]`` tables judge
    no run at ``refine`` (a deck without tables gets the default comparison at any; a converged-mesh
    comparison, :func:`exudyn_overrides`, judges the deck's finest tables at any)."""
    from reference.io.deck import load_deck

    read = load_deck(deck, overrides=element_overrides(deck, element))
    if exudyn_overrides(read, 1)[1]:
        return
    tables = read.crosscheck
    refines = sorted({int(spec.get("refine", 1)) for spec in tables.values()})
    if tables and refine not in refines:
        raise NoCheckAtRefine(f"no [crosscheck] table has refine = {refine}: the deck's tables judge the runs at "
                              f"refine {', '.join(map(str, refines))}; use "
                              + " or ".join(f"--refine {r}" for r in refines))


def element_overrides(deck, element: str | None) -> dict:
    """The dotted overrides giving every flexible beam of ``deck`` the element family ``element``
    (``flexmbs crosscheck --element``; none for ``None``)."""
    if element is None:
        return {}
    from reference.io.deck_reader import read_toml

    beams = read_toml(Path(deck))[1].get("beams", [])
    return {f"beams.{k}.element": element for k, beam in enumerate(beams)
            if isinstance(beam, dict) and not beam.get("rigid", False)}


CONVERGED_REFINE = 8
"""Exudyn's least refinement of a model with beams of a family it lacks (:func:`exudyn_overrides`)."""


def exudyn_overrides(read, refine: int) -> tuple[dict, int | None]:
    """What Exudyn runs for the reference's deck ``read`` at ``refine``: the overrides and, for a converged-mesh
    comparison, the refinement of the deck's tables judged (``None``: same mesh, the tables at ``refine``).

    Exudyn has no element of the families outside :data:`~crosscheck.exudyn_model.EXUDYN_ELEMENTS`: a beam
    of such a family becomes Exudyn's two-node beam (``beams.K.element = "beam2"``), and every flexible beam
    is refined by the deck's finest ``[crosscheck]`` refinement, at least :data:`CONVERGED_REFINE` (8 for
    models/three_bar.toml: 32 coupler elements, 2 % of the deflection's peak from 16 elements), times
    ``refine``, so that both engines give their converged answers; the deck's finest tables judge them.
    """
    beams = {}
    for e in read.domain.elements:
        if e.formulation.family not in EXUDYN_ELEMENTS:
            beams.setdefault(e.label.rpartition("/")[0] or e.label, e.formulation.family)
    if not beams:
        return {"refine": refine}, None
    from reference.io.deck_reader import read_toml

    deck_beams = read_toml(Path(read.path))[1].get("beams", [])
    finest = max((int(spec.get("refine", 1)) for spec in read.crosscheck.values()), default=CONVERGED_REFINE)
    overrides = {"refine": refine * max(finest, CONVERGED_REFINE)}
    for k, beam in enumerate(deck_beams):
        if isinstance(beam, dict) and beam.get("label") in beams:
            overrides[f"beams.{k}.element"] = "beam2"
    return overrides, finest


def run_engines(deck, out, refine: int = 1, exudyn_dt: float | None = None, t_end: float | None = None,
                progress=None, exudyn_progress=None, element: str | None = None) -> dict:
    """Both engines on ``deck``: the results files ``out/results_reference.h5`` and ``results_exudyn.h5``.

    The explicit reference needs the step divided by ``refine`` (its critical step
    shrinks with the elements); Exudyn (and the implicit algorithms) keep the deck's
    step unless ``exudyn_dt`` is given.  The deck's algorithm is translated
    (:func:`crosscheck.exudyn_model.solver_settings`).  Returns a dict: ``deck`` (the
    reference's :class:`~reference.io.deck.Deck`), ``checks`` (the tables judged),
    ``default``, ``refine``, ``reference`` and ``exudyn`` (the results), ``exudyn_run``
    (:func:`crosscheck.exudyn_model.solve`'s dict), ``dt_exudyn``, ``converged`` (Exudyn's refinement in a
    converged-mesh comparison, :func:`exudyn_overrides`; else ``None``).  ``element``: every flexible
    beam's family in the reference (:func:`element_overrides`).
    """
    from reference.io.deck import load_deck, warm_up

    out = Path(out)
    overrides = {"refine": refine, **({"t_end": t_end} if t_end else {}), **element_overrides(deck, element)}
    read = load_deck(deck, overrides=overrides)
    if read.domain.algorithm().linearised:
        # a time-history comparison of a linearised deck would compare two unloaded states and pass
        raise Unsupported(f"algorithm = {read.domain.solver.algorithm!r} is a linearised analysis and this command "
                          "compares time histories; compare its frequencies with Exudyn's eigen-solver through "
                          "crosscheck.exudyn_modes.modes")
    ex_overrides, converged = exudyn_overrides(read, refine)
    judged = refine if converged is None else converged
    checks = {name: spec for name, spec in read.crosscheck.items() if int(spec.get("refine", 1)) == judged}
    ex_domain = load_deck(deck, overrides={**overrides, **ex_overrides}).domain
    preflight(ex_domain)  # refuse (one line) before running anything: untranslatable or refused by Exudyn
    out.mkdir(parents=True, exist_ok=True)
    warm_up(deck, read.domain.solver.dt, element_overrides(deck, element))
    ref = read.solve(results_path=out / "results_reference.h5", progress=progress)
    algo = read.domain.algorithm()
    # the deck's step: the explicit scheme's was divided by refine, an implicit one was kept
    dt_ex = exudyn_dt or read.domain.solver.dt * (refine if algo.explicit else 1)
    ex = solve_exudyn(ex_domain, dt=dt_ex, results_path=out / "results_exudyn.h5", progress=exudyn_progress, deck=read)
    return {"deck": read, "checks": checks if read.crosscheck else default_crosscheck(),
            "default": not read.crosscheck, "refine": refine,
            "reference": ref, "exudyn": ex["results"], "exudyn_run": ex, "dt_exudyn": dt_ex, "algorithm": algo,
            "converged": None if converged is None else ex_overrides["refine"]}


def compare_runs(runs: dict) -> dict:
    """The verdicts of the tables judged (:func:`crosscheck.compare.compare`) on the two results."""
    return compare(runs["reference"], runs["exudyn"], runs["checks"])


def render(runs: dict, cmp: dict, out, figures=None) -> tuple[list, Path]:
    """``out/crosscheck.md`` and the figure ``crosscheck_<name>[_refine<R>].png`` (in ``figures``, default
    ``out``); returns the Markdown lines and the figure's path."""
    read, ref, ex, refine = runs["deck"], runs["reference"], runs["exudyn_run"], runs["refine"]
    out, domain = Path(out), read.domain
    name = domain.name + (f"_refine{refine}" if refine != 1 else "")
    lines = [f"### Cross-check: `{Path(read.path).name}`" + (f", flexible beams refined ×{refine}" if refine != 1 else ""),
             "", f"Reference: {runs['algorithm'].name.replace('_', ' ')}, h = {domain.solver.dt:g}, solve "
             f"{ref.wall_time:.2f} s. Exudyn {ex['exudyn_version']}: {ex['algorithm']}, h = {runs['dt_exudyn']:g}, "
             f"{ex['steps']} steps, solve {ex['wall_time']:.2f} s. {cmp['nodes']} common nodes; characteristic "
             f"length {cmp['length']:.3g}.", "",
             *([f"Converged meshes: Exudyn has no element of the reference's family "
                f"({', '.join(sorted({e.formulation.family for e in domain.elements} - set(EXUDYN_ELEMENTS)))}); "
                f"its run is the deck with every flexible beam in its own two-node beam, refined ×{runs['converged']}, "
                "and the two converged answers are compared (the deck's finest tables), nodes paired by initial "
                "position.", ""] if runs.get("converged") else []),
             f"Node trajectories: max position difference {cmp['position_max']:.3e} ({cmp['position_max_relative']:.2e} "
             f"of the length), RMS {cmp['position_rms']:.3e}; max rotation difference {cmp['rotation_max']:.3e} rad.", "",
             "| constraint drift | reference | Exudyn |", "|---|---|---|",
             f"| max ‖Φ‖ | {cmp['drift']['a']['violation_max']:.2e} | {cmp['drift']['b']['violation_max']:.2e} |",
             f"| max ‖B V + Φ_t‖ | {cmp['drift']['a']['velocity_violation_max']:.2e} | "
             f"{cmp['drift']['b']['velocity_violation_max']:.2e} |", "",
             *([f"The deck has no `[crosscheck]` table: default comparison of every node's position "
                f"(tolerance {runs['checks']['all_nodes']['tolerance']:g} of the length).", ""] if runs["default"] else []),
             "| observable | max difference | RMS | relative to | measure | tolerance | result | reason |",
             "|---|---|---|---|---|---|---|---|"]
    for v in cmp["verdicts"]:
        lines.append(f"| {v.observable} | {v.max_difference:.3e} | {v.rms_difference:.3e} | {v.relative_to} "
                     f"({v.scale:.3g}) | {v.measure:.3e} | {v.tolerance:g} | {'pass' if v.passed else '**FAIL**'} | {v.reason} |")
    figure = Path(figures or out) / f"crosscheck_{name}.png"
    _figure(cmp, ref, runs["exudyn"], bool(domain.model.n_constraints), name, figure)
    lines += ["", f"![cross-check]({'figures/' if figures else ''}{figure.name})", ""]
    (out / "crosscheck.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return lines, figure


def _figure(cmp: dict, ref, exr, joints: bool, name: str, figure: Path) -> None:
    """One panel per observable judged (both engines and their difference), the energies, and the drift."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    specs = list(dict.fromkeys(v.observable for v in cmp["verdicts"]))
    rows = len(specs) + 1 + joints
    fig, axes = plt.subplots(rows, 1, figsize=(6.4, 2.3 * rows + 0.5), sharex=True, squeeze=False)
    for ax, spec in zip(axes[:, 0], specs):
        obs = parse(spec, ref)
        va, vb = obs.evaluate(ref), parse(spec, exr).evaluate(exr)
        flat = vb.reshape(len(exr.time), -1)
        vb_on = np.stack([np.interp(ref.time, exr.time, c) for c in flat.T], axis=-1).reshape((len(ref.time),) + vb.shape[1:])
        twin = ax.twinx()
        if va.ndim > 1:
            # what the verdict judges: the norm of the vector difference (the largest node's for position:*)
            ax.plot(ref.time, pointwise(va - va[0]), label="reference |x − x(0)|")
            ax.plot(exr.time, pointwise(vb - vb[0]), "--", label="Exudyn |x − x(0)|")
            twin.plot(ref.time, pointwise(va - vb_on), "r:", label="|x_ref − x_Exudyn| (judged)")
            ax.set_ylabel(f"{spec}\nchange [{obs.unit}]", fontsize=8)
        else:
            diff = wrap(va - vb_on) if obs.is_angle else va - vb_on
            ax.plot(ref.time, va, label="reference")
            ax.plot(exr.time, vb, "--", label="Exudyn")
            twin.plot(ref.time, diff, "r:", label="reference − Exudyn (judged)")
            ax.set_ylabel(f"{spec} [{obs.unit}]", fontsize=8)
        twin.set_ylabel(f"difference [{obs.unit}]", fontsize=8, color="r")
        handles = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
        ax.legend(handles, [h.get_label() for h in handles], fontsize=7, loc="upper left")
    ax = axes[len(specs), 0]
    for key, style in (("kinetic", "-"), ("strain", "-.")):
        ax.plot(ref.time, ref.energy[key], style, label=f"{key} (reference)")
        ax.plot(exr.time, exr.energy[key], style, alpha=0.6, lw=2.5, label=f"{key} (Exudyn)")
    ax.set_ylabel("energy [J]", fontsize=8)
    ax.legend(fontsize=7)
    if joints:
        ax = axes[-1, 0]
        ax.semilogy(ref.time[1:], np.maximum(ref.constraint_violation[1:], 1e-17), label="‖Φ‖ reference")
        ax.semilogy(exr.time[1:], np.maximum(exr.constraint_violation[1:], 1e-17), "--", label="‖Φ‖ Exudyn")
        ax.set_ylabel("constraint\nviolation [m]", fontsize=8)
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("time t [s]")
    axes[0, 0].set_title(f"Cross-check {name}: reference engine and Exudyn", fontsize=10)
    fig.tight_layout()
    fig.savefig(figure, dpi=120)
    plt.close(fig)
