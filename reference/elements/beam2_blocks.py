"""The vectorised Beam2 element loop: blocks of elements in the structure-of-arrays rows of
``reference/generated/beam2_soa.py`` (derivations/soa.py), bit for bit the per-element kernel's rows
(:func:`reference.elements.driver.element_row`).

:func:`soa_rows` fills every element's row of the work array (the parallel loop over blocks, from
:data:`reference.parallel.PARALLEL_NODES` nodes on); below, :func:`soa_forces` runs the blocks on one
thread and adds each block's forces from its rows straight into the nodes' sums instead.
The values that never change (reference lengths and rotations, stiffness) are laid out in the rows once,
when the family's data are packed (:func:`soa_fixed_rows`).  Measured costs: docs/benchmarks.md §5.
"""

from __future__ import annotations

import numpy as np

from reference.elements.driver import row_layout
from reference.elements.formulation import section_quaternion, to_node_frame
from reference.generated import beam2_soa as soa
from reference.jit import inlined, kernel, parallel_kernel, prange

ROW = row_layout(2, "Beam2Row", forces=12, strains=6, stresses=6, triads=8, moments=6, spare=1, energy=1)
"""The work row of a Beam2 element (and of a beam2_se3 one), :func:`reference.elements.driver.row_layout`:
section-frame forces (12), the strains ``Γ, K`` (6) and resultants ``N, M`` (6) at the midpoint, the ends'
section triads (8), the node-frame moments (6), the strain energy."""

_section_quaternion = inlined(section_quaternion)
_to_node_frame = inlined(to_node_frame)


def straight_elements(offset: np.ndarray) -> np.ndarray:
    """(E,) int8: 1 where both end offsets of the element (``offset`` (E, 2, 4)) are exactly the identity
    (:func:`is_identity`: the section frames are the node frames), else 0."""
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    return np.all(offset == identity, axis=(1, 2)).astype(np.int8)


def soa_fixed_rows(L0, psi0, gamma0, stiff) -> np.ndarray:
    """The inputs of ``generated.beam2_soa.internal_forces_soa`` that never change, in its rows of ``u``:
    row b for block b (elements ``64 b …``), component k of its element e at ``[b, k * BLOCK + e]`` (zeros
    past the last element)."""
    B, E = soa.BLOCK, L0.shape[0]
    n_blocks = (E + B - 1) // B
    rows = np.zeros((n_blocks * B, soa.FIXED_ROWS))
    rows[:E, soa.FIXED_L0] = L0
    rows[:E, soa.FIXED_PSI0:soa.FIXED_PSI0 + 3] = psi0
    rows[:E, soa.FIXED_GAMMA0:soa.FIXED_GAMMA0 + 3] = gamma0
    rows[:E, soa.FIXED_C:soa.FIXED_C + 6] = stiff
    blocks = rows.reshape(n_blocks, B, soa.FIXED_ROWS).transpose(0, 2, 1)
    return np.ascontiguousarray(blocks).reshape(n_blocks, soa.FIXED_ROWS * B)  # (0, …) for a family of none


@inlined
def add_element(conn, e, W, r, S):
    """Add the node-frame forces of element e (row r of ``W``, :data:`ROW`) into ``S``."""
    s, m = W[r, ROW.forces], W[r, ROW.moments]
    for a in range(2):
        n = conn[e, a]
        for k in range(3):
            S[n, k] += s[6 * a + k]
            S[n, 3 + k] += m[3 * a + k]



@inlined
def gather_block(x, q, conn, offset, straight, W, e0, n, v):
    """The inputs of elements ``e0 … e0+n−1`` that change into the rows of ``v`` (``generated.beam2_soa``'s
    layout): positions and section quaternions (composed ``p_a = q_a ⊗ o_a`` into the row's triads as the
    generic driver does, :func:`reference.elements.driver.gather`, unless both offsets are the identity)."""
    B = soa.BLOCK
    for k in range(n):
        e = e0 + k
        i, j = conn[e, 0], conn[e, 1]
        for c in range(3):
            v[(soa.ROW_X1 + c) * B + k] = x[i, c]
            v[(soa.ROW_X2 + c) * B + k] = x[j, c]
        if straight[e]:
            for c in range(4):
                v[(soa.ROW_Q1 + c) * B + k] = q[i, c]
                v[(soa.ROW_Q2 + c) * B + k] = q[j, c]
        else:
            P = W[e, ROW.triads].reshape((2, 4))
            _section_quaternion(q[i], offset[e, 0], P[0])
            _section_quaternion(q[j], offset[e, 1], P[1])
            for c in range(4):
                v[(soa.ROW_Q1 + c) * B + k] = P[0, c]
                v[(soa.ROW_Q2 + c) * B + k] = P[1, c]


