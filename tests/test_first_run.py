"""A first result without compiling: the reference path from an empty compile cache (issue 36).

Reading a deck, assembling the Model and running it on the reference backend must start no numba compilation
(``numba:compile`` events, :class:`reference.jit.CompileTimer`): the build-time helpers (rest states, the joints'
redundancy check, load arms, the blow-up monitor, a permutation's sign) run their kernels' Python form
(:func:`reference.scalar.scalar_twin`) or plain NumPy.  They must build the same Model as the compiled
kernels, bit for bit, so that a compiled run's results do not move.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

COMPILE_EVENTS = """
import sys, warnings
import numba.core.event as event
from reference.io.deck import load_deck

warnings.simplefilter("ignore")
compiled = []


class Listener(event.Listener):
    def on_start(self, e):
        dispatcher = e.data.get("dispatcher")
        compiled.append(getattr(getattr(dispatcher, "py_func", None), "__qualname__", repr(dispatcher)))

    def on_end(self, e):
        pass


event.register("numba:compile", Listener())
for deck, overrides in [("three_bar", {"t_end": 0.01}), ("embedded_beam_static", {}), ("cantilever_modes", {}),
                        ("lee_frame", {"solver.max_points": 3}),
                        ("cantilever_modes", {"beams.0.element": "beam2_se3"})]:
    domain = load_deck(f"models/{deck}.toml", overrides={**overrides, "solver.backend": "reference"}).domain
    assert domain.solve().status == "completed", deck
print(sorted(set(compiled)))
"""
"""Four gallery decks (explicit with joints, static, modes, arc length) and a beam2_se3 mesh, read and solved on
the reference path; prints the kernels numba compiled."""


def test_reading_assembling_and_a_reference_run_compile_nothing_from_an_empty_cache(tmp_path):
    """In a fresh process with an empty NUMBA_CACHE_DIR (a warm cache or this process's earlier tests would hide a
    compilation), no numba compilation happens at all: the list of compiled kernels is empty."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    out = subprocess.run([sys.executable, "-c", COMPILE_EVENTS], cwd=ROOT, capture_output=True, text=True,
                         timeout=900, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    assert ast.literal_eval(out.stdout.strip().splitlines()[-1]) == []


