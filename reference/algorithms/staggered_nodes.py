"""The node loops of the staggered step (paper §3.3, docs/formulation.md §6): kick, the step's sums, drift.

Each loop has one per-node (or per-chunk) body, run by a serial loop on a small model and by a
parallel loop (``prange``) from :data:`reference.parallel.PARALLEL_NODES` nodes on, with the same
bits either way and for any thread count (the rules of :mod:`reference.parallel`): the kick and the
drift write each node's own rows; the sums of the step (external work, damping dissipation, the
energy guard's kinetic energy and external powers, the finiteness check) are chunked.
:mod:`reference.algorithms.staggered` calls them.
"""

from __future__ import annotations

import math

from reference.generated import rotation_maps as rm
from reference.jit import inlined, parallel_kernel, prange
from reference.parallel import CHUNK, PARALLEL_NODES, n_chunks

_cayley_update = inlined(rm.cayley_update_scalars)

SWEEP_TOLERANCE = 2.0**-52
"""The sweeps stop early once a sweep changes ω by less than this relative to |ω| (round-off):
a slowly turning node (h|ω| ≲ 1e-8, most nodes of a beam) needs two."""

SUMS = 6
"""The chunked sums of :func:`node_sums`: external work rate, damping dissipation rate, kinetic energy,
external power at V^{n−½} and at V^{n+½}, and the sum of the new velocities (finite or not)."""


@inlined
def _principal(a01, a02, a10, a12, a20, a21):
    """True when the off-diagonal entries of a 3×3 node inertia (or its inverse) are all zero: principal axes,
    a third of the products.  On numbers: it is called inside the loops over the nodes."""
    return a01 == 0.0 and a02 == 0.0 and a10 == 0.0 and a12 == 0.0 and a20 == 0.0 and a21 == 0.0


@inlined
def kick_range(lo, hi, ids, by_id, c, J, Jinv, free, mass, constrained, v, w, S, F, hk, v_new, w_new, sweeps, extra,
               from_guess):
    """Stage 2 at the nodes ``lo … hi − 1`` (or ``ids[lo:hi]`` if ``by_id``): ``v* = v + h_k (m⁻¹(F − S_u) − c v)``
    and the body-frame angular velocity with the midpoint gyroscopic term ``ω̄ × J ω̄`` by at most
    ``sweeps`` fixed-point sweeps (``extra`` more at a node of no joint), from ``w`` or, if
    ``from_guess``, from ``w_new``.  The loop over the nodes is here, not a call per node: an inlined
    call inside a loop costs numba's reference-count updates of its array arguments per iteration.

    Takes 20 parameters: the node arrays the serial and the parallel kick bind once (a group's field read in the
    loop costs updates per node, :mod:`reference.jit`), the velocities and the sweeps.
    """
    for p in range(lo, hi):
        i = ids[p] if by_id else p
        n_sweeps = sweeps if constrained[i] else sweeps + extra
        m_inv = 1.0 / mass[i]
        for k in range(3):
            v_new[i, k] = free[i, k] * (v[i, k] + hk * ((F[i, k] - S[i, k]) * m_inv - c * v[i, k]))
        w0, w1, w2 = w[i, 0], w[i, 1], w[i, 2]
        r0, r1, r2 = F[i, 3] - S[i, 3], F[i, 4] - S[i, 4], F[i, 5] - S[i, 5]
        if c != 0.0:  # damping moment −c J ω at the old half step
            r0 -= c * (J[i, 0, 0] * w0 + J[i, 0, 1] * w1 + J[i, 0, 2] * w2)
            r1 -= c * (J[i, 1, 0] * w0 + J[i, 1, 1] * w1 + J[i, 1, 2] * w2)
            r2 -= c * (J[i, 2, 0] * w0 + J[i, 2, 1] * w1 + J[i, 2, 2] * w2)
        n0, n1, n2 = w0, w1, w2
        if from_guess:
            n0, n1, n2 = w_new[i, 0], w_new[i, 1], w_new[i, 2]
        # a principal-axes inertia (every node of a straight beam) needs a third of the products
        diagonal = _principal(J[i, 0, 1], J[i, 0, 2], J[i, 1, 0], J[i, 1, 2], J[i, 2, 0], J[i, 2, 1]) and \
            _principal(Jinv[i, 0, 1], Jinv[i, 0, 2], Jinv[i, 1, 0], Jinv[i, 1, 2], Jinv[i, 2, 0], Jinv[i, 2, 1])
        for sweep in range(n_sweeps):
            b0, b1, b2 = 0.5 * (w0 + n0), 0.5 * (w1 + n1), 0.5 * (w2 + n2)
            if diagonal:
                j0, j1, j2 = J[i, 0, 0] * b0, J[i, 1, 1] * b1, J[i, 2, 2] * b2
            else:
                j0 = J[i, 0, 0] * b0 + J[i, 0, 1] * b1 + J[i, 0, 2] * b2
                j1 = J[i, 1, 0] * b0 + J[i, 1, 1] * b1 + J[i, 1, 2] * b2
                j2 = J[i, 2, 0] * b0 + J[i, 2, 1] * b1 + J[i, 2, 2] * b2
            g0 = r0 - (b1 * j2 - b2 * j1)
            g1 = r1 - (b2 * j0 - b0 * j2)
            g2 = r2 - (b0 * j1 - b1 * j0)
            if diagonal:
                m0 = free[i, 3] * (w0 + hk * (Jinv[i, 0, 0] * g0))
                m1 = free[i, 4] * (w1 + hk * (Jinv[i, 1, 1] * g1))
                m2 = free[i, 5] * (w2 + hk * (Jinv[i, 2, 2] * g2))
            else:
                m0 = free[i, 3] * (w0 + hk * (Jinv[i, 0, 0] * g0 + Jinv[i, 0, 1] * g1 + Jinv[i, 0, 2] * g2))
                m1 = free[i, 4] * (w1 + hk * (Jinv[i, 1, 0] * g0 + Jinv[i, 1, 1] * g1 + Jinv[i, 1, 2] * g2))
                m2 = free[i, 5] * (w2 + hk * (Jinv[i, 2, 0] * g0 + Jinv[i, 2, 1] * g1 + Jinv[i, 2, 2] * g2))
            # converged to round-off: a further sweep would change nothing
            done = sweep > 0 and abs(m0 - n0) + abs(m1 - n1) + abs(m2 - n2) <= \
                SWEEP_TOLERANCE * (abs(m0) + abs(m1) + abs(m2))
            n0, n1, n2 = m0, m1, m2
            if done:
                break
        w_new[i, 0], w_new[i, 1], w_new[i, 2] = n0, n1, n2


