"""Model decks: the shipped decks load; bad decks give one clear message naming file, entry and fix."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from reference.domain import Domain
from reference.io.deck import DeckError, load_deck

MODELS = Path(__file__).resolve().parent.parent / "models"

GOOD = """
[meta]
name = "tiny"
[sections.s]
EA = 1e3
GA2 = 1e3
GA3 = 1e3
GJ = 1.0
EI2 = 1.0
EI3 = 1.0
rhoA = 1.0
rhoJ1 = 2e-2
rhoJ2 = 1e-2
rhoJ3 = 1e-2
[time_functions.up]
kind = "ramp"
t0 = 0.0
t1 = 0.01
[[beams]]
label = "b"
start = [0.0, 0.0, 0.0]
end = [1.0, 0.0, 0.0]
elements = 4
section = "s"
[[clamps]]
node = "b:start"
[[loads]]
node = "b:end"
force = [0.0, 0.0, 1e-3]
time_function = "up"
[solver]
dt = 1e-3
t_end = 0.02
output_every = 5
"""


def write(tmp_path, text, name="deck.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_embedded_beam_deck_has_the_paper_data():
    d = load_deck(MODELS / "embedded_beam.toml").domain
    assert len(d.nodes) == 13 and len(d.elements) == 12
    sec = d.elements[0].formulation.section
    assert (sec.EI2, sec.GJ, sec.EA, sec.rhoA, sec.rhoJ2) == (100.0, 100.0, 4.0, 6.4e-7, 1.6e-5)
    load = d.loading[0]
    assert load.moment and not load.follower and d.node(load.node).label == "beam:12"
    assert np.allclose(load.vector * load.time_function(2.0), [0.0, -2 * np.pi * 100.0 / 10.0, 0.0])
    assert load.time_function(1.0) == pytest.approx(0.5)
    assert d.solver.dt == 2e-4 and d.solver.t_end == 2.0 and d.solver.damping == 25.0
    assert d.critical_time_step() / d.solver.dt == pytest.approx(1.66, abs=0.01)  # docs/benchmarks.md §1: margin 1.66


def test_refine_override_multiplies_elements_and_divides_the_step(tmp_path):
    d = load_deck(write(tmp_path, GOOD), overrides={"refine": 3}).domain
    assert len(d.elements) == 12 and d.solver.dt == pytest.approx(1e-3 / 3) and d.solver.output_every == 15


@pytest.mark.parametrize(
    "change, entry, words",
    [
        (("elements = 4", "elemnts = 4"), "beams[0].elemnts", "did you mean 'elements'"),
        (('node = "b:end"', 'node = "b:tip"'), "loads[0].node", "beam 'b' has no node 'tip'"),
        (('node = "b:start"', 'node = "c:start"'), "clamps[0].node", "no node 'c:start'"),
        (("EA = 1e3", "EA = -1e3"), "sections.s.EA", "must be positive"),
        (("dt = 1e-3", "dt = 5e-2"), "solver.dt", "critical time step"),
        (("t_end = 0.02", "t_end = 0.0205"), "solver.t_end", "whole number of steps"),
        (('section = "s"', 'section = "t"'), "beams[0].section", "no section 't'"),
        (('time_function = "up"', 'time_function = "upp"'), "loads[0].time_function", "did you mean 'up'"),
        (('kind = "ramp"', 'kind = "rampp"'), "time_functions.up.kind", "did you mean 'ramp'"),
        (("end = [1.0, 0.0, 0.0]", "end = [0.0, 0.0, 0.0]"), "beams[0]", "zero-length"),
        (("force = [0.0, 0.0, 1e-3]", "force = [0.0, 1e-3]"), "loads[0].force", "list of 3 numbers"),
        (("[solver]", "[[joints]]\nkind = 'revolut'\nbody_i = 'b:end'\npoint = [1.0, 0.0, 0.0]\n[solver]"),
         "joints[0].kind", "did you mean 'revolute'"),
        (("[solver]", "[[joints]]\nkind = 'revolute'\nbody_i = 'rotor'\npoint = [1.0, 0.0, 0.0]\n[solver]"),
         "joints[0].body_i", "no node 'rotor'"),
        (("[solver]", "[[joints]]\nkind = 'rotation_drive'\nbody_i = 'b:end'\npoint = [1.0, 0.0, 0.0]\n[solver]"),
         "joints[0]", "needs a time_function"),
        (("[solver]", "[solver\n"), "not valid TOML", "line"),
    ],
)
def test_bad_decks_are_rejected_with_one_clear_message(tmp_path, change, entry, words):
    path = write(tmp_path, GOOD.replace(*change))
    with pytest.raises(DeckError) as info:
        load_deck(path)
    message = str(info.value)
    assert str(path) in message
    assert entry in message
    assert words in message
    assert "\n" not in message.strip() or "TOML" in message


@pytest.mark.parametrize(
    "text, entry, words",
    [
        ("sections = 5\n" + GOOD.split("[sections.s]")[0], "sections", "write it as [sections.NAME]"),
        (GOOD.replace('kind = "ramp"', 'kind = ["ramp"]'), "time_functions.up.kind", "unknown kind"),
        (GOOD.replace("[solver]", "[[fixed]]\nnode = 'b:end'\ndofs = [[1]]\n[solver]"), "fixed[0].dofs",
         "names: x, y, z, rx, ry, rz"),
        (GOOD.replace("[solver]", "[[fixed]]\nnode = 'b:end'\ndofs = ['rzz']\n[solver]"), "fixed[0].dofs",
         "did you mean 'rz'"),
        ("checks = 3\n" + GOOD, "checks", "write it as [checks.NAME]"),
        (GOOD.replace("output_every = 5", "output_every = 5\nconsistent_initial_velocities = 'yes'"),
         "solver.consistent_initial_velocities", "true or false"),
        (GOOD.replace("elements = 4", "elements = 2.5"), "beams[0].elements", "integer"),
        (GOOD.replace("elements = 4", "elements = 0"), "beams[0].elements", "integer ≥ 1"),
        (GOOD.replace("rhoA = 1.0", "rhoA = 0.0"), "sections.s.rhoA", "must be positive"),
        (GOOD.replace("[[beams]]", "[[nodes]]\nlabel = 'n'\nposition = [0.0, 1.0, 0.0]\n"
                      "rotation = [1.0, 0.0, 0.0, 1.0]\n[[beams]]"), "nodes[0].rotation", "unit norm"),
        (GOOD.replace("[meta]", "[metta]\nname = 'x'\n[meta]"), "deck.metta", "did you mean 'meta'"),
        (GOOD.replace("[solver]\n", "[solver]\nalgorithm = 'newmark'\n"), "solver.algorithm",
         "staggered_central_difference"),
    ],
)
def test_malformed_structure_is_a_deck_error_not_a_traceback(tmp_path, text, entry, words):
    path = write(tmp_path, text)
    with pytest.raises(DeckError) as info:
        load_deck(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {entry}") and words in message and "\n" not in message


def test_unreadable_files_are_deck_errors(tmp_path):
    with pytest.raises(DeckError, match="no such deck file"):
        load_deck(tmp_path / "missing.toml")
    with pytest.raises(DeckError, match="it is a directory"):
        load_deck(tmp_path)
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe[meta]\n")
    with pytest.raises(DeckError, match="not a UTF-8 text file"):
        load_deck(binary)


def test_toml_syntax_error_gives_the_line(tmp_path):
    path = write(tmp_path, GOOD.replace("[solver]", "[solver"))
    line = GOOD.splitlines().index("[solver]") + 1
    with pytest.raises(DeckError, match=rf"not valid TOML: .*\(at line {line}, column"):
        load_deck(path)


def test_dt_above_critical_gives_both_numbers_and_a_dt_that_works(tmp_path):
    path = write(tmp_path, GOOD.replace("dt = 1e-3", "dt = 5e-2").replace("t_end = 0.02", "t_end = 0.1"))
    with pytest.raises(DeckError) as info:
        load_deck(path)
    message = str(info.value)
    crit = load_deck(write(tmp_path, GOOD, "ok.toml")).domain.critical_time_step()
    assert "dt = 0.05" in message and f"{crit:.4g}" in message
    suggested = float(message.split("e.g. dt = ")[1].split()[0])
    d = load_deck(path, overrides={"dt": suggested}).domain  # the suggestion is stable and divides t_end
    assert d.solver.dt == suggested < crit


def test_overrides_are_validated_and_named(tmp_path):
    path = write(tmp_path, GOOD)
    with pytest.raises(DeckError, match=r"dt override \(--dt\): dt = 1 is above the critical time step"):
        load_deck(path, overrides={"dt": 1.0})
    with pytest.raises(DeckError, match=r"t_end override \(--t-end\): .*not a whole number of steps.*use t_end = "):
        load_deck(path, overrides={"t_end": 0.0215})
    with pytest.raises(DeckError, match="must be positive"):
        load_deck(path, overrides={"t_end": -1.0})
    with pytest.raises(DeckError, match="unknown override 'dtt'"):
        load_deck(path, overrides={"dtt": 1e-3})
    d = load_deck(path, overrides={"t_end": 0.01, "dt": 5e-4}).domain
    assert (d.solver.t_end, d.solver.dt, d.solver.output_every) == (0.01, 5e-4, 10)  # output times kept


def test_deck_holds_the_domain_and_what_the_verification_reads_beside_it(tmp_path):
    """load_deck returns a Deck: the ready Domain and, outside it, the
    deck's text and path (written into results files), [meta], [checks] and [crosscheck]."""
    path = write(tmp_path, GOOD)
    d = load_deck(path)
    assert isinstance(d.domain, Domain) and d.domain.name == "tiny" and d.domain.model is not None
    assert d.text == GOOD and d.path == str(path) and d.metadata["name"] == "tiny"
    assert d.checks == {} and d.crosscheck == {}
    for field in ("metadata", "checks", "crosscheck", "deck_text", "deck_path"):
        assert not hasattr(d.domain, field), field
    assert [n.label for n in load_deck(path).domain.nodes] == [n.label for n in d.domain.nodes]
    r = d.solve(results_path=tmp_path / "results.h5")
    assert r.attrs["deck"] == GOOD and r.attrs["deck_path"] == str(path)
    bare = load_deck(path).domain.solve(results_path=tmp_path / "bare.h5")  # no deck: still a valid file
    assert bare.attrs["deck"] == "" and bare.attrs["status"] == "completed" and len(bare.time) == len(r.time)


