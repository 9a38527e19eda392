"""``flexmbs crosscheck`` on an arc-length deck (crosscheck/path_crosscheck.py): Exudyn's static solver on the
pre-limit path of Lee's frame against flexmbs' arc-length points at the same loads."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("exudyn")

from crosscheck.path_crosscheck import FRACTION, run  # noqa: E402

DECK = Path(__file__).resolve().parents[1] / "models" / "lee_frame.toml"


def coarse(per_leg: int) -> dict:
    """The deck at ``per_leg`` Beam2 elements per leg (a fifth of them between the knee and the load; the deck
    itself is beam3), its path cut after 45 points (past the first limit point), on the compiled path as before."""
    return {"beams.0.elements": per_leg, "beams.1.elements": per_leg // 5, "beams.2.elements": per_leg - per_leg // 5,
            **{f"beams.{k}.element": "beam2" for k in range(3)}, "solver.max_points": 45, "solver.backend": "compiled"}


def test_exudyn_static_path_converges_to_the_arc_length_points(tmp_path):
    """Both engines on the same Beam2-type meshes (flexmbs' Beam2, Exudyn's ObjectBeamGeometricallyExact) from 0
    to 0.9 of the first limit load: the load point and the knee at every flexmbs point of the rising branch.  The
    two elements differ at second order in the element size, so the largest difference falls by about 4 from
    5 to 10 elements per leg (measured 4.4: 1.5e-2 and 3.4e-3; 2.3e-4 of the size at 40 per leg, the deck's former mesh)."""
    a = run(DECK, tmp_path / "5", overrides=coarse(5))
    b = run(DECK, tmp_path / "10", overrides=coarse(10))
    for c in (a, b):
        assert c["load_factor"] == pytest.approx(FRACTION * c["critical"], rel=1e-12)
        assert c["points"] >= 15 and c["nodes"] == ["knee", "load"]
    print(f"largest difference / size: {a['difference']:.3e} (5 per leg), {b['difference']:.3e} (10 per leg)")
    assert b["difference"] < 5e-3
    assert 3.0 < a["difference"] / b["difference"] < 5.5
