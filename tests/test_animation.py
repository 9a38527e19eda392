"""``flexmbs plot --animate``: the animation draws the connectors and the ground, fitted to the motion.

No solve: the motion is the deck's initial configuration carried along a rigid translation and
rotation (every node moved alike), which is all the drawing reads from a results file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


def _moved(domain, n_frames=5, shift=(0.8, 0.0, -0.3), turn=0.4):
    """Results of the domain's nodes turned about z by up to ``turn`` [rad] and translated by up to ``shift`` [m]."""
    from reference.io.results import Results

    x0 = np.array([n.position for n in domain.nodes])
    q0 = np.array([n.rotation for n in domain.nodes])
    time = np.linspace(0.0, 1.0, n_frames)
    positions, rotations = [], []
    for s in time:
        c, h = np.cos(turn * s), 0.5 * turn * s
        A = np.array([[c, -np.sin(turn * s), 0.0], [np.sin(turn * s), c, 0.0], [0.0, 0.0, 1.0]])
        positions.append(x0 @ A.T + s * np.asarray(shift))
        # Euler parameters of the turn (cos h, 0, 0, sin h) times each node's: p ⊗ q, scalar first
        p0, p3 = np.cos(h), np.sin(h)
        rotations.append(np.column_stack([p0 * q0[:, 0] - p3 * q0[:, 3], p0 * q0[:, 1] - p3 * q0[:, 2],
                                          p0 * q0[:, 2] + p3 * q0[:, 1], p0 * q0[:, 3] + p3 * q0[:, 0]]))
    return Results(time=time, labels=[n.label for n in domain.nodes], positions=np.array(positions),
                   rotations=np.array(rotations))


def measure() -> dict:
    """The animation figure of the force-element deck's moved configuration: what it draws, its limits."""
    import matplotlib

    matplotlib.use("Agg")
    from flexmbs.plot import animation_figure, plane
    from reference.io.deck import load_deck

    domain = load_deck(ROOT / "models" / "force_elements_crosscheck.toml").domain
    r = _moved(domain)
    fig, artists, draw, frames = animation_figure(r, domain)
    seen = []
    for k in range(len(frames)):
        draw(k)
        seen += [x.get_xydata() for group in artists.values() for x in group if len(x.get_xydata())]
    seen = np.concatenate(seen)
    fig.canvas.draw()  # the limits as drawn, after the equal aspect is applied
    ax = fig.axes[0]
    a, b = plane(r)
    P = r.positions.reshape(-1, 3)
    return {"kinds": {kind: len(group) for kind, group in artists.items()},
            "spring_points": len(artists["spring"][0].get_xydata()),
            "xlim": list(ax.get_xlim()), "ylim": list(ax.get_ylim()), "aspect": float(ax.get_aspect()),
            "drawn": [seen[:, 0].min(), seen[:, 0].max(), seen[:, 1].min(), seen[:, 1].max()],
            "nodes": [P[:, a].min(), P[:, a].max(), P[:, b].min(), P[:, b].max()]}


def test_animation_draws_springs_joints_and_ground_fitted_to_the_motion():
    """The deck's point-to-point spring-damper, torsion spring, bushing and revolute joint are drawn, and the
    ground under its clamp and the wheel's pin; the axes hold everything drawn over the whole motion (a
    translation of 0.8 m and a turn of 0.4 rad beyond the initial configuration), with at most 5 % of the
    drawing's extent empty on each side (more along the short side of a drawing flatter than 2.5 : 1), at
    equal scale."""
    pytest.importorskip("matplotlib")
    from test_families import uncompiled_json  # the deck reader uncompiled: no kernel is compiled for this

    m = uncompiled_json("-c", "import json, test_animation as t; print(json.dumps(t.measure()))", timeout=300)
    for kind in ("body", "spring", "torsion spring", "bushing", "joint", "ground"):
        assert m["kinds"].get(kind), f"no {kind} drawn: {m['kinds']}"
    assert m["kinds"]["ground"] >= 2 * 3  # two held points (the clamp, the wheel's pin), a symbol of 3+ lines each
    assert m["spring_points"] > 10  # a zigzag, not a line
    (x0, x1), (y0, y1), (dx0, dx1, dy0, dy1) = m["xlim"], m["ylim"], m["drawn"]
    assert x0 <= dx0 and dx1 <= x1 and y0 <= dy0 and dy1 <= y1
    # 5 % empty on each side; a drawing flatter than 2.5 : 1 (this one: 3.8 m by 1.3 m) has its short side
    # widened to 2.5 : 1, the flattest figure drawn
    assert x1 - x0 <= 1.1 * (dx1 - dx0) * (1 + 1e-9)
    assert y1 - y0 <= 1.1 * (dy1 - dy0) * (1 + 1e-9) or abs((x1 - x0) / (y1 - y0) - 2.5) < 1e-9
    # the limits follow the motion: the nodes' end positions (moved 0.8 m along x) are inside
    assert x0 <= m["nodes"][0] and m["nodes"][1] <= x1
    assert m["aspect"] == 1.0


def test_plot_help_names_the_default_folder():
    """``plot --out``'s help names the folder the figures go to without it (the results file's path less .h5)."""
    from flexmbs.cli import parser

    plot = parser()._subparsers._group_actions[0].choices["plot"]
    text = " ".join(plot.format_help().split())
    assert "default: the results file's path without .h5, e.g. out/three_bar/results/ for out/three_bar/results.h5" in text
