"""``flexmbs crosscheck``: one deck in both engines, compared, with a Markdown report and figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.compare import compare, pointwise
from crosscheck.exudyn_model import preflight
from crosscheck.exudyn_model import solve as solve_exudyn
from reference.observables import default_crosscheck, parse, wrap


def run(deck, out, refine: int = 1, exudyn_dt: float | None = None, t_end: float | None = None,
        progress=None, figures=None, exudyn_progress=None) -> dict:
    """Run ``deck`` with the reference and with Exudyn, compare, write ``out/crosscheck.md``.

    The reference needs the step divided by ``refine`` (its critical step
    shrinks with the elements); Exudyn's implicit solver keeps the deck's step
    unless ``exudyn_dt`` is given.  Returns the comparison dict with ``markdown``
    (the report's lines) and the two results.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reference.domain import Domain

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    overrides = {"refine": refine, **({"t_end": t_end} if t_end else {})}
    ex_domain = Domain.from_deck(deck, overrides=overrides)
    preflight(ex_domain)  # refuse (one line) before running anything: untranslatable or refused by Exudyn
    ref_domain = Domain.from_deck(deck, overrides=overrides)
    ref = ref_domain.solve(results_path=out / "results_reference.h5", progress=progress)
    dt_ex = exudyn_dt or ref_domain.solver.dt * refine
    ex = solve_exudyn(ex_domain, dt=dt_ex, results_path=out / "results_exudyn.h5", progress=exudyn_progress)
    exr = ex["results"]
    checks = {name: spec for name, spec in ref_domain.crosscheck.items() if int(spec.get("refine", 1)) == refine}
    default = not ref_domain.crosscheck
    if default:
        checks = default_crosscheck()
    cmp = compare(ref, exr, checks)
    name = ref_domain.name + (f"_refine{refine}" if refine != 1 else "")
    lines = [f"### Cross-check: `{Path(deck).name}`" + (f", flexible beams refined ×{refine}" if refine != 1 else ""), "",
             f"Reference: staggered central difference, h = {ref_domain.solver.dt:g}, solve {ref.wall_time:.2f} s. "
             f"Exudyn {ex['exudyn_version']}: generalized-α, h = {dt_ex:g}, {ex['steps']} steps, solve "
             f"{ex['wall_time']:.2f} s. {cmp['nodes']} common nodes; characteristic length {cmp['length']:.3g}.", "",
             f"Node trajectories: max position difference {cmp['position_max']:.3e} ({cmp['position_max_relative']:.2e} "
             f"of the length), RMS {cmp['position_rms']:.3e}; max rotation difference {cmp['rotation_max']:.3e} rad.", "",
             "| constraint drift | reference | Exudyn |", "|---|---|---|",
             f"| max ‖Φ‖ | {cmp['drift']['a']['violation_max']:.2e} | {cmp['drift']['b']['violation_max']:.2e} |",
             f"| max ‖B V + Φ_t‖ | {cmp['drift']['a']['velocity_violation_max']:.2e} | "
             f"{cmp['drift']['b']['velocity_violation_max']:.2e} |", "",
             *([f"The deck has no `[crosscheck]` table: default comparison of every node's position "
                f"(tolerance {checks['all_nodes']['tolerance']:g} of the length).", ""] if default else []),
             "| observable | max difference | RMS | relative to | measure | tolerance | result | reason |",
             "|---|---|---|---|---|---|---|---|"]
    for v in cmp["verdicts"]:
        lines.append(f"| {v.observable} | {v.max_difference:.3e} | {v.rms_difference:.3e} | {v.relative_to} "
                     f"({v.scale:.3g}) | {v.measure:.3e} | {v.tolerance:g} | {'pass' if v.passed else '**FAIL**'} | {v.reason} |")
    specs = list(dict.fromkeys(v.observable for v in cmp["verdicts"]))
    joints = bool(ref_domain.model.n_constraints)
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
    figure = Path(figures or out) / f"crosscheck_{name}.png"
    fig.savefig(figure, dpi=120)
    plt.close(fig)
    lines += ["", f"![cross-check]({'figures/' if figures else ''}{figure.name})", ""]
    (out / "crosscheck.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    cmp.update(default=default, markdown=lines, figure=figure, reference=ref, exudyn=exr, exudyn_wall=ex["wall_time"])
    return cmp
