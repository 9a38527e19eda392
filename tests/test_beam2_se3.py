"""The helicoidal two-node beam ``beam2_se3`` (issue 21): the roll-up exact with any mesh, every
algorithm, the deck key, an arc as its exact reference.

The runs happen in one subprocess with the engine uncompiled (``NUMBA_DISABLE_JIT=1``; see
tests/test_families.py for why): a few seconds of plain Python instead of compiling every
algorithm's kernels for a model of this family.  The element's own checks (rigid motion,
objectivity, path independence, patch test, tangent, locking, orders) are the family suite's.
The compiled path of the family (its kernels inlined into the engine's static and modes
kernels) runs in ``make families``, whose long suite is compiled: a cold compile of a
beam2_se3 model costs minutes, past the test budget.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from reference.domain import Domain
from reference.elements import Section
from reference.io.deck import load_deck
from reference.io.deck_reader import DeckError

from test_families import uncompiled_json

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


def run_all() -> dict:
    """Every algorithm on beam2_se3 models (and beam2 where the two are compared)."""
    from flexmbs.verification.analytic import elastica_tip

    out = {}
    for n, refine in ((3, 1), (12, 4)):  # 12 = 3 elements × refine 4 (the CLI's --refine)
        d = load_deck(MODELS / "embedded_beam_static.toml",
                             overrides={"beams.0.elements": 3, "beams.0.element": "beam2_se3",
                                        "solver.tolerance": 1e-12, "refine": refine}).domain
        r = d.solve()
        tip = r.position(f"beam:{n}")
        out[f"rollup{n}"] = {"k": r.time.tolist(), "status": r.status,
                             "error": [float(np.linalg.norm(tip[i] - elastica_tip(10.0, k)) / 10.0)
                                       for i, k in enumerate(r.time)]}
    for family in ("beam2", "beam2_se3"):
        r = load_deck(MODELS / "cantilever_modes.toml",
                             overrides={"beams.0.element": family, "beams.0.elements": 8}).domain.solve()
        out[f"modes_{family}"] = r.data("modes/frequency").tolist()
        r = load_deck(MODELS / "lateral_buckling.toml",
                             overrides={"beams.0.element": family, "beams.0.elements": 8}).domain.solve()
        out[f"buckling_{family}"] = r.data("buckling/load_factor").tolist()
        for algorithm, dt in (("staggered_central_difference", 2e-4), ("generalized_alpha", 2e-3)):
            r = load_deck(MODELS / "three_bar.toml",
                                 overrides={"beams.1.element": family, "solver.t_end": 0.04,
                                            "solver.algorithm": algorithm, "solver.dt": dt}).domain.solve()
            out[f"{algorithm}_{family}"] = {"status": r.status, "tip": r.position("coupler:4")[-1].tolist()}
    from flexmbs.verification.families import bend_tip

    out["bend"] = list(bend_tip("beam2_se3", 8))
    R, section = 2.0, Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0,
                              rhoA=1.0, rhoJ1=1.0, rhoJ2=1.0, rhoJ3=1.0)
    for family in ("beam2", "beam2_se3"):
        d = Domain("arc")
        d.add_beam("arc", (R, 0.0, 0.0), (0.0, R, 0.0), 4, section, axis2=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0),
                   element=family)
        elements = d.initialization().elements
        out[f"arc_{family}"] = float(np.sum([data.L0 for data in elements if data.conn.shape[0]]))
        out[f"types_{family}"] = [type(data).__name__ for data in elements]
    return out


@pytest.fixture(scope="module")
def runs():
    return uncompiled_json(__file__)


@pytest.mark.parametrize("n", [3, 12])
def test_rollup_is_exact_with_any_mesh(runs, n):
    """Issue 21: the embedded beam (models/embedded_beam_static.toml) rolled up to k = 2 in 20 static
    load steps with 3 and with 12 beam2_se3 elements (3 refined 4 times): the tip on the elastica (the
    circle) within 1e-10 L at every load step (Newton to 1e-12; measured 9e-16 L at 3 elements and
    1.8e-12 L at 12).  Beam2's 12 elements err by up to 2.1e-3 L (the polygon)."""
    r = runs[f"rollup{n}"]
    assert r["status"] == "completed" and r["k"][-1] == pytest.approx(2.0)
    assert len(r["error"]) >= 21 and max(r["error"]) <= 1e-10


