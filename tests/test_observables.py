"""The observable grammar (reference/observables.py): checked at deck load, evaluated on either engine's
results, used by the cross-check, `flexmbs plot` and the default comparison (issue 10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from crosscheck.harness import run
from flexmbs.cli import main
from flexmbs.verification.observables import rocker_angle
from reference.domain import Domain
from reference.interactions import NodalLoad
from reference.io.deck import DeckError
from reference.elements import Section
from reference.io.deck import load_deck
from reference.observables import ObservableError, parse, relative_angle

MODELS = Path(__file__).resolve().parent.parent / "models"
G = 9.81

HELD_BAR = """
[meta]
name = "held_bar"
description = "A rigid bar (mass 2, length 1) along x, pinned at x = 0 about y and held horizontal by a drive"

[sections.bar]
EA = 1.0
GA2 = 1.0
GA3 = 1.0
GJ = 1.0
EI2 = 1.0
EI3 = 1.0
rhoA = 2.0
rhoJ1 = 0.01
rhoJ2 = 0.01
rhoJ3 = 0.01

[time_functions.hold]
kind = "constant"
value = 0.0

[[beams]]
label = "bar"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
elements = 1
section = "bar"
rigid = true

[[joints]]
label = "pin"
kind = "revolute"
body_i = "bar"
point = [0.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]

[[joints]]
label = "motor"
kind = "rotation_drive"
body_i = "bar"
point = [0.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]
time_function = "hold"

[gravity]
g = [0.0, 0.0, -9.81]

