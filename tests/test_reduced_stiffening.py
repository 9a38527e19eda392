"""Reduced flexible bodies (issue 39): stiffening of a spinning reduced blade (reference/reduced/stiffening.py).

rotating_cantilever's blade (32 Beam2, EI = ρA = L = 1, clamped on the spin axis) at Ω = 6 rad/s: the
geometrically exact beam's modes about the steady rotation (the modes algorithm, about = "rotation", on the
reference path) against the reduced blade (frame at the hub, clamped modes), with and without the centrifugal
stress stiffness of its modes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sps

from reference.io.deck import load_deck
from reference.modal import modes as pencil_modes
from reference.reduced.body import ReducedBody, steady_spin
from reference.reduced.craig_bampton import beam_matrices, clamped_modes
from reference.reduced.invariants import invariants
from reference.reduced.stiffening import centrifugal_stiffening

MODELS = Path(__file__).resolve().parents[1] / "models"
SPIN = 6.0


@pytest.fixture(scope="module")
def blade():
    """The deck's domain, the blade's matrices and the full beam's 4 lowest roots |s| [rad/s] about the spin."""
    domain = load_deck(MODELS / "rotating_cantilever.toml").domain
    beam = beam_matrices(domain, "blade")
    domain.solver.backend = "reference"
    full = 2 * np.pi * domain.solve().data("modes/frequency")
    return domain, beam, np.sort(full)


def _reduced_roots(domain, beam, n_modes, stiffened):
    basis = clamped_modes(beam, 0, n_modes)
    body = ReducedBody("blade", beam, basis, invariants(beam, basis, origin=beam.x[0]))
    M, G, K = steady_spin(body, [0.0, 0.0, SPIN])
    if stiffened:
        K = K + SPIN ** 2 * centrifugal_stiffening(domain, beam, basis, (0,), [0.0, 0.0, 1.0], beam.x[0])
    found = pencil_modes(sps.csr_matrix(M), sps.csr_matrix(G), sps.csr_matrix(K), 4)
    return np.sort(np.abs(found.s))


@pytest.mark.parametrize("n_modes, tolerance", [(4, 1e-2), (8, 1e-3)])
def test_the_stiffened_reduced_blade_has_the_full_beams_spinning_frequencies(blade, n_modes, tolerance):
    """With the stress stiffness the reduced blade's lead-lag and flapwise frequencies at Ω = 6 (full beam:
    4.262, 7.359, 26.11, 26.79 rad/s) follow the full beam's: measured 0.63 %, 0.21 %, 0.07 %, 0.06 % with 4
    modes and 0.04 %, 0.014 %, 0.014 %, 0.013 % with 8 (the modal truncation of the stiffened shapes); 1 % and
    0.1 % bound them.  A missing factor or sign in K_G moves the flapwise frequency by tens of percent."""
    domain, beam, full = blade
    np.testing.assert_allclose(_reduced_roots(domain, beam, n_modes, True), full, rtol=tolerance)


def test_without_stiffening_the_reduced_blade_keeps_its_rest_frequency_and_its_lag_mode_diverges(blade):
    """The same blade without K_G: its flapwise frequency stays at the rest value 3.515 rad/s, 52 % below the
    full beam's 7.359, and its first lead-lag mode is unstable (the real root √(Ω² − ω₀²) = 4.86 rad/s where the
    full beam vibrates at 4.262): the divergence of linear modes under fast rotation that the stiffness cures."""
    domain, beam, full = blade
    roots = _reduced_roots(domain, beam, 4, False)
    assert roots[0] == pytest.approx(3.5151, rel=1e-4)  # the rest flapwise frequency (32 lumped elements)
    assert roots[0] < 0.5 * full[1]
    assert roots[1] == pytest.approx(roots[2], rel=1e-9)  # ±√(Ω² − ω₀²): a decaying and a growing root
    assert roots[1] == pytest.approx(np.sqrt(SPIN ** 2 - roots[0] ** 2), rel=1e-6)