@parallel_kernel
def _kick_parallel(c, J, Jinv, free, mass, constrained, v, w, S, F, hk, v_new, w_new, sweeps, extra):
    """The kick of :func:`kick_nodes` chunk by chunk in a parallel loop (:func:`kick_range` per chunk).

    Takes 15 parameters: those of :func:`kick_range` but the node range, which its parallel loop chooses per
    chunk.
    """
    N = v.shape[0]
    for k in prange(n_chunks(N)):
        kick_range(k * CHUNK, min(N, (k + 1) * CHUNK), constrained, False, c, J, Jinv, free, mass, constrained, v, w,
                   S, F, hk, v_new, w_new, sweeps, extra, False)


@inlined
def kick_nodes(nodes, c, v, w, S, F, hk, v_new, w_new, sweeps, extra_free_sweeps):
    """The kick of every node (:func:`kick_range`, ``sweeps`` sweeps, ``extra_free_sweeps`` more at a node of
    no joint); a parallel loop from :data:`~reference.parallel.PARALLEL_NODES` nodes on.  ``nodes`` the Model's
    group, ``c`` its mass-proportional damping [1/s] (not the Model: every array of an inlined function's
    argument costs two atomic reference-count updates a call).

    Takes 11 parameters: the Model's node group, its damping, the velocities before and after, the forces, the half
    step and the sweeps, the kick's inputs and outputs.
    """
    # the arrays bound once: a field read inside the loop costs two atomic reference-count updates per
    # iteration (numba), and a row view (J[i]) as many
    J, Jinv, free, mass, constrained = nodes.inertia, nodes.inertia_inv, nodes.free, nodes.mass, nodes.constrained
    if v.shape[0] >= PARALLEL_NODES:
        _kick_parallel(c, J, Jinv, free, mass, constrained, v, w, S, F, hk, v_new, w_new, sweeps, extra_free_sweeps)
    else:
        kick_range(0, v.shape[0], constrained, False, c, J, Jinv, free, mass, constrained, v, w, S, F, hk, v_new,
                   w_new, sweeps, extra_free_sweeps, False)


@inlined
def _chunk_sums(k, mass, J, free, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part):
    """Row k of ``part`` (:data:`SUMS`): the sums of :func:`node_sums` over the nodes of chunk k, in node
    order (each sum's terms in the order of the serial loops it replaces).

    Takes 14 parameters: those of :func:`node_sums` with the node group's arrays bound once, and the chunk k the
    parallel loop chooses.
    """
    c = 0.5 if mean else 1.0
    d = 0.5 if mean else 0.0
    dW, dD, T, P_old, P_new, total = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for i in range(k * CHUNK, min(v.shape[0], (k + 1) * CHUNK)):
        for a in range(3):
            dW += 0.5 * (f_prev[i, a] + F[i, a]) * v[i, a] + 0.5 * (f_prev[i, 3 + a] + F[i, 3 + a]) * w[i, a]
            total += v_new[i, a] + w_new[i, a]
        if damped:
            for a in range(3):
                dD += mass[i] * v[i, a] * 0.5 * (v[i, a] + v_new[i, a]) * free[i, a]
                for b in range(3):
                    dD += w[i, a] * J[i, a, b] * 0.5 * (w[i, b] + w_new[i, b]) * free[i, 3 + a]
        if guarded:
            # a principal-axes inertia (every node of a straight beam): T without its zero products, the
            # same sum (a term ±0 leaves a sum of terms ≥ 0 as it is)
            diagonal = _principal(J[i, 0, 1], J[i, 0, 2], J[i, 1, 0], J[i, 1, 2], J[i, 2, 0], J[i, 2, 1])
            for a in range(3):
                va = c * v[i, a] + d * v_new[i, a]
                T += 0.5 * mass[i] * va * va
                P_old += F[i, a] * v[i, a] + F[i, 3 + a] * w[i, a]
                P_new += F[i, a] * v_new[i, a] + F[i, 3 + a] * w_new[i, a]
                wa = c * w[i, a] + d * w_new[i, a]
                if diagonal:
                    T += 0.5 * wa * J[i, a, a] * wa
                else:
                    for b in range(3):
                        T += 0.5 * wa * J[i, a, b] * (c * w[i, b] + d * w_new[i, b])
    part[k, 0], part[k, 1], part[k, 2], part[k, 3], part[k, 4], part[k, 5] = dW, dD, T, P_old, P_new, total


