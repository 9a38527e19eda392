"""Deterministic parallel loops over nodes and elements: the rules every parallel loop of the engine keeps.

Results are bit for bit the same for any thread count (:func:`reference.jit.use_threads`):

1. A parallel loop writes per-item rows only (element e its row ``W[e]`` of the family's work
   array, node i its rows of ``v``, ``x``, ``q``, ``r``; a tangent block its own slice of the
   values, at a position known before the loop).
2. The element → node accumulation is a per-node **gather** (:func:`gather`) in a fixed order: the
   node → (element, end) incidence in CSR form (:func:`node_incidence`, built once by each
   family's ``pack``), in ascending element order, which adds the same numbers in the same order
   as the serial scatter (:func:`scatter`, element by element): the same bits.
3. A sum over nodes (energies, powers, work) is taken over fixed chunks of :data:`CHUNK` nodes,
   each chunk's partial sum in node order, the partial sums then added in chunk order on one
   thread.  The chunk size does not depend on the thread count, so neither does the sum; a model
   of at most :data:`CHUNK` nodes (every deck of ``models/``) has one chunk and today's serial
   bits.  The element energies are summed serially, in element order (one addition per element).

Whether a loop runs in parallel depends on the model's size only (:data:`PARALLEL_NODES`, the
element driver's ``PARALLEL_ELEMENTS``, :mod:`reference.elements.driver`), never on the thread count:
the serial and parallel forms of a loop give the same bits anyway, the threshold only keeps a small model
off the cost of starting a parallel region (the measured crossovers: docs/benchmarks.md §5, §10).  Joints,
master/slave joints, force elements and loads stay serial (few, and they write into shared node rows).
"""

from __future__ import annotations

import numpy as np

from reference.jit import inlined, parallel_kernel, prange

CHUNK = 256
"""Nodes per chunk of the chunked sums (fixed: the sums' bits must not depend on the thread count)."""

PARALLEL_NODES = 2048
"""From this many nodes on, the node loops of the explicit step (kick, drift, the step's sums,
the force reset, the element → node gather) and of the implicit residual and tangent run as
parallel loops (on one thread too: the same bits).  Below it the serial loops skip the cost of
starting a parallel region, which costs as much as the serial loops over many nodes (docs/benchmarks.md §5, §10)."""


ELEMENT_CHUNK = 16
"""Elements per chunk of a parallel tangent loop (each chunk has its own scratch; no sums, so the
size only sets the granularity)."""


@inlined
def element_chunks(n):
    """Chunks of :data:`ELEMENT_CHUNK` elements covering ``n`` elements."""
    return (n + ELEMENT_CHUNK - 1) // ELEMENT_CHUNK


@inlined
def n_chunks(n):
    """Chunks of :data:`CHUNK` items covering ``n`` items (at least one)."""
    return max(1, (n + CHUNK - 1) // CHUNK)


def node_incidence(conn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The node → (element, end) incidence of a family's connectivity ``conn`` (E, n) in CSR form.

    Returns ``start`` (N_f + 1,), ``item`` (E n,) with ``N_f = max(conn) + 1``: the entries of node
    i are ``item[start[i]:start[i + 1]]``, each ``e n + a`` (end a of element e), in ascending
    element order (the order of the serial scatter, :func:`scatter`).
    """
    flat = np.asarray(conn, dtype=np.int64).reshape(-1)
    count = np.bincount(flat, minlength=int(flat.max()) + 1 if flat.size else 0)
    start = np.zeros(count.shape[0] + 1, dtype=np.int64)
    np.cumsum(count, out=start[1:])
    return start, np.argsort(flat, kind="stable").astype(np.int64)


@inlined
def scatter(conn, W, moment, S):
    """Serial element → node accumulation: for every element e in order and end a, ``S[conn[e, a], :3] +=
    W[e, 6a:6a+3]`` (forces, inertial) and ``S[…, 3:] += W[e, moment+3a:moment+3a+3]`` (node-frame moments)."""
    ends = conn.shape[1]
    for e in range(conn.shape[0]):
        for a in range(ends):
            n = conn[e, a]
            for k in range(3):
                S[n, k] += W[e, 6 * a + k]
                S[n, 3 + k] += W[e, moment + 3 * a + k]


@parallel_kernel
def gather(start, item, ends, W, moment, S):
    """:func:`scatter` as a parallel loop over the nodes, bit for bit: node i adds its entries
    ``item[start[i]:start[i + 1]]`` (:func:`node_incidence`, ascending element order)."""
    for n in prange(start.shape[0] - 1):
        for p in range(start[n], start[n + 1]):
            e = item[p] // ends
            a = item[p] - e * ends
            for k in range(3):
                S[n, k] += W[e, 6 * a + k]
                S[n, 3 + k] += W[e, moment + 3 * a + k]


@inlined
def accumulate(conn, start, item, W, moment, S):
    """The element → node accumulation of a family: :func:`gather` from :data:`PARALLEL_NODES` nodes
    on, :func:`scatter` below (the same bits)."""
    if start.shape[0] - 1 >= PARALLEL_NODES:
        gather(start, item, conn.shape[1], W, moment, S)
    else:
        scatter(conn, W, moment, S)


@inlined
def energy_sum(W, column):
    """``Σ_e W[e, column]`` in element order (the family's strain energy)."""
    U = 0.0
    for e in range(W.shape[0]):
        U += W[e, column]
    return U


@parallel_kernel
def reset_forces(S, F, mass, g0, g1, g2):
    """``S = 0`` and ``F`` = gravity ``m g`` (no moments), node by node in parallel."""
    for i in prange(S.shape[0]):
        for a in range(6):
            S[i, a] = 0.0
        F[i, 0], F[i, 1], F[i, 2] = mass[i] * g0, mass[i] * g1, mass[i] * g2
        F[i, 3], F[i, 4], F[i, 5] = 0.0, 0.0, 0.0