@inlined
def scatter_block(offset, straight, W, e0, n, v):
    """The forces and energies of elements ``e0 … e0+n−1`` from the rows of ``v`` into their rows of ``W``
    (:data:`ROW`), the moments taken back to the node frames; the strains and resultants are not written
    (nothing of the step reads them)."""
    B = soa.BLOCK
    for k in range(n):
        e = e0 + k
        s, m = W[e, ROW.forces], W[e, ROW.moments]
        for c in range(12):
            s[c] = v[(soa.ROW_S + c) * B + k]
        W[e, ROW.energy] = v[soa.ROW_RETURNS * B + k]
        for a in range(2):
            if straight[e]:
                for c in range(3):
                    m[3 * a + c] = s[6 * a + 3 + c]
            else:
                _to_node_frame(offset[e, a], s[6 * a + 3:6 * a + 6], m[3 * a:3 * a + 3])


@parallel_kernel
def soa_rows(x, q, conn, offset, straight, blocked, W):
    """Every element's forces and energy in its row of ``W`` (E, ``ROW.width``), bit for bit the generic
    driver's (:func:`reference.elements.driver.element_row`):
    blocks of ``soa.BLOCK`` elements gathered into a structure of arrays, the generated
    ``internal_forces_soa`` (vectorised across the elements; ``blocked`` its rows that never change,
    :func:`soa_fixed_rows`), scattered back."""
    E = conn.shape[0]
    for b in prange((E + soa.BLOCK - 1) // soa.BLOCK):
        v = np.empty(soa.ROWS * soa.BLOCK)
        e0 = b * soa.BLOCK
        n = min(soa.BLOCK, E - e0)
        gather_block(x, q, conn, offset, straight, W, e0, n, v)
        soa.internal_forces_soa(n, v, blocked[b])
        scatter_block(offset, straight, W, e0, n, v)


@inlined
def add_block(conn, offset, straight, W, e0, n, v, S, U):
    """Add the forces of elements ``e0 … e0+n−1`` from the rows of ``v`` into ``S`` (N, 6) as
    :func:`reference.parallel.scatter` adds their rows of ``W`` (element order, end 1 then end 2: the same
    sums bit for bit), a curved element's through its row of ``W`` (:func:`scatter_block`); returns ``U``
    plus their energies, in element order (:func:`reference.parallel.energy_sum`'s sum)."""
    B = soa.BLOCK
    for k in range(n):
        e = e0 + k
        i, j = conn[e, 0], conn[e, 1]
        if straight[e]:  # node-frame moments = section-frame moments
            for c in range(3):
                S[i, c] += v[(soa.ROW_S + c) * B + k]
                S[i, 3 + c] += v[(soa.ROW_S + 3 + c) * B + k]
            for c in range(3):
                S[j, c] += v[(soa.ROW_S + 6 + c) * B + k]
                S[j, 3 + c] += v[(soa.ROW_S + 9 + c) * B + k]
        else:
            scatter_block(offset, straight, W, e, 1, v[k:])
            add_element(conn, e, W, e, S)
        U += v[soa.ROW_RETURNS * B + k]
    return U


@kernel
def soa_forces(x, q, conn, offset, straight, blocked, W, S):
    """:func:`soa_rows` and the element → node sum (:func:`reference.parallel.scatter`) in one serial
    pass (a model below :data:`reference.parallel.PARALLEL_NODES` nodes): each block's forces go from its rows straight into ``S`` (:func:`add_block`), none through
    ``W`` (but a curved element's); returns the strain energy.  The same bits as the two passes; it spares
    the parallel launch and the rows' round trip through ``W`` (docs/benchmarks.md §5)."""
    E = conn.shape[0]
    if E == 0:
        return 0.0  # a model without Beam2 elements: no work array to allocate
    v = np.empty(soa.ROWS * soa.BLOCK)
    U = 0.0
    for b in range((E + soa.BLOCK - 1) // soa.BLOCK):
        e0 = b * soa.BLOCK
        n = min(soa.BLOCK, E - e0)
        gather_block(x, q, conn, offset, straight, W, e0, n, v)
        soa.internal_forces_soa(n, v, blocked[b])
        U = add_block(conn, offset, straight, W, e0, n, v, S, U)
    return U