def _elements(E: int, seed: int):
    """E elements of random geometry: node positions (E, 2, 3), unit Euler parameters (E, 2, 4) near a common
    triad (rest curvatures up to about 0.3 rad), stiffnesses (E, 6)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(E, 2, 3))
    p = np.array([1.0, 0.0, 0.0, 0.0]) + 0.15 * rng.normal(size=(E, 2, 4))
    p /= np.linalg.norm(p, axis=2, keepdims=True)
    return x, p, rng.uniform(0.5, 2.0, size=(E, 6))


def test_beam2_rest_states_in_python_equal_the_compiled_kernel_bit_for_bit():
    """The Python form of Beam2's rest-state kernel gives the compiled kernel's ψ0 and Γ0 exactly (tolerance 0: the
    Model's arrays feed every compiled run, whose results must stay bit for bit)."""
    from reference.elements.beam2 import _rest_strains, end_offsets
    from reference.scalar import scalar_twin

    x, p, stiff = _elements(40, 1)
    L0 = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    rel = end_offsets(p[:, 0], p[:, 1])
    plain = np.empty((40, 3)), np.empty((40, 3))
    compiled = np.empty((40, 3)), np.empty((40, 3))
    scalar_twin(_rest_strains)(x, p, L0, rel, stiff, *plain)
    _rest_strains(x, p, L0, rel, stiff, *compiled)
    assert np.array_equal(plain[0], compiled[0]) and np.array_equal(plain[1], compiled[1])


def test_joint_constraint_blocks_in_python_equal_the_compiled_kernels_bit_for_bit():
    """three_bar's Φ, Φ_t, B and B M⁻¹ at a moved configuration: the Python forms used at set-up
    (:func:`reference.joints.setup.constraint_blocks`) against the step's compiled kernels, exactly."""
    from reference.io.deck import load_deck
    from reference.joints.assembly import apply_inverse_mass, assemble_constraints
    from reference.joints.setup import constraint_blocks

    domain = load_deck(ROOT / "models" / "three_bar.toml").domain
    model = domain.initialization()
    state = domain.initial_conditions()
    rng = np.random.default_rng(2)
    x = state.x + 0.01 * rng.normal(size=state.x.shape)
    q = state.q + 0.01 * rng.normal(size=state.q.shape)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    plain = constraint_blocks(model, x, q, 0.3)
    m, J = model.n_constraints, model.joints.i.shape[0]
    compiled = np.zeros(m), np.zeros(m), np.zeros((J, 6, 12)), np.zeros((J, 6, 12))
    assemble_constraints(model, x, q, 0.3, compiled[0], compiled[1], compiled[2], np.zeros(10), np.zeros(120))
    apply_inverse_mass(model, compiled[2], compiled[3])
    for a, b in zip(plain, compiled):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("n", [0, 1, 2, 7, 480])
def test_permutation_sign_counts_the_cycles(n):
    """The sign from the cycle count (plain SciPy) against walking the cycles one by one, for random permutations
    (lee_frame's sign test takes permutations of 480 entries)."""
    from reference.linalg import permutation_sign

    rng = np.random.default_rng(n)
    for _ in range(10):
        perm = rng.permutation(n)
        seen, transpositions = np.zeros(n, dtype=bool), 0
        for start in range(n):
            k, length = start, 0
            while not seen[k]:
                seen[k], k, length = True, perm[k], length + 1
            transpositions += max(length - 1, 0)
        assert permutation_sign(perm) == (-1) ** transpositions


def test_the_first_run_bench_writes_the_element_family_into_a_copy_of_the_deck(tmp_path):
    """``flexmbs bench --first-run`` runs issue 36's beam3 case from a copy of the deck with ``element = "beam3"``
    in its beam table: the copy reads as a beam3 model, and the original is untouched."""
    from flexmbs.bench_first_run import BEAM3, _deck_with
    from reference.io.deck import load_deck

    _, deck, keys, _ = BEAM3
    before = deck.read_text(encoding="utf-8")
    copy = _deck_with(deck, keys, tmp_path)
    assert copy != deck and deck.read_text(encoding="utf-8") == before
    families = {e.formulation.family for e in load_deck(copy, overrides={"solver.dt": 1e-4}).domain.elements}
    assert families == {"beam3"}


def test_a_first_run_of_a_static_deck_takes_the_reference_path(tmp_path, monkeypatch):
    """The first-run measurement of embedded_beam_static from an empty cache: two ``flexmbs run --backend auto``
    processes; ``auto`` takes the reference path (its one line), and each process returns a positive time."""
    from flexmbs.bench_first_run import ROOT, first_and_warm

    first, warm, line = first_and_warm(ROOT / "models" / "embedded_beam_static.toml")
    assert line.startswith("backend: reference (")
    assert first > 0.0 and warm > 0.0


def test_a_large_model_builds_with_the_compiled_kernel_a_small_one_with_its_python_form():
    """:func:`reference.scalar.build_time_form`: the Python form up to PYTHON_ITEMS elements or joints (nothing to
    compile), the kernel itself above (the Python loop would cost more than the compilation at every solve)."""
    from reference.elements.beam2 import _rest_strains
    from reference.scalar import PYTHON_ITEMS, build_time_form, scalar_twin

    assert build_time_form(_rest_strains, PYTHON_ITEMS) is scalar_twin(_rest_strains)
    assert build_time_form(_rest_strains, PYTHON_ITEMS + 1) is _rest_strains


def test_rest_states_are_remembered_per_mesh_and_handed_out_as_copies():
    """``Domain.solve`` rebuilds the model at every call: Beam2's rest states of a mesh already seen are the kept
    ones (:func:`reference.scalar.remembered`), equal to a fresh evaluation, new arrays each call (changing one
    changes nothing kept), and a moved node gives new ones."""
    from reference.elements.beam2 import Beam2Formulation

    x = np.array([[[0.0, 0.0, 0.0], [0.5, 0.1, 0.0]], [[0.5, 0.1, 0.0], [1.0, 0.0, 0.2]]])
    p = np.tile([1.0, 0.0, 0.0, 0.0], (2, 2, 1))
    stiff = np.tile([1e4, 4e3, 4e3, 1.1, 1.0, 4.0], (2, 1))
    fresh = Beam2Formulation.rest_states.__wrapped__(x, p, stiff)
    first = Beam2Formulation.rest_states(x, p, stiff)
    first[1][:] = np.nan
    again = Beam2Formulation.rest_states(x, p, stiff)
    for a, b in zip(fresh, again):
        np.testing.assert_array_equal(a, b)
    moved = x.copy()
    moved[1, 1, 0] = 1.5
    assert Beam2Formulation.rest_states(moved, p, stiff)[0][1] != again[0][1]
