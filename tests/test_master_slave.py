"""The master/slave joint formulation: exact elimination, agreement with Lagrange multipliers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexmbs.verification.observables import midspan_deflection, rocker_angle
from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.io.deck import DeckError, load_deck
from reference.joints import Jacobian, MasterSlave
from reference.observables import wrap
from reference.rotation import EulerParameters

DECK = Path(__file__).resolve().parent.parent / "models" / "three_bar.toml"


def master_slave_deck(tmp_path):
    text = DECK.read_text()
    for joint in ('label = "A"', 'label = "B"'):
        text = text.replace(joint, joint + '\nformulation = "master_slave"')
    path = tmp_path / "three_bar_ms.toml"
    path.write_text(text)
    return path


def test_master_slave_and_lagrange_agree_on_the_three_bar(tmp_path):
    """Joints A and B (coupler ends on crank and rocker) by elimination, O1, drive and O3 by
    multipliers; 10 s.  Against the all-multiplier run: rocker within 1e-5 rad (measured
    2.4e-6), mid-span deflection within 1 % of its peak (measured 0.02 %); the eliminated
    joints hold to round-off; the remaining multiplier rows keep ‖Φ‖ ≤ 5e-5 (the alternating
    projections leave 4e-6); energy balance within 0.5 % of the peak kinetic energy."""
    ref = load_deck(DECK).solve()
    d = load_deck(master_slave_deck(tmp_path)).domain
    assert d.model.master_slave.master.shape[0] == 2 and d.model.n_constraints == 11
    r = d.solve()
    assert np.max(np.abs(wrap(rocker_angle(r) - rocker_angle(ref)))) <= 1e-5
    peak = np.max(np.abs(midspan_deflection(ref)))
    assert np.max(np.abs(midspan_deflection(r) - midspan_deflection(ref))) <= 0.01 * peak
    for i in range(0, len(r.time), 50):
        A = EulerParameters(r.rotation("crank")[i]).matrix()
        assert np.linalg.norm(r.position("coupler:0")[i] - (r.position("crank")[i] + A @ [0.5, 0.0, 0.0])) < 1e-12
        R = EulerParameters(r.rotation("rocker")[i]).matrix()
        assert np.linalg.norm(r.position("coupler:4")[i] - (r.position("rocker")[i] + R @ [-2.0, 0.0, 0.0])) < 1e-12
    assert r.constraint_violation.max() <= 5e-5
    e = r.energy
    assert np.max(np.abs(e["external_work"] - e["kinetic"] - e["strain"])) <= 5e-3 * e["kinetic"].max()


SEC = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=10.0, EI2=10.0, EI3=10.0, rhoA=1.0, rhoJ1=2e-3, rhoJ2=1e-3, rhoJ3=1e-3)


def floating(formulation, kind):
    """A spinning rigid body in free space with a flexible beam hanging on a joint at its side."""
    d = Domain("floating")
    hub = d.add_rigid_body("hub", 5.0, [1.0, 1.5, 2.0], [0.0, 0.0, 0.0])
    nodes = d.add_beam("arm", (0.5, 0.0, 0.0), (2.5, 0.0, 0.0), 4, SEC)
    d.add_joint(kind, nodes[0], hub, [0.5, 0.0, 0.0], axis=[0.0, 0.0, 1.0], formulation=formulation)
    hub.angular_velocity = np.array([0.3, 0.2, 2.0])
    for n in nodes:
        n.velocity = np.cross([0.3, 0.2, 2.0], n.position)
    d.solver = SolverSettings(dt=2e-4, t_end=2.0, output_every=100, consistent_initial_velocities=True)
    return d


@pytest.mark.parametrize("kind", ["spherical", "revolute"])
def test_floating_body_with_flexible_arm(kind):
    """Free flight, no gravity: elimination and multipliers agree (arm tip within 1e-4 of the
    2 m arm over 2 s: the two enforce the same joint, differing by the multiplier scheme's
    O(h²) constraint error); both conserve the total linear momentum (no external force: the
    projections are momentum-preserving) to 1e-9 relative."""
    runs = {}
    for name, f in (("ms", MasterSlave()), ("lagrange", Jacobian())):
        d = floating(f, kind)
        r = d.solve()
        masses = d.model.nodes.mass  # lumped masses, beam nodes included
        P = np.einsum("n,tnk->tk", masses, r.velocities)
        assert np.max(np.linalg.norm(P - P[0], axis=1)) <= 1e-9 * max(np.linalg.norm(P[0]), 1.0)
        runs[name] = r
    diff = np.abs(runs["ms"].position("arm:4") - runs["lagrange"].position("arm:4")).max()
    assert diff <= 1e-4


def test_master_slave_refuses_what_it_cannot_eliminate():
    d = Domain()
    hub = d.add_rigid_body("hub", 5.0, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    nodes = d.add_beam("arm", (0.5, 0.0, 0.0), (2.5, 0.0, 0.0), 2, SEC)
    d.add_joint("cylindrical", nodes[0], hub, [0.5, 0.0, 0.0], formulation=MasterSlave(), label="C")
    with pytest.raises(ValueError, match="joint 'C': master/slave is available for spherical and revolute"):
        d.initialization()
    d.joints.clear()
    d.add_joint("spherical", hub, nodes[0], [0.5, 0.0, 0.0], formulation=MasterSlave(), label="S")
    with pytest.raises(ValueError, match="slave \\(body_i\\) of a master/slave joint must be a beam node"):
        d.initialization()


def test_deck_chooses_the_formulation_per_joint(tmp_path):
    text = DECK.read_text().replace('label = "A"', 'label = "A"\nformulation = "master-slave"')
    path = tmp_path / "typo.toml"
    path.write_text(text)
    with pytest.raises(DeckError, match="unknown joint formulation 'master-slave'"):
        load_deck(path)
