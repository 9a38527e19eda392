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
    d = Domain.from_deck(MODELS / "embedded_beam.toml")
    assert len(d.nodes) == 13 and len(d.elements) == 12
    sec = d.elements[0].formulation.section
    assert (sec.EI2, sec.GJ, sec.EA, sec.rhoA, sec.rhoJ2) == (100.0, 100.0, 4.0, 6.4e-7, 1.6e-5)
    load = d.loading[0]
    assert load.moment and not load.follower and d.node(load.node).label == "beam:12"
    assert np.allclose(load.vector * load.time_function(2.0), [0.0, -2 * np.pi * 100.0 / 10.0, 0.0])
    assert load.time_function(1.0) == pytest.approx(0.5)
    assert d.solver.dt == 2e-4 and d.solver.t_end == 2.0 and d.solver.damping == 25.0
    assert d.critical_time_step() / d.solver.dt == pytest.approx(1.66, abs=0.01)  # BENCHMARKS: margin 1.67


def test_refine_override_multiplies_elements_and_divides_the_step(tmp_path):
    d = load_deck(write(tmp_path, GOOD), overrides={"refine": 3})
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


def test_good_tiny_deck_runs(tmp_path):
    d = load_deck(write(tmp_path, GOOD))
    r = d.solve()
    assert r.time[-1] == pytest.approx(0.02) and len(r.time) == 5
    assert r.position("b:4")[-1][2] > 0.0
