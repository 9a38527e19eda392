"""Issue 23's engine reproducers, each the documented example deck (or a shipped model) plus one
change: non-finite loads named as such, pathological formulas refused in one line within a second,
zero-length springs, parallel universal-joint axes without warning lines, bounded counts, the API
validating like the deck, far joints warned about in one line, lean rigid bars, override and
blow-up messages kept short, and a static run's bounded Newton history."""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from flexmbs.cli import main
from reference.errors import SolverDiverged
from reference.io.deck import DeckError, load_deck
from reference.validation import JOINT_OFFSET, ModelWarning, joint_offsets

from test_reliability import EXAMPLE, MAX_CHARS, assert_one_clean_line, changed

MODELS = Path(__file__).resolve().parent.parent / "models"
RAMP = 'kind = "ramp"                   # 0 -> 1 on [0, 0.01], held after\nt0 = 0.0\nt1 = 0.01\n'
STATIC = {"dt = 1e-3                       # below the critical step of this mesh\n": "load_steps = 4\n",
          "damping = 0.0\n": ""}


def with_algorithm(text: str, algorithm: str) -> str:
    text = text.replace('algorithm = "staggered_central_difference"', f'algorithm = "{algorithm}"')
    if algorithm == "static":
        for old, new in STATIC.items():
            text = text.replace(old, new)
    return text


def write(tmp_path, text: str) -> Path:
    path = tmp_path / "deck.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("algorithm", ["generalized_alpha", "static", "staggered_central_difference"])
@pytest.mark.parametrize("formula, value", [("1/t", "inf"), ("log(t-1)", "nan")])
def test_a_non_finite_load_is_named_as_such(tmp_path, algorithm, formula, value):
    """Before: "the Newton matrix became singular" (generalized-α, static)."""
    text = with_algorithm(changed(RAMP, f'kind = "expression"\nexpr = "{formula}"\n'), algorithm)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SolverDiverged) as info:
            load_deck(write(tmp_path, text)).domain.solve()
    message = str(info.value)
    assert message.startswith(f"the load on node 'b:4' is not finite at t = 0 (its time function gives {value})")
    assert "\n" not in message and "singular" not in message and len(message) <= 200, message


@pytest.mark.parametrize("formula, words", [
    ("9**9**9", "an exponent above 100"),
    ("t**1e9", "an exponent above 100"),
    ("2**(2**30)", "an exponent above 100"),
    ("exp(exp(t))", "an exponential of an exponential"),
    ("exp(800)", "exceeds 1e300"),
    ("+".join(["sin(t)"] * 100), "above the limit of 500"),
    ("*".join(["(1+t)"] * 70), "more than 200 operations"),
])
def test_a_pathological_formula_is_refused_in_one_line_within_a_second(tmp_path, formula, words):
    """Before: ``9**9**9`` hung the reader (sympy computed the 370-million-digit integer)."""
    path = write(tmp_path, changed(RAMP, f'kind = "expression"\nexpr = "{formula}"\n'))
    t0 = time.perf_counter()
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert time.perf_counter() - t0 < 1.0
    assert_one_clean_line(str(info.value), path, "time_functions.up.expr", words)


def test_an_ordinary_formula_still_reads(tmp_path):
    d = load_deck(write(tmp_path, changed(RAMP, 'kind = "expression"\nexpr = "sin(3*t)**2 + (1 + t)**(1/2)"\n')))
    d = d.domain
    assert d.solve().status == "completed"


SPRING = ('[[rigid_bodies]]\nlabel = "rb"\nmass = 1.0\ninertia = [1.0, 1.0, 1.0]\nposition = [1.0, 0.0, 0.0]\n'
          '[[springs]]\nkind = "point_to_point"\nbody_i = "rb"\nbody_j = "b:end"\npoint_i = [1.0, 0.0, 0.0]\n'
          'point_j = [1.0, 0.0, 0.0]\nstiffness = 10.0\nrest_length = 0.5\n')


def test_a_zero_length_spring_is_refused_in_one_line(tmp_path):
    """Before: generalized-α ended "the run failed at t = 0: ZeroDivisionError: division by zero"."""
    path = write(tmp_path, with_algorithm(EXAMPLE.replace("[solver]", SPRING + "[solver]"), "generalized_alpha"))
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert_one_clean_line(str(info.value), path, "springs[0]", "the points coincide")
    assert "Error" not in str(info.value).replace("DeckError", "")


