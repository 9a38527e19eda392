"""The spin-up of models/rotating_blade_reduced.toml (issue 39): a blade spun up past its first bending frequency,
reduced with and without geometric stiffening, against the full geometrically exact beam on the same mesh
(flexmbs/verification/reduced.py, the report's section)."""

from __future__ import annotations

import numpy as np
import pytest

from flexmbs.verification.reduced import DECKS, MODELS, tip_in_hub, variant
from reference.io.deck import load_deck
from reference.io.deck_reader import read_toml

DECK = MODELS / "rotating_blade_reduced.toml"
HORIZON = 10.0
"""[s]: the lead-lag deflection peaks near 5 s (the spin-up's largest angular acceleration) and the spin passes the
first bending frequency, 3.52 rad/s, at 8.4 s: both are inside, at half the deck's 20 s."""


def test_the_variants_differ_from_the_deck_only_where_asked(tmp_path):
    full = read_toml(variant(DECK, tmp_path, "full", drop_reduce=True))[1]
    deck = read_toml(DECK)[1]
    assert "reduce" not in full["beams"][0] and "backend" not in full["solver"]
    full["beams"][0]["reduce"], full["solver"]["backend"] = deck["beams"][0]["reduce"], deck["solver"]["backend"]
    assert full == deck
    source = MODELS / "cantilever_modes.toml"
    reduced = read_toml(variant(source, tmp_path, "red", '{ modes = 6, interfaces = ["beam:start"] }'))[1]
    assert reduced["beams"][0]["reduce"] == {"modes": 6, "interfaces": ["beam:start"]}
    assert reduced["solver"]["backend"] == "reference" and set(DECKS) <= {p.name for p in MODELS.glob("*.toml")}


@pytest.fixture(scope="module")
def spun(tmp_path_factory):
    """Lead-lag tip deflections (hub frame's y) [m] of the full beam and the reduced blade with and without
    stiffening, to :data:`HORIZON`; the unstiffened run may stop (None then)."""
    from reference.errors import SolverDiverged

    folder = tmp_path_factory.mktemp("spinup")
    over = {"t_end": HORIZON}
    out = {"full": load_deck(variant(DECK, folder, "full", drop_reduce=True), over).solve(),
           "stiffened": load_deck(DECK, over).solve()}
    plain = variant(DECK, folder, "plain")
    plain.write_text(plain.read_text().replace("stiffening = true", "stiffening = false"))
    try:
        out["plain"] = load_deck(plain, over).solve()
    except SolverDiverged:
        out["plain"] = None
    return {k: None if r is None else (r.time, tip_in_hub(r)[:, 1]) for k, r in out.items()}


def test_the_stiffened_reduced_blade_follows_the_full_beam(spun):
    """The issue's target: within 2 % of the peak tip deflection (lead-lag, the hub frame's y)."""
    (_, full), (_, stiff) = spun["full"], spun["stiffened"]
    peak = np.abs(full).max()
    assert 0.04 < peak < 0.07  # ~5.4 % of the length: a linear but not a negligible deflection
    assert np.abs(stiff - full).max() <= 0.02 * peak


def test_the_unstiffened_reduced_blade_leaves_the_full_beam(spun):
    """Without the stress stiffness the linear modes lose the lead-lag stiffness the spin adds (unstable past
    Ω = 3.52 rad/s, reached at 8.4 s): over the first 10 s the unstiffened blade leaves the full beam by far more
    than the stiffened one (measured 0.065 m against the full beam's 0.054 m peak; the stiffened one within 2 %).
    Exudyn's run of the same modes diverges sooner (2 × the peak at 6.75 s, below): the difference between the two
    unstiffened runs is open (docs/benchmarks.md, reduced bodies)."""
    (_, full), (_, stiff) = spun["full"], spun["stiffened"]
    peak = np.abs(full).max()
    if spun["plain"] is None:
        return
    plain = spun["plain"][1]
    assert np.abs(plain - full).max() > max(0.05 * peak, 3.0 * np.abs(stiff - full).max())


@pytest.fixture(scope="module")
def full_blade(tmp_path_factory):
    """The full geometrically exact blade (compiled generalized-α): time and lead-lag tip deflection."""
    r = load_deck(variant(DECK, tmp_path_factory.mktemp("full"), "full", drop_reduce=True)).solve()
    return r.time, tip_in_hub(r)[:, 1]


def test_exudyn_reduced_blade_with_flexmbs_stiffening_follows_the_full_beam(full_blade):
    """The issue's spin-up target with the dynamics run by Exudyn (crosscheck/exudyn_spinup.py): flexmbs's clamped
    modes, invariants and stress stiffness, the stiffened blade within 2 % of the full beam's peak tip deflection
    over the deck's 20 s (measured 0.20 % with the deck's 8 modes; 2.0 % with 4, a phase drift after the spin-up)."""
    from crosscheck.exudyn_spinup import spinup

    t, full = full_blade
    out = spinup(DECK, stiffening=True)
    assert np.allclose(out["time"], t, atol=1e-9)
    peak = np.abs(full).max()
    assert 0.04 < peak < 0.07
    assert np.abs(out["lag"] - full).max() <= 0.02 * peak


def test_exudyn_reduced_blade_without_stiffening_diverges(full_blade):
    """Without the stress stiffness the lead-lag mode is unstable past Ω = 3.52 rad/s: measured 2 × the full beam's
    peak at t = 6.75 s and 131 × by 10 s (growth ~2–5 /s, already before the spin reaches 3.52 rad/s at 8.4 s: the
    softened lead-lag mode, near zero frequency, answers the spin-up's angular acceleration quasi-statically)."""
    from crosscheck.exudyn_spinup import spinup

    t, full = full_blade
    out = spinup(DECK, stiffening=False, t_end=10.0)
    assert np.abs(out["lag"]).max() > 50.0 * np.abs(full).max()