def test_embedded_beam_states_its_checks_with_tolerances_and_reasons():
    deck = load_deck(MODELS / "embedded_beam.toml")
    d = deck.domain
    tip = deck.checks["tip_vs_elastica"]
    assert tip["tolerance"] == 0.005 and tip["relative_to"] == "L" and tip["at"] == [0.25 * k for k in range(1, 9)]
    assert deck.checks["out_of_plane"]["tolerance"] == 0.0
    assert all(spec.get("reason") for spec in deck.checks.values())
    prov = deck.metadata["provenance"]
    assert "Kromer" in prov["paper"] and prov["section"] == "5.1" and "docs/benchmarks.md" in prov["data"]
    assert d.elements[0].formulation.section.rhoJ1 == 1.6e-5 and d.solver.output_every == 50
    assert [n.label for n in d.nodes][:: 12] == ["beam:0", "beam:12"]


def test_the_documented_example_deck_loads_and_runs(tmp_path):
    doc = (MODELS.parent / "docs" / "deck.md").read_text()
    example = doc.split("## A small example")[1].split("```toml\n")[1].split("```")[0]
    d = load_deck(write(tmp_path, example)).domain
    assert len(d.nodes) == 5 and d.solve().time[-1] == pytest.approx(0.02)


def test_good_tiny_deck_runs(tmp_path):
    d = load_deck(write(tmp_path, GOOD))
    r = d.solve()
    assert r.time[-1] == pytest.approx(0.02) and len(r.time) == 5
    assert r.position("b:4")[-1][2] > 0.0
