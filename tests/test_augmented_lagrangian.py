"""The augmented-Lagrangian joint formulation (reference/joints/augmented_lagrangian.py; issue 37, item 2).

Bayo's augmented Lagrangian applies −Bᵀ(λ* + α Φ) and iterates λ* ← λ* + α Φ: its converged motion
is the Lagrange-multiplier one, for any penalty α.  Measured here on the paper's three-bar (the
rocker angle and every joint's reaction against the multiplier run), with the explicit, static and
generalized-α algorithms, and on the rigid four-bar, whose four 3D revolute joints are redundant.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexmbs.deckchecks.three_bar import quasi_static_deck, rigid_coupler_deck
from flexmbs.verification.analytic import fourbar_rocker_angle
from flexmbs.verification.observables import crank_angle, rocker_angle
from reference.io.deck import DeckError, load_deck
from reference.joints.augmented_lagrangian import AugmentedLagrangian
from reference.joints.formulation import Jacobian

MODELS = Path(__file__).resolve().parent.parent / "models"
THREE_BAR = MODELS / "three_bar.toml"


def solve(path, formulation=None, **overrides):
    """Solve the deck at ``path`` with every joint's formulation replaced (None: as the deck says)."""
    domain = load_deck(path, overrides=overrides).domain
    if formulation is not None:
        for joint in domain.joints:
            joint.formulation = formulation
    return domain, domain.solve()


def departure(a, b) -> dict:
    """Largest differences between two runs of one deck: rocker angle [rad], reaction forces [N] and
    moments [N m] of every joint, at every output."""
    (da, ra), (_, rb) = a, b
    return {"rocker": float(np.max(np.abs(rocker_angle(ra) - rocker_angle(rb)))),
            "force": max(float(np.max(np.abs(ra.reaction(j.label)[0] - rb.reaction(j.label)[0]))) for j in da.joints),
            "moment": max(float(np.max(np.abs(ra.reaction(j.label)[1] - rb.reaction(j.label)[1]))) for j in da.joints)}


@pytest.fixture(scope="module")
def multipliers():
    return solve(THREE_BAR)