[solver]
dt = 1e-3
t_end = 0.1
output_every = 10
"""


def three_bar_with(tmp_path, observable, table="crosscheck.rocker"):
    text = (MODELS / "three_bar.toml").read_text()
    if table == "crosscheck.rocker":
        assert text.count('observable = "angle.z:rocker"') == 1
        text = text.replace('observable = "angle.z:rocker"', f"observable = {observable!r}")
    else:
        text += f'\n[{table}]\nobservable = {observable!r}\ntolerance = 1.0\nreason = "test"\n'
    path = tmp_path / "deck.toml"
    path.write_text(text)
    return path


MISTAKES = [
    ("positon:coupler:end", "unknown observable 'positon'; did you mean 'position'?"),
    ("position:coupler:ned", "no node 'coupler:ned'; did you mean 'coupler:end'?"),
    ("position:b:start", "no node 'b:start'"),
    ("reaction_force:Q", "no joint 'Q'"),
    ("reaction_moment.w:crank drive", "'reaction_moment' has no component 'w'"),
    ("section_force.x:coupler/0", "'section_force' has no component 'x'"),
    ("section_moment:coupler/4", "no element 'coupler/4'"),
    ("energy:kinetik", "no energy 'kinetik'; did you mean 'kinetic'?"),
    ("distance:coupler:start", "'distance' takes node,node"),
    ("angle:rocker", "'angle' needs its axis"),
    ("midspan_deflection:crank", "no beam 'crank'"),
    ("position", "'position' needs its argument"),
]


@pytest.mark.parametrize("text, message", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_every_bad_observable_is_refused_when_the_deck_is_loaded(tmp_path, text, message):
    """A typo, an unknown node/joint/element, a wrong component or argument count: one DeckError line
    naming the file and the entry, at load time."""
    with pytest.raises(DeckError) as info:
        load_deck(three_bar_with(tmp_path, text)).domain
    msg = str(info.value)
    assert "\n" not in msg and message in msg and msg.startswith(f"{tmp_path / 'deck.toml'}: crosscheck.rocker.observable")


def test_checks_observables_use_the_same_grammar(tmp_path):
    with pytest.raises(DeckError, match=r"checks.mine.observable: 'velocity:rocer': no node 'rocer'; did you mean 'rocker'"):
        load_deck(three_bar_with(tmp_path, "velocity:rocer", "checks.mine")).domain
    with pytest.raises(DeckError, match="expected an observable text, got 3"):
        path = tmp_path / "n.toml"
        path.write_text((MODELS / "three_bar.toml").read_text() + "\n[checks.n]\nobservable = 3\n")
        load_deck(path).domain


@pytest.mark.parametrize("text", [m[0] for m in MISTAKES[:6]])
def test_crosscheck_refuses_bad_observables_before_running_with_one_line(tmp_path, capsys, text):
    """`flexmbs crosscheck` with each kind of mistake: exit 2, one line on stderr, no traceback, and no
    engine ran (no results file)."""
    deck = three_bar_with(tmp_path, text)
    assert main(["crosscheck", str(deck), "--out", str(tmp_path / "cc")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err and err.startswith("flexmbs: error:")
    assert not (tmp_path / "cc" / "results_reference.h5").exists()


def test_evaluation_shapes_aliases_and_descriptions():
    d = load_deck(MODELS / "three_bar.toml", overrides={"t_end": 0.2}).domain
    r = d.solve()
    n = len(r.time)
    assert np.array_equal(r.position("coupler:end"), r.position("coupler:4"))  # aliases work in Results
    assert np.array_equal(r.position("coupler:start"), r.position("coupler:0"))
    shapes = {"position:coupler:end": (n, 3), "position.z:coupler:end": (n,), "rotation.q0:crank": (n,),
              "velocity.norm:rocker": (n,), "position:*": (n, len(r.labels), 3), "distance:crank,rocker": (n,),
              "angle.z:rocker": (n,), "angle.z:coupler:2,crank": (n,), "deflection:coupler:2,coupler:start,coupler:end": (n, 3),
              "reaction_force:A": (n, 3), "reaction_moment.z:crank drive": (n,), "section_force.1:coupler/end": (n,),
              "section_moment:coupler/0": (n, 3), "energy:total": (n,), "midspan_deflection:coupler": (n, 3)}
    for text, shape in shapes.items():
        obs = parse(text, d)
        assert obs.evaluate(r).shape == shape and obs.describe().endswith("]"), text
        assert parse(text, r) == obs  # the same observable parsed against the results file
    assert parse("reaction_moment.z:crank drive", d).describe() == (
        "z component of the moment of joint 'crank drive' on its body_i about the joint point, inertial [N m]")
    assert np.array_equal(parse("section_force.1:coupler/end", r).evaluate(r), r.section_force("coupler", 3)[:, 0])


def test_rocker_angle_is_the_relative_rotation_and_matches_the_old_definition():
    """`rocker_angle` (flexmbs.verification) from `angle.z:rocker`; the old hard-wired angle of the line pivot (4, 0) → rocker centre
    equals its initial value plus that rotation, to the joint drift (≤ 1e-5 rad; measured 1.4e-13)."""
    d = load_deck(MODELS / "three_bar.toml", overrides={"t_end": 3.0}).domain
    r = d.solve()
    c = r.position("rocker")
    old = np.unwrap(np.arctan2(c[:, 1], c[:, 0] - 4.0))
    assert np.max(np.abs(rocker_angle(r) - old)) <= 1e-5
    assert np.array_equal(parse("angle.z:rocker", r).evaluate(r), relative_angle(r, "rocker"))
    assert np.max(np.abs(relative_angle(r, "rocker") - (old - old[0]))) <= 1e-5


def test_deflection_works_for_bending_in_any_plane():
    """A post along z bent in x (the case that divided by zero): the deflection vector of its middle
    node from the chord is finite, has no y component, and its length is the distance of the node from
    the chord line computed independently (|(m − a) × c|)."""
    sec = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)
    d = Domain("vertical")
    nodes = d.add_beam("post", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 4, sec, axis2=(0.0, 1.0, 0.0))
    d.add_joint("fixed", nodes[0], None, [0.0, 0.0, 0.0], label="foot")
    d.add_interaction(NodalLoad(nodes[-1], np.array([1e-3, 0.0, 0.0])))
    d.solver.dt, d.solver.t_end, d.solver.output_every = 1e-3, 0.5, 50
    r = d.solve()
    v = parse("midspan_deflection:post", d).evaluate(r)
    assert np.all(np.isfinite(v)) and np.max(np.abs(v[:, 1])) == 0.0
    m, a, b = r.position("post:2"), r.position("post:start"), r.position("post:end")
    c = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
    expected = np.linalg.norm(np.cross(m - a, c), axis=1)  # distance of m from the line a–b
    assert np.allclose(np.linalg.norm(v, axis=1), expected, rtol=1e-12, atol=1e-15)
    assert np.max(np.abs(v[:, 0])) > 0.0


def test_a_deck_without_crosscheck_gets_the_default_comparison_and_reactions_agree(tmp_path, capsys):
    """No [crosscheck] table: every node's position is compared (1 % of the length) and the output says
    so.  The held bar is static: both engines report the closed-form reactions — pin force m g up on
    the bar, motor torque −m g L/2 about y (the weight's moment about the pin is +m g L/2) — within
    1e-6 (measured 2e-14 and 0; Exudyn's ForceLocal/TorqueLocal mapped by crosscheck/exudyn_model.py)."""
    deck = tmp_path / "held_bar.toml"
    deck.write_text(HELD_BAR)
    cmp = run(deck, tmp_path / "cc")
    assert cmp["default"] and [v.observable for v in cmp["verdicts"]] == ["position:*"]
    assert cmp["verdicts"][0].passed
    assert any("no `[crosscheck]` table" in line for line in cmp["markdown"])
    m, L = 2.0, 1.0
    for res in (cmp["reference"], cmp["exudyn"]):
        force, _ = res.reaction("pin")
        _, torque = res.reaction("motor")
        assert np.allclose(force, [0.0, 0.0, m * G], atol=1e-6 * m * G)
        assert np.allclose(torque, [0.0, -m * G * L / 2, 0.0], atol=1e-6 * m * G)
    assert main(["crosscheck", str(deck), "--out", str(tmp_path / "cc2")]) == 0
    assert "no [crosscheck] table" in capsys.readouterr().out


def test_plot_any_observable(tmp_path, capsys):
    deck = tmp_path / "held_bar.toml"
    deck.write_text(HELD_BAR)
    assert main(["run", str(deck), "--out", str(tmp_path / "run"), "--no-vtk"]) == 0
    results = tmp_path / "run" / "results.h5"
    assert main(["plot", str(results), "--observable", "reaction_moment.y:motor", "--out", str(tmp_path / "p")]) == 0
    assert (tmp_path / "p" / "observable_reaction_moment.y_motor.png").stat().st_size > 1000
    capsys.readouterr()
    assert main(["plot", str(results), "--observable", "reaction_moment.y:motr"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "did you mean 'motor'?" in err


def test_observable_errors_are_value_errors_with_a_fix():
    d = load_deck(MODELS / "three_bar.toml").domain
    with pytest.raises(ObservableError, match="; did you mean 'reaction_force'"):
        parse("reaction_forces:A", d)
    odd = Domain("odd")
    odd.add_beam("b", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 3, d.elements[0].formulation.section)
    with pytest.raises(ObservableError, match="odd number"):
        parse("midspan_deflection:b", odd)
    assert parse("deflection:b:1,b:start,b:end", odd).args == ("b:1", "b:start", "b:end")
