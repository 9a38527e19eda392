"""Writing element and connector tangent blocks into the values of the Newton matrix.

The implicit algorithms take each node's rotation unknown δ as ``q = q_n ⊗ exp(ψ + δ)``
(generalized-α; ψ = 0 for the static update ``q ⊗ exp(δ)``), so every
configuration-dependent block is multiplied on the right by the tangent operator
``J_r(ψ)`` of its nodes, ``exp(ψ + δ) = exp(ψ) exp(J_r(ψ) δ) + O(δ²)`` (Brüls, Cardona
& Arnold 2012, §4).  :func:`times_right_jacobian` does that for three columns;
:func:`store_block` applies it to every node of a block and copies the block into the
values array in the order of :func:`reference.algorithms.implicit.newton_pattern`.
"""

from __future__ import annotations

from reference.generated import rotation_maps as rm
from reference.jit import inlined


@inlined
def times_right_jacobian(K, c0, psi, Jr):
    """``K[:, c0:c0+3] ← K[:, c0:c0+3] J_r(ψ)`` (skipped for ψ = 0); ``Jr`` (9,) scratch."""
    if psi[0] == 0.0 and psi[1] == 0.0 and psi[2] == 0.0:
        return
    rm.right_jacobian(psi, Jr)
    for a in range(K.shape[0]):
        k0, k1, k2 = K[a, c0], K[a, c0 + 1], K[a, c0 + 2]
        for b in range(3):
            K[a, c0 + b] = k0 * Jr[b] + k1 * Jr[3 + b] + k2 * Jr[6 + b]


@inlined
def store_block(Kb, nodes, n, psi, Jr, ck, values, p):
    """Copy ``ck`` times the (6n × 6n) block ``Kb`` of the nodes ``nodes[:n]`` into ``values`` from
    position ``p`` on (row by row), its rotation columns first multiplied by each node's ``J_r(ψ)``
    (a node −1, the ground, is skipped); returns the position after the block."""
    size = 6 * n
    for a in range(n):
        if nodes[a] >= 0:
            times_right_jacobian(Kb, 6 * a + 3, psi[nodes[a]], Jr)
    for a in range(size):
        for b in range(size):
            values[p] = ck * Kb[a, b]
            p += 1
    return p
