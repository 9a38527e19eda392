"""Singularity judged on the equilibrated Newton matrix (issue 23; :mod:`reference.linalg`): the
steel three-bar runs as ``static`` (its raw pivots spread over 7e-15, the 1e-14 raw test called it
singular at load factor 0, although its condition after row/column scaling is 1.3e10), and a free
mechanism is still reported singular."""

from __future__ import annotations

from pathlib import Path

import pytest

from reference.errors import SolverDiverged
from reference.io.deck import load_deck

from test_reliability import EXAMPLE

MODELS = Path(__file__).resolve().parent.parent / "models"


def static_steel_three_bar(tmp_path):
    text = (MODELS / "steel_three_bar.toml").read_text()
    old = text[text.index('algorithm = "generalized_alpha"'):text.index("output_every = 1")]
    path = tmp_path / "steel_static.toml"
    path.write_text(text.replace(old, 'algorithm = "static"\nt_end = 0.2\nload_steps = 4\ntolerance = 1e-12\n'))
    return load_deck(path).domain


def test_the_steel_three_bar_solves_statically(tmp_path):
    d = static_steel_three_bar(tmp_path)
    r = d.solve()
    assert r.status == "completed"
    # every load step ends in equilibrium: its last Newton residual is below the tolerance (1e-12)
    # times the forces of the model (EA = 5.4e7 N), the first residual being the out-of-balance load
    last = d.last_run["solver"].history  # the last load level's Newton residuals
    assert last[-1] < 1e-12 * 5.4e7 and last[-1] < 1e-6 * max(last), last


def test_a_free_mechanism_is_still_singular(tmp_path):
    """The documented cantilever without its clamp has six rigid-body motions: singular at once."""
    path = tmp_path / "free.toml"
    path.write_text(EXAMPLE.replace('[[clamps]]\nnode = "b:start"\n', "")
                    .replace('algorithm = "staggered_central_difference"', 'algorithm = "static"\nload_steps = 2')
                    .replace("dt = 1e-3                       # below the critical step of this mesh\n", "")
                    .replace("damping = 0.0\n", ""))
    with pytest.raises(SolverDiverged, match="the Newton matrix became singular at load factor 0"):
        load_deck(path).domain.solve()
