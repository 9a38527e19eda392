"""Rigid double pendulum (docs/benchmarks.md §3): energy and drift of the chaotic release; linear modes."""

from __future__ import annotations

import numpy as np

from flexmbs.deckchecks import crossings, energy_error, energy_panel, history_axes, inertia_about


def hanging_deck(deck, path, velocities) -> object:
    """The deck's bars hanging along −z, started at rest with body angular rates ``velocities`` (θ̇1, θ̇2) about y."""
    text = deck.read_text()
    swaps = [('start = [0.0, 0.0, 0.0]\nend = [1.0, 0.0, 0.0]', 'start = [0.0, 0.0, 0.0]\nend = [0.0, 0.0, -1.0]'),
             ('start = [1.0, 0.0, 0.0]\nend = [2.0, 0.0, 0.0]', 'start = [0.0, 0.0, -1.0]\nend = [0.0, 0.0, -2.0]'),
             ('point = [1.0, 0.0, 0.0]', 'point = [0.0, 0.0, -1.0]')]
    for old, new in swaps:
        assert old in text, old
        text = text.replace(old, new)
    w1, w2 = (float(w) for w in velocities)
    # rotation about +y: a point at depth c moves along −x at c θ̇; the body frame (e1 = −z, e2 = y) sees θ̇ about e2
    text = text.replace("[solver]", f"""[[initial_velocities]]
node = "upper"
velocity = [{-0.5 * w1!r}, 0.0, 0.0]
angular_velocity = [0.0, {w1!r}, 0.0]

[[initial_velocities]]
node = "lower"
velocity = [{-(1.0 * w1 + 0.5 * w2)!r}, 0.0, 0.0]
angular_velocity = [0.0, {w2!r}, 0.0]

[solver]""").replace("t_end = 3.0", "t_end = 6.0")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def evaluate(ctx):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmbs.verification.analytic import double_pendulum_frequencies
    from reference.io.deck import load_deck

    domain = ctx.domain()
    r = ctx.solve(domain, results_file=True)
    up, lo = domain.node("upper"), domain.node("lower")
    Jy = [inertia_about(b, [0.0, 1.0, 0.0]) for b in (up, lo)]
    omegas, modes = double_pendulum_frequencies(up.mass, 0.5, Jy[0], 1.0, lo.mass, 0.5, Jy[1], 9.81)
    measured = []
    runs = []
    for k in range(2):
        shape = modes[:, k] / np.max(np.abs(modes[:, k]))
        d = load_deck(hanging_deck(ctx.deck, ctx.out / f"double_pendulum_mode{k + 1}.toml", 1e-3 * omegas[k] * shape)).domain
        rm = ctx.solve(d, f"mode {k + 1}")
        c = rm.position("upper")
        theta1 = np.arctan2(-c[:, 0], -c[:, 2])
        ups = crossings(rm.time, theta1, direction=+1)
        measured.append(2 * np.pi / np.mean(np.diff(ups)))
        runs.append((rm, theta1))
    rel = np.abs(np.array(measured) / omegas - 1)
    checks = [ctx.check("energy", "chaotic release: |Δ(W_gravity − T)| / peak T", "0 (conservative)", energy_error(r)),
              ctx.check("drift", "chaotic release: max ‖Φ‖ [m]", "0", np.max(r.constraint_violation)),
              ctx.check("linear_modes", "mode 1 frequency, relative error", f"{omegas[0]:.6f} rad/s", rel[0]),
              ctx.check("linear_modes", "mode 2 frequency, relative error", f"{omegas[1]:.6f} rad/s", rel[1])]
    fig, axes = history_axes(plt, 3)
    for label in ("upper", "lower"):
        c = r.position(label)
        axes[0].plot(r.time, np.degrees(np.unwrap(np.arctan2(-c[:, 0], -c[:, 2]))), label=f"{label} bar (centre)")
    axes[0].set_ylabel("angle of the centre\nfrom −z [deg]")
    axes[0].legend(fontsize=7)
    axes[0].set_title("Double pendulum released from the horizontal; below: normal-mode runs", fontsize=10)
    energy_panel(axes[1], r)
    for k, (rm, th) in enumerate(runs):
        axes[2].plot(rm.time[rm.time <= r.time[-1]], 1e3 * th[rm.time <= r.time[-1]],
                     label=f"mode {k + 1}: ω = {measured[k]:.5f} (closed form {omegas[k]:.5f}) rad/s")
    axes[2].set_ylabel("upper bar angle,\nmode runs [mrad]")
    axes[2].legend(fontsize=7)
    lines = [ctx.figure(fig, "double_pendulum.png", "double pendulum"), "",
             "Normal modes of the hanging pendulum (closed form: eigenvalues of the linearised equations "
             "M θ̈ + K θ = 0): " + "; ".join(f"mode {k + 1} {omegas[k]:.6f} rad/s, measured {measured[k]:.6f}"
                                            for k in range(2)) + ".", ""]
    return lines, checks
