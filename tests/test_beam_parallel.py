"""The parallel Beam2 element loop: bit for bit the serial kernel, for any thread count."""

from __future__ import annotations

import numpy as np
import pytest

from reference.elements.beam2 import beam2_assemble, beam2_assemble_parallel
from reference.io.deck import load_deck
from reference.jit import threads, use_threads

from tests.test_sparse_constraints import ROOT


def test_parallel_element_loop_equals_the_serial_kernel_bit_for_bit(monkeypatch):
    """Roll-up mesh refined 4× (48 elements) at a randomly perturbed configuration: the forces
    and the energy of the parallel loop on 1 and 2 threads equal the serial kernel's exactly
    (each element writes its own row; the sums are taken in element order on one thread)."""
    d = load_deck(ROOT / "models" / "embedded_beam.toml", overrides={"refine": 4}).domain
    m = d.model.elements[0]  # the Beam2 family's data
    rng = np.random.default_rng(3)
    x = np.array([n.position for n in d.nodes]) + 1e-2 * rng.standard_normal((len(d.nodes), 3))
    q = np.array([n.rotation for n in d.nodes]) + 1e-2 * rng.standard_normal((len(d.nodes), 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    S_ref = np.zeros((len(d.nodes), 6))
    U_ref = beam2_assemble(x, q, m.conn, m.offset, m.L0, m.psi0, m.gamma0, m.stiff, S_ref, np.zeros(40))
    assert np.abs(S_ref).max() > 0.0
    for n in (1, 2):
        use_threads(n)
        S, W = np.full_like(S_ref, np.nan), np.zeros((m.conn.shape[0], 40))
        U = beam2_assemble_parallel(x, q, m.conn, m.offset, m.L0, m.psi0, m.gamma0, m.stiff, S, W)
        assert U == U_ref and np.array_equal(S, S_ref)
    use_threads(1)


def test_reruns_are_bit_identical_with_two_threads(monkeypatch):
    """The same deck run twice with FLEXMBS_THREADS=2 gives identical histories (and the same as
    one thread)."""
    deck = ROOT / "models" / "embedded_beam.toml"
    runs = []
    for n in ("2", "2", "1"):
        monkeypatch.setenv("FLEXMBS_THREADS", n)
        runs.append(load_deck(deck, overrides={"t_end": 0.02}).solve())
    use_threads(1)
    for r in runs[1:]:
        assert np.array_equal(r.positions, runs[0].positions) and np.array_equal(r.rotations, runs[0].rotations)


def test_bad_thread_count_is_refused(monkeypatch):
    monkeypatch.setenv("FLEXMBS_THREADS", "two")
    with pytest.raises(ValueError, match="FLEXMBS_THREADS='two': expected a positive integer"):
        threads()
