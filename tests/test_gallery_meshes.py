"""The gallery decks on the element family their own mesh study recommends (issue 36: once nothing compiles for a
short run, the compile cost no longer picks the mesh).

Lee's frame (models/lee_frame.toml) is beam3 with 5 elements per leg on ``backend = "auto"``: its mesh study
(the deck's notes) finds it 5.5e-4 above the converged first limit load at an eighth of Beam2's coordinates,
and ``auto`` runs it on the reference path, so that neither its first run nor this test compiles anything.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from reference.io.deck import load_deck
from reference.validation import ModelWarning

MODELS = Path(__file__).resolve().parents[1] / "models"
CONVERGED_P1 = 18.5446
"""The converged first limit load P L²/EI of Lee's frame (beam3 with 20 elements per leg, the deck's notes)."""


def test_lee_frame_is_beam3_on_the_reference_path_and_meets_its_first_limit_target():
    """The deck's own mesh, its path cut after 50 points (the first limit point is passed at about 47): auto
    takes the reference path, and the first limit load is within 1e-3 of the converged value (measured
    +5.5e-4: beam3's mesh error at 5 per leg; Beam2 at 20 per leg is +3.3e-3 and would fail, at 40 per leg
    +8e-4)."""
    domain = load_deck(MODELS / "lee_frame.toml", overrides={"solver.max_points": 50}).domain
    assert {e.formulation.family for e in domain.elements} == {"beam3"} and len(domain.elements) == 10
    assert domain.solver.backend == "auto"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # the stability line of the first limit point
        r = domain.solve()
    assert domain.last_run["backend"][0] == "reference"
    critical = r.data("path/critical_load_factor")
    assert len(critical) >= 1
    P1 = 10.0 * critical[0]  # P L²/EI = 10 λ (the deck's notes)
    assert P1 == pytest.approx(CONVERGED_P1, rel=1e-3)
