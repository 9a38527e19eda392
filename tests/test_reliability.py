"""Issue 12's reproducers: each is the documented example deck plus one change, and each ends in one
line ``FILE: ENTRY: problem; fix`` (a DeckError; ``flexmbs: error: …``, exit 2 on the command line),
at most 300 characters after the file name, quickly, without warnings."""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from flexmbs.cli import main
from reference.io.deck import DeckError, load_deck

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = (ROOT / "docs" / "deck.md").read_text().split("## A small example")[1].split("```toml\n")[1].split("```")[0]
BODY = '[[rigid_bodies]]\nlabel = "rb"\nmass = 1.0\ninertia = [1.0, 1.0, 1.0]\nposition = [2.0, 0.0, 0.0]\n'
JOINT = '[[joints]]\nkind = "revolute"\nbody_i = "b:end"\npoint = [1.0, 0.0, 0.0]\n'
MAX_CHARS = 300


def with_body(line: str) -> str:
    return EXAMPLE.replace("[solver]", BODY + line + "\n[solver]")


def changed(old: str, new: str) -> str:
    assert EXAMPLE.count(old) == 1, old
    return EXAMPLE.replace(old, new)


REPRODUCERS = {
    "array nested 600 deep": ("line 1", "x = " + "[" * 600 + "]" * 600 + "\n" + EXAMPLE, "nested more than"),
    "dotted key 100,000 deep": ("line 1", "a" + ".a" * 100_000 + " = 1\n" + EXAMPLE, "dotted key"),
    "t_end = 1e308": ("solver.t_end", changed("t_end = 0.02 ", "t_end = 1e308 "), "outside the range"),
    "dt = 5e-324": ("solver.dt", changed("dt = 1e-3 ", "dt = 5e-324 "), "outside the range"),
    "t_end = 1e29 (overflowing step count)": ("solver", changed("t_end = 0.02 ", "t_end = 1e29 "), "above the limit"),
    "dt = 1e-29 (overflowing step count)": ("solver", changed("dt = 1e-3 ", "dt = 1e-29 "), "above the limit"),
    "GA3 = 1e308": ("sections.steel_rod.GA3", changed("GA3 = 1e3", "GA3 = 1e308"), "outside the range"),
    "GA3 = 1e30 (tiny critical step)": ("solver.dt", changed("GA3 = 1e3", "GA3 = 1e30"), "above the limit"),
    "checks with a non-table entry": ("checks.quick", EXAMPLE + "\n[checks]\nquick = false\n", "expected a table"),
    "superscript digit in a reference": ("loads[0].node", changed('node = "b:end"', 'node = "b:²"'), "no node"),
    "full-width digit in a reference": ("loads[0].node", changed('node = "b:end"', 'node = "b:４"'), "no node"),
    "a billion elements": ("beams[0].elements", changed("elements = 4", "elements = 1000000000"), "limit"),
    "10^12 steps": ("solver", changed("dt = 1e-3 ", "dt = 2e-14 "), "raise solver.max_steps"),
    "rigid body rotation of norm 2": ("rigid_bodies[0].rotation", with_body("rotation = [2.0, 0.0, 0.0, 0.0]"),
                                      "unit norm"),
    "rigid body rotation zero": ("rigid_bodies[0].rotation", with_body("rotation = [0.0, 0.0, 0.0, 0.0]"),
                                 "unit norm"),
    "zero rotation with consistent initial velocities": (
        "rigid_bodies[0].rotation",
        with_body("rotation = [0.0, 0.0, 0.0, 0.0]").replace("damping = 0.0", "consistent_initial_velocities = true"),
        "unit norm"),
    "non-symmetric inertia": ("rigid_bodies[0].inertia", EXAMPLE.replace(
        "[solver]", BODY.replace("[1.0, 1.0, 1.0]", "[[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]") + "[solver]"),
        "not symmetric"),
    "non-positive inertia": ("rigid_bodies[0].inertia", EXAMPLE.replace(
        "[solver]", BODY.replace("[1.0, 1.0, 1.0]", "[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]") + "[solver]"),
        "not positive definite"),
    "empty rigid body position": ("rigid_bodies[0].position", EXAMPLE.replace(
        "[solver]", BODY.replace("position = [2.0, 0.0, 0.0]", "position = []") + "[solver]"), "list of 3 numbers"),
    "200,000-number force": ("loads[0].force", changed("force = [0.0, 0.0, 1e-3]",
                                                       "force = [" + ", ".join(["1.0"] * 200_000) + "]"),
                             "(200000 items)"),
    "zero joint axis": ("joints[0].axis", EXAMPLE.replace("[solver]", JOINT + "axis = [0.0, 0.0, 0.0]\n[solver]"),
                        "zero vector"),
    "NUL in meta.name": ("meta.name", changed('name = "cantilever"', 'name = "a\\u0000b"'), "unusable name"),
    "slash in meta.name": ("meta.name", changed('name = "cantilever"', 'name = "sub/dir"'), "unusable name"),
    "meta.name escaping the output folder": ("meta.name", changed('name = "cantilever"', 'name = "../../escaped"'),
                                             "unusable name"),
    "a quoted key holding a newline (make fuzz)": ("deck.secti\\ns", '"secti\\ns" = 1\n' + EXAMPLE, "unknown key"),
}


def assert_one_clean_line(message: str, path: Path, entry: str, words: str) -> None:
    assert "\n" not in message and len(message) - len(str(path)) <= MAX_CHARS, (len(message), message[:400])
    assert message.startswith(f"{path}: {entry}"), message
    assert words in message, message


