"""Modes of a cantilever in steady rotation (``about = "rotation"``): flapwise and lead-lag frequencies
against the published table of Hodges & Rutkowski (1981), the Campbell diagram over the table's spin rates."""

from __future__ import annotations

import numpy as np


def families(shapes) -> np.ndarray:
    """Each mode's plane for a beam along x spinning about z: ``"flap"`` (out of the plane of rotation, z)
    or ``"lag"`` (in-plane, y), by the larger of the node displacements (real and imaginary parts)."""
    amplitude = np.abs(shapes[:, :, :3]).max(axis=1)
    return np.where(amplitude[:, 2] >= amplitude[:, 1], "flap", "lag")


def published(lam: float, kind: str) -> np.ndarray:
    """The two lowest nondimensional frequencies of the table at λ (a table entry), flap or lag
    (``ω̄_lag² = ω̄_flap² − λ²``, docs/formulation.md §11)."""
    from flexmbs.verification.analytic import ROTATING_CANTILEVER_FLAP

    flap = np.array(ROTATING_CANTILEVER_FLAP[int(round(lam))])
    return flap if kind == "flap" else np.sqrt(flap**2 - lam**2)


def by_family(frequency_hz, shapes, scale: float) -> dict:
    """The computed nondimensional frequencies (ω × ``scale``, ``scale = √(ρA L⁴/EI)``) by family."""
    kind = families(shapes)
    w = 2.0 * np.pi * np.asarray(frequency_hz) * scale
    return {k: w[kind == k] for k in ("flap", "lag")}


def scales(domain) -> tuple[float, float]:
    """``√(ρA L⁴/EI)`` [s] (EI about the flapwise axis 2) and the length L of the deck's one beam."""
    sec = domain.elements[0].formulation.section
    L = float(np.linalg.norm(domain.nodes[-1].position - domain.nodes[0].position))
    return float(np.sqrt(sec.rhoA * L**4 / sec.EI2)), L


def evaluate(ctx):
    domain = ctx.domain()
    scale, _ = scales(domain)
    r = ctx.solve(domain, results_file=True)
    lam = float(r.data("modes/spin_rate")) * scale
    found = by_family(r.data("modes/frequency"), r.data("modes/shape"), scale)
    errors = {k: found[k][:2] / published(lam, k) - 1.0 for k in ("flap", "lag")}
    zeta = float(np.max(np.abs(r.data("modes/damping_ratio"))))
    checks = [ctx.check("flap", f"flapwise modes 1–2 at λ = {lam:g}: max relative error",
                        "Hodges & Rutkowski 1981", np.max(np.abs(errors["flap"]))),
              ctx.check("lag", f"lead-lag modes 1–2 at λ = {lam:g}: max relative error",
                        "√(ω̄_flap² − λ²), published ω̄_flap", np.max(np.abs(errors["lag"]))),
              ctx.check("undamped", "largest |damping ratio|", "0 (conservative)", zeta)]
    lines = ["| family | mode | ω̄ computed | ω̄ published | relative error |", "|---|---|---|---|---|"]
    for k in ("flap", "lag"):
        for j in range(2):
            lines.append(f"| {k} | {j + 1} | {found[k][j]:.5f} | {published(lam, k)[j]:.4f} | {errors[k][j]:+.2e} |")
    lines.append("")
    rates = np.arange(0, 13, 6 if ctx.quick else 1, dtype=float)
    lines += campbell_section(ctx, domain, rates / scale, scale)
    return lines, checks


def campbell_section(ctx, domain, rates, scale: float) -> list[str]:
    """The Campbell diagram of the deck over ``rates`` [rad/s] against the published points, and the largest
    errors over the range."""
    import matplotlib.pyplot as plt

    from flexmbs.campbell import campbell

    table = campbell(domain, rates, 4, shapes=True)
    lam = rates * scale
    worst = {"flap": 0.0, "lag": 0.0}
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for k, style in (("flap", "o"), ("lag", "s")):
        mine = np.array([by_family(f, s, scale)[k][:2] for f, s in zip(table.frequency, table.shapes)])
        ref = np.array([published(x, k) for x in lam])
        worst[k] = float(np.max(np.abs(mine / ref - 1.0)))
        for j in range(2):
            ax.plot(lam, mine[:, j], "-", color="C0" if k == "flap" else "C1",
                    label=f"flexmbs, {k}" if j == 0 else None)
            ax.plot(lam, ref[:, j], style, mfc="none", color="k", label=f"published, {k}" if j == 0 else None)
    ax.plot(lam, lam, ":", color="0.5", label="1P (ω = Ω)")
    ax.set_xlabel("spin rate λ = Ω √(ρA L⁴/EI)")
    ax.set_ylabel("frequency ω̄ = ω √(ρA L⁴/EI)")
    ax.legend(fontsize=7)
    figure = ctx.figure(fig, "rotating_cantilever_campbell.png",
                        "Campbell diagram of the rotating cantilever, flexmbs (lines) against Hodges & Rutkowski "
                        "1981 (flap) and √(ω̄² − λ²) (lag) (markers)")
    plt.close(fig)
    return [f"**Campbell diagram** ({len(rates)} spin rates, λ = {lam[0]:g} … {lam[-1]:g}; "
            f"`flexmbs campbell`): largest relative error of the two lowest flapwise modes {worst['flap']:.2e}, "
            f"lead-lag {worst['lag']:.2e} (second-order mesh error, largest for the second mode at λ = 12).", "",
            figure, ""]
