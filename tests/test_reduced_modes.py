"""Reduced flexible bodies, part 1 (issue 39): modes of a meshed beam from the project's own linearisation.

reference/reduced/craig_bampton.py builds the Craig–Bampton and free-free bases from the element families'
tangent and the lumped masses; reference/reduced/invariants.py sums the floating frame's inertia shape
integrals.  Checked here: the reduction is exact in its kept modes against the full mesh's modes analysis,
the invariants rebuild the mass matrix of the nodal definition, floating-frame modes carry no rigid motion,
and bad input is one line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from reference.io.deck import load_deck
from reference.reduced.craig_bampton import (beam_matrices, craig_bampton, floating_modes, free_free,
                                             interface_positions)
from reference.reduced.invariants import invariants, mass_matrix, nodal_rows
from reference.rotation import skew

MODELS = Path(__file__).resolve().parents[1] / "models"


@pytest.fixture(scope="module")
def cantilever():
    domain = load_deck(MODELS / "cantilever_modes.toml").domain
    return domain, beam_matrices(domain, "beam")


@pytest.fixture(scope="module")
def coupler():
    domain = load_deck(MODELS / "three_bar.toml").domain
    return domain, beam_matrices(domain, "coupler")


def test_a_clamped_free_beam_reduced_with_6_modes_keeps_the_full_meshs_frequencies(cantilever):
    """cantilever_modes (32 Beam2, clamped at its start): Craig–Bampton with the clamped node as the interface
    and 6 fixed-interface modes, the interface then held, against the full mesh's modes analysis (the modes
    algorithm on the reference path).  The 6 lowest frequencies hold the 3 lowest bending modes towards z and
    towards y.  Tolerance 1e-6 relative (the issue's): the kept modes are the full model's exactly, so only
    the two eigensolvers' round-off (~1e-13) separates them; a wrong mass or stiffness entry is O(1)."""
    domain, beam = cantilever
    basis = craig_bampton(beam, interface_positions(domain, beam, ["beam:start"]), 6)
    w2 = sla.eigh(basis.K[6:, 6:], basis.M[6:, 6:], eigvals_only=True)
    reduced = np.sqrt(w2) / (2 * np.pi)
    domain.solver.backend = "reference"
    full = domain.solve().data("modes/frequency")[:6]
    np.testing.assert_allclose(reduced, full, rtol=1e-6, atol=0)
    np.testing.assert_allclose(basis.frequencies, full, rtol=1e-6, atol=0)


def test_the_craig_bampton_basis_spans_the_rigid_motions_and_the_floating_modes_do_not(coupler):
    """The three-bar's coupler (4 Beam2, interfaces at both ends, 4 modes: 12 + 4 coordinates): the reduced
    free body has exactly six zero frequencies (its constraint modes reproduce the rigid motions); the floating
    modes (the other 10) are mass-orthogonal to them, i.e. the frame's mean axes: ``S₁ = 0`` and ``C₀ = 0``
    about the centre of mass, to round-off (1e-10 of the mass-normalised scale 1)."""
    domain, beam = coupler
    basis = craig_bampton(beam, interface_positions(domain, beam, ["coupler:start", "coupler:end"]), 4)
    assert basis.T.shape == (30, 16)
    w2 = sla.eigh(basis.K, basis.M, eigvals_only=True)
    assert np.sum(np.abs(w2) < 1e-8 * w2[-1]) == 6
    modes = floating_modes(beam, basis)
    assert modes.T.shape == (30, 10) and np.all(modes.frequencies > 1.0)  # the coupler's lowest is ~3.9 Hz
    inv = invariants(beam, modes)
    assert inv.mass == pytest.approx(5.0, rel=1e-14)  # rhoA = 1 over the 5 m coupler, lumped on its 5 nodes
    np.testing.assert_allclose(inv.first_moment, 0.0, atol=1e-13)
    assert np.abs(inv.modal_first_moment).max() < 1e-10
    assert np.abs(inv.coupling).max() < 1e-10
    np.testing.assert_allclose(inv.modal_mass, np.eye(10), atol=1e-12)


@pytest.mark.parametrize("kind", ["free_free", "craig_bampton"])
def test_the_invariants_rebuild_the_mass_matrix_of_the_nodal_definition(cantilever, kind):
    """The mass matrix from the invariants against ``Σ G_iᵀ diag(m_i I, J_i) G_i`` summed node by node
    (reference/reduced/invariants.py's docstring) at a random frame rotation and modal coordinates, about an
    origin off the centre of mass (so S₀ ≠ 0).  1e-12 relative: the same sums in another order."""
    domain, beam = cantilever
    basis = free_free(beam, 5) if kind == "free_free" else floating_modes(
        beam, craig_bampton(beam, interface_positions(domain, beam, ["beam:start", "beam:end"]), 3))
    inv = invariants(beam, basis, origin=np.array([-0.2, 0.1, 0.05]))
    m, J, Pt, Pr = nodal_rows(beam, basis)
    rng = np.random.default_rng(39)
    r = basis.T.shape[1]
    q, A = 0.3 * rng.normal(size=r), sla.expm(skew(rng.normal(size=3)))
    expected = np.zeros((6 + r, 6 + r))
    for i in range(len(m)):
        G = np.zeros((6, 6 + r))
        G[:3, :3], G[3:, 3:6] = np.eye(3), np.eye(3)
        G[:3, 3:6] = -A @ skew(beam.x[i] - inv.origin + Pt[i] @ q)
        G[:3, 6:], G[3:, 6:] = A @ Pt[i], Pr[i]
        expected += G.T @ sla.block_diag(m[i] * np.eye(3), J[i]) @ G
    M = mass_matrix(inv, A, q)
    assert np.abs(M - expected).max() <= 1e-12 * np.abs(expected).max()
    assert np.abs(inv.first_moment).max() > 0.1  # the origin is off the centre of mass: S₀ is tested


def test_the_free_free_modes_of_a_beam_are_its_unsupported_elastic_modes(cantilever):
    """free_free skips exactly the six rigid motions: its modes are the 7th… eigenpairs of the beam's (K, M),
    (LAPACK's dense solver here, the project's shift-invert one there: 3e-10 apart, 1e-8 asserted), and they are
    mass-orthogonal to a rigid rotation (C₀ = 0), 1e-10 of the normalised scale."""
    _, beam = cantilever
    basis = free_free(beam, 4)
    w2 = sla.eigh(beam.K, beam.M, eigvals_only=True)
    np.testing.assert_allclose((2 * np.pi * basis.frequencies) ** 2, w2[6:10], rtol=1e-8)  # two solvers: 3e-10
    assert np.abs(invariants(beam, basis).coupling).max() < 1e-10


@pytest.mark.parametrize("call, message", [
    (lambda d, b: interface_positions(d, b, ["coupler:9"]), "reduce.interfaces: beam 'coupler' has no node '9'"),
    (lambda d, b: interface_positions(d, b, ["nope"]), "reduce.interfaces: no node 'nope'"),
    (lambda d, b: interface_positions(d, b, ["crank"]), "reduce.interfaces: node 'crank' is not a node of beam"),
    (lambda d, b: interface_positions(d, b, ["coupler:0", "coupler:start"]), "named twice"),
    (lambda d, b: craig_bampton(b, (0, 4), 19), "reduce.modes: 19 modes asked of beam 'coupler'"),
    (lambda d, b: free_free(b, 25), "reduce.modes: 25 modes asked of beam 'coupler', which has 24 elastic"),
    (lambda d, b: craig_bampton(b, (), 2), "Craig–Bampton needs at least one interface"),
    (lambda d, b: beam_matrices(d, "crank"), "reduce: no flexible beam 'crank' (a rigid bar has no modes)"),
])
def test_bad_reduction_input_is_one_line(coupler, call, message):
    domain, beam = coupler
    with pytest.raises(ValueError) as refused:
        call(domain, beam)
    assert message in str(refused.value) and "\n" not in str(refused.value)
