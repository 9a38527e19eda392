"""``flexmbs crosscheck``: one deck in both engines, compared, with a Markdown report and figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.compare import compare, observable, _last_node
from crosscheck.exudyn_model import check_supported
from crosscheck.exudyn_model import solve as solve_exudyn


def run(deck, out, refine: int = 1, exudyn_dt: float | None = None, t_end: float | None = None,
        progress=None, figures=None, exudyn_progress=None) -> dict:
    """Run ``deck`` with the reference and with Exudyn, compare, write ``out/crosscheck.md``.

    The explicit reference needs the step divided by ``refine`` (its critical step
    shrinks with the elements); Exudyn (and the implicit algorithms) keep the deck's
    step unless ``exudyn_dt`` is given.  The deck's algorithm is translated (static →
    Exudyn's static solver, generalized-α → Exudyn's at the same ρ∞).  Returns the comparison dict with ``markdown``
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
    check_supported(ex_domain)  # refuse before running anything
    ref_domain = Domain.from_deck(deck, overrides=overrides)
    ref = ref_domain.solve(results_path=out / "results_reference.h5", progress=progress)
    algo = ref_domain.algorithm()
    # the deck's step: the explicit scheme's was divided by refine, an implicit one was kept
    dt_ex = exudyn_dt or ref_domain.solver.dt * (refine if algo.explicit else 1)
    ex = solve_exudyn(ex_domain, dt=dt_ex, results_path=out / "results_exudyn.h5", progress=exudyn_progress)
    exr = ex["results"]
    checks = {name: spec for name, spec in ref_domain.crosscheck.items() if int(spec.get("refine", 1)) == refine}
    cmp = compare(ref, exr, checks)
    name = ref_domain.name + (f"_refine{refine}" if refine != 1 else "")
    lines = [f"### Cross-check: `{Path(deck).name}`" + (f", flexible beams refined ×{refine}" if refine != 1 else ""), "",
             f"Reference: {algo.name.replace('_', ' ')}, h = {ref_domain.solver.dt:g}, solve {ref.wall_time:.2f} s. "
             f"Exudyn {ex['exudyn_version']}: {ex['algorithm']}, h = {dt_ex:g}, {ex['steps']} steps, solve "
             f"{ex['wall_time']:.2f} s. {cmp['nodes']} common nodes; characteristic length {cmp['length']:.3g}.", "",
             f"Node trajectories: max position difference {cmp['position_max']:.3e} ({cmp['position_max_relative']:.2e} "
             f"of the length), RMS {cmp['position_rms']:.3e}; max rotation difference {cmp['rotation_max']:.3e} rad.", "",
             "| constraint drift | reference | Exudyn |", "|---|---|---|",
             f"| max ‖Φ‖ | {cmp['drift']['a']['violation_max']:.2e} | {cmp['drift']['b']['violation_max']:.2e} |",
             f"| max ‖B V + Φ_t‖ | {cmp['drift']['a']['velocity_violation_max']:.2e} | "
             f"{cmp['drift']['b']['velocity_violation_max']:.2e} |", "",
             "| observable | max difference | RMS | relative to | measure | tolerance | result | reason |",
             "|---|---|---|---|---|---|---|---|"]
    for v in cmp["verdicts"]:
        lines.append(f"| {v.observable} | {v.max_difference:.3e} | {v.rms_difference:.3e} | {v.relative_to} "
                     f"({v.scale:.3g}) | {v.measure:.3e} | {v.tolerance:g} | {'pass' if v.passed else '**FAIL**'} | {v.reason} |")
    specs = list(dict.fromkeys(v.observable for v in cmp["verdicts"]))
    fig, axes = plt.subplots(len(specs) + 2, 1, figsize=(6.4, 2.4 * (len(specs) + 2)), sharex=True, squeeze=False)
    for ax, spec in zip(axes[:, 0], specs):
        va, vb = observable(ref, spec, _last_node(ref)), observable(exr, spec, _last_node(exr))
        if va.ndim == 2:
            va, vb = np.linalg.norm(va - va[0], axis=1), np.linalg.norm(vb - vb[0], axis=1)
            ax.set_ylabel("|Δ position|", fontsize=8)
        else:
            ax.set_ylabel(spec.split(":")[0], fontsize=8)
        ax.plot(ref.time, va, label="reference")
        ax.plot(exr.time, vb, "--", label="Exudyn")
        ax.plot(ref.time, va - np.interp(ref.time, exr.time, vb), ":", label="difference")
        ax.legend(fontsize=7)
    ax = axes[-2, 0]
    for key, style in (("kinetic", "-"), ("strain", "-.")):
        ax.plot(ref.time, ref.energy[key], style, label=f"{key} (reference)")
        ax.plot(exr.time, exr.energy[key], style, alpha=0.6, lw=2.5, label=f"{key} (Exudyn)")
    ax.set_ylabel("energy", fontsize=8)
    ax.legend(fontsize=7)
    ax = axes[-1, 0]
    ax.semilogy(ref.time[1:], np.maximum(ref.constraint_violation[1:], 1e-17), label="‖Φ‖ reference")
    ax.semilogy(exr.time[1:], np.maximum(exr.constraint_violation[1:], 1e-17), "--", label="‖Φ‖ Exudyn")
    ax.set_xlabel("t")
    ax.legend(fontsize=7)
    fig.tight_layout()
    figure = Path(figures or out) / f"crosscheck_{name}.png"
    fig.savefig(figure, dpi=120)
    plt.close(fig)
    lines += ["", f"![cross-check]({'figures/' if figures else ''}{figure.name})", ""]
    (out / "crosscheck.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    cmp.update(markdown=lines, figure=figure, reference=ref, exudyn=exr, exudyn_wall=ex["wall_time"])
    return cmp