@pytest.mark.parametrize("name", list(REPRODUCERS))
def test_reproducer_is_one_clean_deck_error(tmp_path, name):
    entry, text, words = REPRODUCERS[name]
    path = tmp_path / "deck.toml"
    path.write_text(text, encoding="utf-8")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DeckError) as info:
            load_deck(path)
    assert time.perf_counter() - t0 < 5.0  # "in under a few seconds"; the parser guard is what keeps it so
    assert_one_clean_line(str(info.value), path, entry, words)


def test_refine_override_of_a_billion_is_refused(tmp_path):
    path = tmp_path / "deck.toml"
    path.write_text(EXAMPLE)
    with pytest.raises(DeckError) as info:
        load_deck(path, overrides={"refine": 10**9})
    assert_one_clean_line(str(info.value), path, "override refine (--refine)", "above the limit")


def test_max_steps_raises_the_step_limit(tmp_path):
    path = tmp_path / "deck.toml"
    path.write_text(changed("t_end = 0.02 ", "t_end = 2000.0 ").replace("damping = 0.0", "max_steps = 3000000"))
    assert load_deck(path).domain.solver.t_end == 2000.0
    path.write_text(changed("t_end = 0.02 ", "t_end = 2000.0 "))
    with pytest.raises(DeckError, match="2e\\+09 steps, above the limit of 1e\\+09"):
        load_deck(path, overrides={"dt": 1e-6})


@pytest.mark.parametrize("name", ["10^12 steps", "a billion elements", "zero joint axis", "NUL in meta.name"])
def test_cli_gives_one_line_and_exit_2(tmp_path, capsys, name):
    entry, text, words = REPRODUCERS[name]
    path = tmp_path / "deck.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 2
    captured = capsys.readouterr()
    err = captured.err.rstrip("\n")
    assert err.startswith(f"flexmbs: error: {path}: {entry}") and "\n" not in err and words in err
    assert len(err) <= MAX_CHARS + len(f"flexmbs: error: {path}") and not (tmp_path / "out" / "results.h5").exists()


def test_cli_refine_override_of_a_billion(tmp_path, capsys):
    path = tmp_path / "deck.toml"
    path.write_text(EXAMPLE)
    assert main(["run", str(path), "--refine", "1000000000", "--out", str(tmp_path / "out")]) == 2
    assert "above the limit" in capsys.readouterr().err


def test_redundancy_message_names_the_loop_and_its_fix_works():
    """The planar four-bar of rigid bars closed by four revolute joints: the message names all four
    joints of the loop and its fix (ε on one of them); docs/deck.md gives the other fix, checked here:
    one revolute replaced by a spherical still leaves a redundant equation; a spherical and a universal
    joint remove them, and the mechanism then runs (the crank swings under a sideways gravity)."""
    from reference.domain import Domain, SolverSettings
    from reference.interactions import Gravity

    from test_pendulum import BAR

    def four_bar(kinds):
        d = Domain("rigid four-bar")
        crank = d.add_rigid_bar("crank", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), BAR, axis2=(1.0, 0.0, 0.0))
        coupler = d.add_rigid_bar("coupler", (0.0, 1.0, 0.0), (4.0, 4.0, 0.0), BAR)
        rocker = d.add_rigid_bar("rocker", (4.0, 4.0, 0.0), (4.0, 0.0, 0.0), BAR, axis2=(1.0, 0.0, 0.0))
        d.add_joint("revolute", crank, None, [0.0, 0.0, 0.0], label="O1")
        d.add_joint("revolute", coupler, crank, [0.0, 1.0, 0.0], label="A")
        d.add_joint(kinds[0], rocker, coupler, [4.0, 4.0, 0.0], label="B", axis=(0.0, 0.0, 1.0),
                    reference=(4.0, 3.0, 0.0) if kinds[0] == "universal" else None)
        d.add_joint(kinds[1], rocker, None, [4.0, 0.0, 0.0], label="O3")
        d.add_interaction(Gravity(np.array([-9.81, 0.0, 0.0])))
        d.solver = SolverSettings(dt=1e-3, t_end=0.2, output_every=100)
        return d

    with pytest.raises(ValueError) as info:
        four_bar(("revolute", "revolute")).initialization()
    message = str(info.value)
    assert "3 equation(s)" in message and "in the loop O1, A, B, O3" in message, message
    # one line of at most ~200 characters: the loop's own fix, the other fixes in the docs it names
    assert "fix: epsilon > 0 on O3" in message and "docs/deck.md" in message and len(message) <= 200, message
    with pytest.raises(ValueError, match="1 equation"):
        four_bar(("revolute", "spherical")).initialization()
    d = four_bar(("universal", "spherical"))
    r = d.solve()
    assert r.status == "completed" and r.constraint_violation.max() < 1e-4  # the bound of test_pendulum's linkage
    assert r.position("crank")[-1][0] < r.position("crank")[0][0] - 1e-3  # it swings under gravity


def test_a_long_name_and_its_fix_fit_the_message_length(tmp_path):
    """make fuzz (10,000 cases): a 400-character beam name in a line load gave 302 characters after the file
    name — the two separators were not counted. Every message keeps to 300 after the file name."""
    from reference.io.deck_reader import MESSAGE_CHARS, Reader

    reader = Reader(tmp_path / "deck.toml")
    for problem, fix in (("no flexible beam '" + "x" * 400 + "'", "beams: b"), ("p" * 50, "f" * 500),
                         ("q" * 500, "g" * 500), ("short", "")):
        message = str(reader.fail("line_loads[0].beam", problem, fix))
        assert len(message) - len(str(tmp_path / "deck.toml")) <= MESSAGE_CHARS, message