@parallel_kernel
def _sums_parallel(mass, J, free, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part):
    """The rows of ``part`` (:func:`node_sums`) chunk by chunk in a parallel loop (:func:`_chunk_sums` per chunk).

    Takes 13 parameters: those of :func:`_chunk_sums` but the chunk, which its parallel loop chooses.
    """
    for k in prange(part.shape[0]):
        _chunk_sums(k, mass, J, free, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part)


@inlined
def node_sums(nodes, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part, out):
    """The step's sums over the nodes into ``out`` (:data:`SUMS`,), chunk by chunk (``part``
    (:func:`~reference.parallel.n_chunks`, :data:`SUMS`) scratch), the chunks' partial sums added in order:

    0. ``Σ ½(F^{n−1} + F^n)·V^{n−½}`` (times h the external work of the increment into t_n);
    1. if ``damped``: ``Σ m V^{n−½}·½(V^{n−½} + V^{n+½}) + ω^{n−½}·J·½(ω^{n−½} + ω^{n+½})`` over the free
       coordinates (times ``h c`` the energy the mass-proportional damping removes in one kick);
    2–4. if ``guarded``: the kinetic energy at the integer-step velocities (``mean``; else at V^{n−½})
       and the external powers ``F·V^{n−½}``, ``F·V^{n+½}`` (:func:`reference.algorithms.staggered._balance`);
    5. ``Σ (v^{n+½} + ω^{n+½})`` over every component: not finite if a velocity is not (or overflows).

    ``nodes`` the Model's group.

    Takes 12 parameters: the node group, the velocities before and after the kick, the forces of two steps, three
    flags and two outputs: the energy balance's inputs.
    """
    mass, J, free = nodes.mass, nodes.inertia, nodes.free
    if v.shape[0] >= PARALLEL_NODES:
        _sums_parallel(mass, J, free, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part)
    else:
        for k in range(part.shape[0]):
            _chunk_sums(k, mass, J, free, v, w, v_new, w_new, F, f_prev, damped, guarded, mean, part)
    for s in range(SUMS):
        out[s] = part[0, s]
        for k in range(1, part.shape[0]):
            out[s] += part[k, s]


@inlined
def _drift_chunk(k, x, q, v, w, v_new, w_new, f_prev, F, h):
    for i in range(k * CHUNK, min(x.shape[0], (k + 1) * CHUNK)):
        for a in range(3):
            v[i, a] = v_new[i, a]
            w[i, a] = w_new[i, a]
            x[i, a] += h * v_new[i, a]
        # numbers, not the row views q[i], w_new[i]: a view costs two atomic updates per node (reference.jit)
        p0, p1, p2, p3 = _cayley_update(q[i, 0], q[i, 1], q[i, 2], q[i, 3], w_new[i, 0], w_new[i, 1], w_new[i, 2], h)
        nrm = math.sqrt(p0 ** 2 + p1 ** 2 + p2 ** 2 + p3 ** 2)
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = p0 / nrm, p1 / nrm, p2 / nrm, p3 / nrm
        for a in range(6):
            f_prev[i, a] = F[i, a]


@parallel_kernel
def _drift_parallel(x, q, v, w, v_new, w_new, f_prev, F, h):
    for k in prange(n_chunks(x.shape[0])):
        _drift_chunk(k, x, q, v, w, v_new, w_new, f_prev, F, h)


@inlined
def drift_nodes(x, q, v, w, v_new, w_new, f_prev, F, h):
    """Stage 3 at every node: ``x^{n+1} = x^n + h v^{n+½}``, ``q^{n+1} = q^n ⊗ p(h ω^{n+½})`` (Cayley,
    normalised), the half-step velocities and the forces kept for the next step's work; a parallel loop
    over chunks from :data:`~reference.parallel.PARALLEL_NODES` nodes on."""
    if x.shape[0] >= PARALLEL_NODES:
        _drift_parallel(x, q, v, w, v_new, w_new, f_prev, F, h)
    else:
        for k in range(n_chunks(x.shape[0])):
            _drift_chunk(k, x, q, v, w, v_new, w_new, f_prev, F, h)