def test_modes_equal_beam2s(runs):
    """Linearised about a straight state the helicoid's strains are Beam2's (``B(ψ) d/L0 ≈ (d − ψ×d/2)/L0``,
    the midpoint-triad shear) and the lumped masses are the same: the cantilever's frequencies agree
    to 1e-9 (measured: identical to the last bit)."""
    assert np.allclose(runs["modes_beam2_se3"], runs["modes_beam2"], rtol=1e-9, atol=0.0)


def test_buckling_runs_and_is_near_the_closed_form(runs):
    """Lateral buckling (models/lateral_buckling.toml, 8 elements): the load factor within 2 % of the
    converged 64-element value 4.06016/4 of the deck (measured +1.25 % Beam2, +1.10 % beam2_se3: a
    second-order mesh error at 8 elements; the pre-buckling deflection is where the two differ)."""
    for family in ("beam2", "beam2_se3"):
        assert runs[f"buckling_{family}"][0] == pytest.approx(4.06016 / 4, rel=2e-2), family


def test_explicit_and_generalized_alpha_run_the_three_bar_coupler(runs):
    """The three-bar mechanism with a beam2_se3 coupler for 0.04 s of its spin-up: both dynamic schemes
    complete, and the coupler's tip agrees with the Beam2 coupler's within 1e-8 m (measured 9e-13 m: the
    two elements differ only at second order in the coupler's small strains; the two schemes differ by
    3.7e-8 m)."""
    for algorithm in ("staggered_central_difference", "generalized_alpha"):
        a, b = runs[f"{algorithm}_beam2_se3"], runs[f"{algorithm}_beam2"]
        assert a["status"] == b["status"] == "completed"
        assert np.allclose(a["tip"], b["tip"], atol=1e-8, rtol=0.0), algorithm


def test_45_degree_bend_against_the_literature(runs):
    """The 45° bend (Bathe & Bolourchi 1979) as one arc of 8 beam2_se3 elements, static, P = 600: the tip
    within 0.5 % of R = 100 of Simo & Vu-Quoc's (1986) 8-element (47.23, 15.79, 53.37), the tolerance of
    models/curved_cantilever.toml (published values of different elements spread by 0.45 % R); measured
    0.087 % R (Beam2: 0.056 % R)."""
    assert np.linalg.norm(np.subtract(runs["bend"], (47.23, 15.79, 53.37))) <= 5e-3 * 100.0


def test_an_arc_is_its_exact_reference(runs):
    """A quarter arc of radius 2 in 4 elements: beam2_se3's reference arc lengths sum to π R/2 to 1e-14
    (the helicoid through the nodes' tangent frames is the circle), Beam2's to the chord polygon
    8 R sin(π/16)."""
    assert runs["arc_beam2_se3"] == pytest.approx(math.pi * 2.0 / 2, rel=1e-14)
    assert runs["arc_beam2"] == pytest.approx(8 * 2.0 * math.sin(math.pi / 16), rel=1e-14)


def test_a_beam2_model_compiles_as_before(runs):
    """beam2_se3 is packed only where a model uses it: a Beam2 model's family tuple, the type every
    compiled kernel is specialised to, is Beam2's alone (no new compilation on the Beam2 path)."""
    assert runs["types_beam2"] == ["Beam2Data"]
    assert runs["types_beam2_se3"] == ["Beam2Data", "Beam2SE3Data"]


def test_deck_element_key_errors():
    """A misspelt family, a non-string and an `element` on a rigid bar are refused in one line naming the
    entry and the fix."""
    cases = [("embedded_beam_static.toml", "beam2_se", "did you mean 'beam2_se3'?"),
             ("embedded_beam_static.toml", 3, "one of: beam2, beam2_se3"),
             ("physical_pendulum.toml", "beam2_se3", "a rigid bar has no elements; remove `element` or `rigid`")]
    for deck, value, fix in cases:
        with pytest.raises(DeckError) as err:
            load_deck(MODELS / deck, overrides={"beams.0.element": value}).domain
        assert "beams[0].element" in str(err.value) and fix in str(err.value) and "\n" not in str(err.value)


if __name__ == "__main__":
    print(json.dumps(run_all()))
