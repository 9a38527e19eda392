"""The deck's ``reduce`` key (issue 39): read by reference/io/deck_reduce.py, built by reference/io/reduced_deck.py.

A beam of a deck marked ``reduce = {modes, interfaces, basis}`` gives the same reduced body as
reference/reduced built directly; bad input is one line naming the entry; and a deck that reduces a beam is
refused by the reader in one line on the compiled backend (reduced bodies run on the reference path only).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from reference.io.deck import load_deck
from reference.io.deck_reader import DeckError
from reference.io.reduced_deck import reduced_bodies
from reference.reduced.craig_bampton import beam_matrices, craig_bampton, floating_modes, free_free
from reference.reduced.invariants import invariants

ROOT = Path(__file__).resolve().parents[1]
THREE_BAR = (ROOT / "models" / "three_bar.toml").read_text()
COUPLER = 'section = "coupler"\n'  # the coupler's entry, beams[1] of the three-bar (the crank is beams[0])


def _deck(tmp_path, reduce: str, after: str = COUPLER) -> Path:
    """The three-bar with ``reduce = …`` added to the beam entry that holds the line ``after``."""
    assert THREE_BAR.count(after) == 1
    path = tmp_path / "reduced.toml"
    path.write_text(THREE_BAR.replace(after, f"{after}reduce = {reduce}\n"))
    return path


def _direct(basis: str, interfaces: tuple, n_modes: int):
    """The coupler's modes and invariants from reference/reduced, without the deck's key."""
    domain = load_deck(ROOT / "models" / "three_bar.toml").domain
    beam = beam_matrices(domain, "coupler")
    modes = floating_modes(beam, craig_bampton(beam, interfaces, n_modes)) if basis == "craig_bampton" \
        else free_free(beam, n_modes)
    return modes, invariants(beam, modes)


@pytest.mark.parametrize("reduce, basis, interfaces, n_modes", [
    ('{ modes = 4, interfaces = ["coupler:start", "coupler:end"] }', "craig_bampton", (0, 4), 4),
    ('{ modes = 3, interfaces = ["coupler:mid"], basis = "free_free" }', "free_free", (2,), 3),
    ('{ modes = [1, 2, 3, 4], interfaces = ["coupler:start", "coupler:end"] }', "craig_bampton", (0, 4), 4),
])
def test_the_decks_reduced_body_is_the_one_built_directly(tmp_path, reduce, basis, interfaces, n_modes):
    """reduced_bodies reads the key and builds the coupler's body; its modes, modal stiffness and mass
    invariants equal those of reference/reduced called directly on the same beam (1e-12 relative: the same
    functions on the same matrices, only the eigensolver's start may differ in the last digits), and the
    interface references resolve to their positions along the beam."""
    bodies = reduced_bodies(_deck(tmp_path, reduce))
    assert list(bodies) == ["coupler"]
    body = bodies["coupler"]
    modes, inv = _direct(basis, interfaces, n_modes)
    assert body.interfaces == interfaces
    assert body.n_modes == modes.T.shape[1] == (10 if basis == "craig_bampton" else 3)  # 12 + 4 less 6 rigid
    np.testing.assert_allclose(body.modes.frequencies, modes.frequencies, rtol=1e-12)
    np.testing.assert_allclose(np.abs(body.modes.T), np.abs(modes.T), rtol=0, atol=1e-12 * np.abs(modes.T).max())
    np.testing.assert_allclose(body.K, inv.modal_stiffness, rtol=1e-12, atol=0)
    assert body.inv.mass == pytest.approx(inv.mass, rel=1e-15)
    np.testing.assert_allclose(body.inv.inertia, inv.inertia, rtol=1e-12)


def test_a_deck_that_reduces_a_beam_is_refused_in_one_line(tmp_path):
    """load_deck reads the key, then refuses the compiled backend (the three-bar's default): reduced bodies
    run on the reference path only; one line, naming the entry and the fix."""
    path = _deck(tmp_path, '{ modes = 4, interfaces = ["coupler:start", "coupler:end"] }')
    with pytest.raises(DeckError) as err:
        load_deck(path)
    assert str(err.value) == (f"{path}: beams[1].reduce: reduced bodies run on the reference path only; "
                              'set backend = "reference" (or "auto") in [solver]')


def test_the_command_line_refuses_a_reduced_deck_in_one_line(tmp_path):
    """`flexmbs run` on the same deck: exit 2 and one line on stderr, no traceback."""
    path = _deck(tmp_path, '{ modes = 4, interfaces = ["coupler:start", "coupler:end"] }')
    run = subprocess.run([sys.executable, "-m", "flexmbs", "run", str(path), "--out", str(tmp_path / "out"),
                          "--no-vtk"], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 2
    assert run.stderr.strip().splitlines() == [f"flexmbs: error: {path}: beams[1].reduce: reduced bodies run on the "
                                               'reference path only; set backend = "reference" (or "auto") in '
                                               "[solver]"]


@pytest.mark.parametrize("reduce, after, entry, problem", [
    ('{ modes = 4, interfaces = ["coupler:9"] }', COUPLER, "beams[1].reduce.interfaces[0]",
     "beam 'coupler' has no node '9'"),
    ('{ modes = 4, interfaces = ["coupler:start", "nope"] }', COUPLER, "beams[1].reduce.interfaces[1]",
     "no node 'nope'"),
    ('{ modes = 4, interfaces = ["crank"] }', COUPLER, "beams[1].reduce.interfaces[0]",
     "node 'crank' is not a node of beam 'coupler'"),
    ('{ modes = "4", interfaces = ["coupler:start"] }', COUPLER, "beams[1].reduce.modes", "expected an integer"),
    ('{ modes = 4, interfaces = ["coupler:0", "coupler:start"] }', COUPLER, "beams[1].reduce.interfaces[1]",
     "node 'coupler:start' named twice; name each interface once"),
    ('{ modes = 19, interfaces = ["coupler:start", "coupler:end"] }', COUPLER, "beams[1].reduce.modes",
     "19 modes asked of beam 'coupler', whose mesh has 18 (its 5 nodes less 2 interface nodes); ask 0 to 18"),
    ('{ modes = 25, basis = "free_free" }', COUPLER, "beams[1].reduce.modes",
     "25 modes asked of beam 'coupler', whose mesh has 24 (its 5 free nodes); ask 1 to 24"),
    ('{ modes = [1, 2, 19], interfaces = ["coupler:start", "coupler:end"] }', COUPLER, "beams[1].reduce.modes",
     "mode 19 asked of beam 'coupler', whose mesh has 18 (its 5 nodes less 2 interface nodes); name modes 1 to 18"),
    ('{ modes = [1, 2, 2], interfaces = ["coupler:start", "coupler:end"] }', COUPLER, "beams[1].reduce.modes",
     "mode numbers [1, 2, 2] repeat one or name none; name each mode once"),
    ('{ modes = [1, 0], interfaces = ["coupler:start", "coupler:end"] }', COUPLER, "beams[1].reduce.modes[1]",
     "expected an integer ≥ 1, got 0"),
    ('{ modes = 4 }', COUPLER, "beams[1].reduce.interfaces", "a Craig–Bampton basis needs at least one interface"),
    ('{ modes = 4, interface = ["coupler:start"] }', COUPLER, "beams[1].reduce.interface",
     "unknown key; did you mean 'interfaces'?"),
    ('{ modes = 4, basis = "craig" }', COUPLER, "beams[1].reduce.basis", "unknown basis 'craig'"),
    ('{ modes = 2, interfaces = ["crank"] }', 'label = "crank"\n', "beams[0].reduce",
     "a rigid bar is one rigid body, it has no modes to reduce; remove reduce or rigid"),
])
def test_bad_reduce_input_is_one_line_naming_the_entry(tmp_path, reduce, after, entry, problem):
    """Each problem the issue lists (a node that does not exist or is not the beam's, more modes than the mesh
    has, a rigid bar marked for reduction, an unknown key) as ``FILE: ENTRY: problem; fix`` in one line, from
    the reader and from reduced_bodies alike."""
    path = _deck(tmp_path, reduce, after)
    for read in (load_deck, reduced_bodies):
        with pytest.raises(DeckError) as err:
            read(path)
        message = str(err.value)
        assert "\n" not in message and message.startswith(f"{path}: {entry}: "), message
        assert problem in message, message


def test_modes_named_by_number_are_those_of_the_lowest_count():
    """``modes = [1, 2, 9]``: the fixed-interface modes 1, 2 and 9 of the coupler, the same frequencies and shapes
    (up to sign, 1e-12 of the largest entry: the same eigensolution) as the 1st, 2nd and 9th of the 9 lowest; the
    interface columns the same; likewise for free-free modes."""
    domain = load_deck(ROOT / "models" / "three_bar.toml").domain
    beam = beam_matrices(domain, "coupler")
    nine, picked = craig_bampton(beam, (0, 4), 9), craig_bampton(beam, (0, 4), [1, 2, 9])
    np.testing.assert_allclose(picked.frequencies, nine.frequencies[[0, 1, 8]], rtol=1e-12)
    columns = list(range(12)) + [12, 13, 20]
    np.testing.assert_allclose(np.abs(picked.T), np.abs(nine.T[:, columns]), rtol=0, atol=1e-12 * np.abs(nine.T).max())
    free, some = free_free(beam, 5), free_free(beam, [2, 5])
    np.testing.assert_allclose(some.frequencies, free.frequencies[[1, 4]], rtol=1e-12)