def test_a_universal_joint_with_parallel_pins_gives_no_warning_line(tmp_path):
    joint = ('[[joints]]\nkind = "universal"\nbody_i = "b:end"\npoint = [1.0, 0.0, 0.0]\naxis = [0.0, 0.0, 1.0]\n'
             'reference = [0.0, 0.0, 2.0]\n')
    path = write(tmp_path, EXAMPLE.replace("[solver]", joint + "[solver]"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DeckError) as info:
            load_deck(path).domain
    assert_one_clean_line(str(info.value), path, "joints[0]", "parallel to its axis")


@pytest.mark.parametrize("line, entry", [
    ("max_iterations = 9223372036854775807", "solver.max_iterations"),
    ("output_every = 9223372036854775807", "solver.output_every"),
    ("max_steps = 9223372036854775807", "solver.max_steps"),
])
def test_counts_are_bounded(tmp_path, line, entry):
    path = write(tmp_path, with_algorithm(EXAMPLE, "generalized_alpha").replace("output_every = 5\n", "") + line + "\n")
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert_one_clean_line(str(info.value), path, entry, "above the limit of")


def test_load_steps_are_bounded(tmp_path):
    path = write(tmp_path, with_algorithm(EXAMPLE, "static").replace("load_steps = 4", "load_steps = 9223372036854775807"))
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert_one_clean_line(str(info.value), path, "solver.load_steps", "above the limit of")


def test_gravity_needs_a_vector_in_the_api():
    """Before: ``Gravity(-9.81)`` pulled along x, y and z."""
    from reference.interactions import Gravity, NodalLoad

    with pytest.raises(ValueError, match=r"^Gravity g \[m/s²\]: expected a vector of 3 finite numbers, got -9\.81; "
                       r"give a vector, e\.g\. Gravity\(\[0\.0, 0\.0, -9\.81\]\)$"):
        Gravity(-9.81)
    assert Gravity([0.0, 0.0, -1.0]).g.tolist() == [0.0, 0.0, -1.0]
    with pytest.raises(ValueError, match="expected a vector of 3 finite numbers"):
        NodalLoad(None, [1.0, np.nan, 0.0])


FAR = ('[[rigid_bodies]]\nlabel = "rb"\nmass = 1.0\ninertia = [1.0, 1.0, 1.0]\nposition = [1.0, 0.0, 0.3]\n'
       '[[joints]]\nlabel = "pin"\nkind = "spherical"\nbody_i = "rb"\nbody_j = "b:end"\npoint = [1.0, 0.3, 0.15]\n')


def test_a_joint_far_from_both_bodies_is_warned_about_in_one_line(tmp_path, capsys):
    """0.34 m off both bodies in a 1.04 m model (issue 23: 0.3 m in 1 m moved the tip 0.56 m):
    one warning naming the joint and the distances, on the command line one line; the run goes on."""
    path = write(tmp_path, EXAMPLE.replace("[solver]", FAR + "[solver]"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert load_deck(path).domain.solve().status == "completed"
    lines = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert len(lines) == 1 and len(caught) == 1, [str(w.message) for w in caught]
    assert lines[0].startswith("joint 'pin': its point is 0.335 from 'rb' and 0.335 from 'b:4'"), lines[0]
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert err == [f"flexmbs: warning: {lines[0]}"], err


def test_no_shipped_model_has_a_far_joint():
    """The threshold (JOINT_OFFSET of the model size) is quiet on every shipped model."""
    assert JOINT_OFFSET == 1e-3
    for deck in sorted(MODELS.glob("*.toml")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            assert joint_offsets(load_deck(deck).domain) == [], deck.name


def test_a_rigid_bar_needs_only_its_mass_data(tmp_path):
    """Before: a rigid bar demanded the ten section keys and ``elements``, never used."""
    bar = ('[sections.bar]\nrhoA = 1.0\nrhoJ1 = 1e-3\nrhoJ2 = 1e-3\nrhoJ3 = 1e-3\n[[beams]]\nlabel = "rb"\n'
           'start = [1.0, 0.0, 0.0]\nend = [2.0, 0.0, 0.0]\nsection = "bar"\nrigid = true\n'
           '[[joints]]\nkind = "spherical"\nbody_i = "rb"\nbody_j = "b:end"\npoint = [1.0, 0.0, 0.0]\n')
    d = load_deck(write(tmp_path, EXAMPLE.replace("[solver]", bar + "[solver]"))).domain
    assert d.node("rb").mass == 1.0 and d.solve().status == "completed"
    # a flexible beam on that section still needs the stiffnesses
    path = write(tmp_path, EXAMPLE.replace("[solver]", bar.replace("rigid = true\n", "elements = 2\n") + "[solver]"))
    with pytest.raises(DeckError, match="sections.bar: missing required key 'EA'"):
        load_deck(path).domain


def test_a_bare_beam_label_offers_start_end_or_an_index(tmp_path):
    path = write(tmp_path, changed('node = "b:end"', 'node = "b"'))
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert_one_clean_line(str(info.value), path, "loads[0].node", "'b' is a beam, not a node; use 'b:start', 'b:end' "
                          "or an index 'b:0'…'b:4'")


@pytest.mark.parametrize("key", ["x" * 300, "a" * 300 + ".b", "beams.０.elements"])
def test_override_messages_are_short_and_indices_ascii(tmp_path, key):
    path = write(tmp_path, EXAMPLE)
    with pytest.raises(DeckError) as info:
        load_deck(path, overrides={key: 3}).domain
    message = str(info.value)
    assert "\n" not in message and len(message) - len(str(path)) <= MAX_CHARS and "x" * 61 not in message, message


def test_blow_up_messages_are_at_most_200_characters(tmp_path):
    """Before: 380–430 characters.  The two blow-ups of tests/test_blowup.py: the energy balance
    (dt = 1.01 × critical) and the stretch check (a huge follower load)."""
    d = load_deck(MODELS / "embedded_beam.toml").domain
    dt = 1.01 * d.critical_time_step()
    d.solver.dt, d.solver.t_end, d.solver.output_every = dt, 5000 * dt, 50
    with pytest.raises(SolverDiverged) as info:
        d.solve()
    assert "energy balance failed" in str(info.value) and len(str(info.value)) <= 200, str(info.value)
    path = write(tmp_path, EXAMPLE.replace("force = [0.0, 0.0, 1e-3]", "force = [0.0, 0.0, 2e6]")
                 .replace('frame = "inertial"', 'frame = "body"').replace("t_end = 0.02 ", "t_end = 2.0 "))
    with pytest.raises(SolverDiverged) as info:
        load_deck(path).domain.solve()
    assert "likely cause: the loads" in str(info.value) and len(str(info.value)) <= 200, str(info.value)


def test_a_static_run_keeps_a_bounded_newton_history(tmp_path):
    """The static run state keeps the Newton residuals of the last load level only (a run of many
    load steps used to keep every step's, ~200 B a step)."""
    d = load_deck(write(tmp_path, with_algorithm(EXAMPLE, "static").replace("load_steps = 4", "load_steps = 200")
                        .replace("output_every = 5", "output_every = 50"))).domain
    assert d.solve().status == "completed"
    history = d.last_run["solver"].history
    assert 1 <= len(history) <= 25 and all(isinstance(r, float) for r in history)


def test_the_api_refuses_what_the_deck_refuses(tmp_path):
    """One wording for both (reference/validation.py): a zero joint axis, a position that is no vector."""
    from reference.domain import Domain
    from reference.validation import ZERO_DIRECTION

    d = Domain()
    node = d.add_node([0.0, 0.0, 0.0], label="n")
    with pytest.raises(ValueError, match=r"^joint 'pin': axis: a direction cannot be the zero vector; give a non-zero"):
        d.add_joint("revolute", node, None, [0.0, 0.0, 0.0], axis=[0.0, 0.0, 0.0], label="pin")
    with pytest.raises(ValueError, match=r"^node 'm': position: expected a vector of 3 finite numbers, got 1\.0$"):
        d.add_node(1.0, label="m")
    path = write(tmp_path, EXAMPLE.replace("[solver]", '[[joints]]\nkind = "revolute"\nbody_i = "b:end"\n'
                                          'point = [1.0, 0.0, 0.0]\naxis = [0.0, 0.0, 0.0]\n[solver]'))
    with pytest.raises(DeckError) as info:
        load_deck(path).domain
    assert str(info.value) == f"{path}: joints[0].axis: {ZERO_DIRECTION[0]}; {ZERO_DIRECTION[1]}"


def test_the_names_a_model_needs_come_from_reference():
    """A model built in Python needs no module paths: the deck's vocabulary is exported from ``reference``."""
    import reference
    from reference import Domain, Gravity, Section, SolverSettings

    assert Domain.__module__ == "reference.domain" and Section.__module__ == "reference.elements.section"
    assert SolverSettings().algorithm == "staggered_central_difference"
    assert Gravity([0.0, 0.0, -9.81]).g[2] == -9.81
    for name in reference.__all__:
        assert getattr(reference, name).__doc__, name


def test_domain_solve_runs_the_solution_loop_it_names():
    """The Domain does not import the loop (tests/test_layering.py): ``Domain.solve`` resolves the loop it names,
    :func:`reference.solution.solve`, on the first solve, as the algorithms' registry resolves its classes."""
    import reference.solution
    from reference import Domain, solve
    from reference.algorithms import resolve

    assert resolve(Domain.solution_loop) is reference.solution.solve is solve


def test_the_ground_has_the_decks_name_in_the_api():
    """Deck and API use one word for the ground: ``"ground"`` (None is accepted too); any other string is
    refused in one line."""
    from reference import Domain, PointToPoint

    d = Domain("pendulum")
    bob = d.add_rigid_body("bob", 1.0, [1.0, 1.0, 1.0], [1.0, 0.0, 0.0])
    pin = d.add_joint("revolute", "ground", bob, [0.0, 0.0, 0.0], label="pin")
    assert pin.body_i is bob and pin.body_j is None  # the ground kept on side j
    spring = PointToPoint(bob, [1.0, 0.0, 0.0], "ground", [0.0, 0.0, 0.0], stiffness=1.0, label="s")
    assert spring.body_j is None
    with pytest.raises(ValueError, match=r"^force element 's' body_j: got the string 'grund'; give a node"):
        PointToPoint(bob, [1.0, 0.0, 0.0], "grund", [0.0, 0.0, 0.0], stiffness=1.0, label="s")
