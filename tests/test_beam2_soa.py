"""The structure-of-arrays Beam2 kernel (``reference/generated/beam2_soa.py``, issue 25 item 2): the
element loop the explicit step runs from 8 elements on gives every element's row of forces (section and
node frames) and energy bit for bit as the per-element kernel does, over every branch of the rotation
maps' coefficient functions and of ``atan2_quadrant``, and for curved (offset) section frames."""

from __future__ import annotations

import numpy as np

from reference.elements.beam2 import beam2_assemble, beam2_assemble_parallel
from reference.elements.beam2_blocks import soa_fixed_rows, soa_forces, straight_elements
from reference.elements.formulation import is_identity, section_quaternion, to_node_frame
from reference.generated import beam2 as generated_beam2
from reference.generated import beam2_soa as soa
from reference.generated import rotation_maps as rm


def unit(v):
    return v / np.linalg.norm(v, axis=-1)[..., None]


def quat(axis, angle):
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * unit(axis)])


def elements(E, seed):
    """E separate two-node elements (nodes 2e, 2e+1) in random configurations: relative rotations
    half log-uniform from 1e-4 to 0.3 rad, half uniform from 0.3 to 3.1 rad (each series branch of
    c_asinc, c_sinc, c_cosc, c_sinc3, c_jinv and their closed forms), a third of the second nodes'
    Euler parameters negated (the other branch of the logarithm), every other element with random
    end offsets (a curved or kinked reference)."""
    rng = np.random.default_rng(seed)
    q = np.empty((2 * E, 4))
    x = rng.standard_normal((2 * E, 3))
    for e in range(E):
        q[2 * e] = unit(rng.standard_normal(4))
        angle = 10 ** rng.uniform(-4, -0.5) if rng.random() < 0.5 else rng.uniform(0.3, 3.1)
        rm.quat_product(q[2 * e].copy(), quat(rng.standard_normal(3), angle), q[2 * e + 1])
        if e % 3 == 0:
            q[2 * e + 1] *= -1.0
        x[2 * e + 1] = x[2 * e] + rng.uniform(0.1, 1.0) * unit(rng.standard_normal(3)) + 0.05 * rng.standard_normal(3)
    conn = np.arange(2 * E, dtype=np.int64).reshape(E, 2)
    offset = np.zeros((E, 2, 4))
    offset[:, :, 0] = 1.0
    offset[1::2] = unit(rng.standard_normal((len(offset[1::2]), 2, 4)))
    L0 = rng.uniform(0.1, 1.0, E)
    psi0 = 1e-2 * rng.standard_normal((E, 3))
    gamma0 = np.array([1.0, 0.0, 0.0]) + 1e-2 * rng.standard_normal((E, 3))
    stiff = 10 ** rng.uniform(0, 6, (E, 6))
    return x, q, conn, offset, L0, psi0, gamma0, stiff


def per_element_row(x, q, conn, offset, L0, psi0, gamma0, stiff, e):
    """Element e's row as the generic driver writes it (``reference.elements.driver.element_row``), from the
    per-element generated kernel."""
    w = np.zeros(40)
    i, j = conn[e]
    p1, p2 = q[i].copy(), q[j].copy()
    if not (is_identity(offset[e, 0]) and is_identity(offset[e, 1])):
        section_quaternion(q[i], offset[e, 0], p1)
        section_quaternion(q[j], offset[e, 1], p2)
    w[39] = generated_beam2.internal_forces(x[i], x[j], p1, p2, L0[e], psi0[e], gamma0[e], stiff[e],
                                            w[:12], w[12:18], w[18:24])
    to_node_frame(offset[e, 0], w[3:6], w[32:35])
    to_node_frame(offset[e, 1], w[9:12], w[35:38])
    return w


def test_soa_rows_equal_the_per_element_kernel_bit_for_bit():
    """Two blocks and a partial third (2·64 + 11 elements): forces (section and node frames) and energy of
    every element equal the per-element kernel's exactly — the same statements in the same order, the
    closed forms (libm) recomputed in the scalar loops where an angle is beyond the series' range; the
    assembled S and ΣU equal the serial kernel's.  (The strains and resultants are not outputs of the
    structure-of-arrays kernel: nothing of the step reads them.)"""
    E = 2 * soa.BLOCK + 11
    data = elements(E, seed=25)
    x, q = data[0], data[1]
    W = np.zeros((E, 40))
    S = np.full((x.shape[0], 6), np.nan)
    U = beam2_assemble_parallel(*data, S, W)
    keep = np.r_[0:12, 32:40]
    for e in range(E):
        ref = per_element_row(*data, e)
        assert np.array_equal(W[e, keep], ref[keep]), (e, np.abs(W[e, keep] - ref[keep]).max())
    S_ref = np.zeros_like(S)
    assert U == beam2_assemble(*data, S_ref, np.zeros(40)) and np.array_equal(S, S_ref)
    # the one-thread pass (forces from the blocks' rows straight into S) gives the same S and ΣU
    conn, offset, L0, psi0, gamma0, stiff = data[2:]
    S_one = np.zeros_like(S)
    U_one = soa_forces(x, q, conn, offset, straight_elements(offset), soa_fixed_rows(L0, psi0, gamma0, stiff),
                          np.zeros((E, 40)), S_one)
    assert U_one == U and np.array_equal(S_one, S_ref)
    # the straight elements' relative rotations |ψ| reach every branch: the short series of c_asinc
    # (|ψ|/2 < 0.029) and the closed forms of c_cosc and c_sinc3 (|ψ|/2 ≥ 1)
    q = data[1]
    r0 = np.abs(np.einsum("ij,ij->i", q[0::2], q[1::2]))[0::2]
    psi = 2 * np.arccos(np.minimum(r0, 1.0))
    assert psi.min() < 0.05 and (psi > 2.2).sum() >= 3
