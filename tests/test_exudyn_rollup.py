"""The roll-up in Exudyn agrees with the reference engine (short horizon, for CI)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crosscheck.exudyn_rollup import solve_rollup_exudyn
from flexmbs.bench import rollup_parameters
from reference.analytic import elastica_tip
from reference.domain import Domain

DECK = Path(__file__).resolve().parent.parent / "models" / "embedded_beam.toml"


def test_exudyn_and_reference_agree_on_the_rollup_start():
    """Same deck data, 0 ≤ k ≤ 0.3 (1,500 steps): both tips within 0.5 % L of the elastica
    and within 0.5 % L of each other (the issue's tolerance; measured ~3e-4 L here, growing
    to the Beam2 polygon error of 0.23 % L at k ≈ 1.3 over the full run)."""
    domain = Domain.from_deck(DECK, overrides={"t_end": 0.3})
    ref = domain.solve()
    params = rollup_parameters(domain)
    ex = solve_rollup_exudyn(**params)
    assert ex["steps"] == 1500
    assert np.allclose(ex["time"], ref.time)
    L = params["L"]
    ref_tip = ref.position("beam:12")
    for i, k in enumerate(ref.time):
        assert np.linalg.norm(ex["tip_position"][i] - elastica_tip(L, k)) <= 5e-3 * L
        assert np.linalg.norm(ex["tip_position"][i] - ref_tip[i]) <= 5e-3 * L
    assert np.all(ex["node_positions"][:, :, 1] == 0.0)


def test_exudyn_static_rollup_closes_the_circle():
    """EXUDYN_NOTES: Exudyn's SE(3) strain represents constant curvature exactly, so its
    static roll-up at k = 2 closes to round-off (1e-9 L allows for the Newton tolerance)."""
    ex = solve_rollup_exudyn(static=True)
    assert np.linalg.norm(ex["tip_position"][-1]) <= 1e-9 * 10.0
