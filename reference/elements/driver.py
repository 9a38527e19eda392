"""The generic element driver: how every element family is executed, apart from its physics.

A family (:class:`~reference.elements.formulation.ElementFormulation`) provides its plain data (``pack``)
and per-element functions with named inputs and outputs, all in the element's own section frames:

- ``element_forces(data, e, X, P, w) → U``: element e's section-frame forces into ``w[ROW.forces]``
  (6n: force, moment of each node in turn) and its strain energy [J], from its nodes' positions ``X``
  (n, 3) [m] and section triads ``P`` (n, 4) (Euler parameters); what else it computes (strains,
  resultants) goes to its own named fields of the work row ``w``;
- ``element_tangent(data, e, X, P, w, K)``: its (6n × 6n) tangent ``∂S/∂[δx_a, δθ_a]`` in the section
  frames into ``K`` (flat, row by row; at least (6n)² entries);
- ``element_resultants(w, N, M)``: after ``element_forces``, its section resultants [N], [N m] into the
  (3,) rows ``N``, ``M`` (section frame);
- ``ROW``: its work row's fields as named slices (:func:`row_layout`).

The driver owns the rest: the gathering of each element's node positions and section triads
``p_a = q_a ⊗ o_a`` (the frame convention of :mod:`reference.elements.formulation`), the node-frame
moments and tangents, the element → node sum (:func:`reference.parallel.accumulate`), the element
energies' sum, the serial and parallel element loops and their size threshold
(:data:`PARALLEL_ELEMENTS`), and the tangent blocks the implicit solvers take
(:func:`reference.newton_blocks.store_block`).  Its three calls, :func:`assemble`, :func:`tangent_values`
and :func:`resultants`, are what :mod:`reference.elements.families` reaches for a family that gives no
calls of its own (Beam2 gives its own vectorised :func:`assemble`).  In compiled code each call of a family's function
is resolved for the type of ``data`` at compile time (numba ``overload``) and inlined; in plain Python it
is looked up (:data:`CLASS_OF_DATA`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.extending import overload

from reference.elements.formulation import is_identity, section_quaternion, tangent_to_node_frames, to_node_frame
from reference.jit import inlined, kernel, parallel_kernel, prange
from reference.newton_blocks import store_block
from reference.parallel import ELEMENT_CHUNK, accumulate, element_chunks, energy_sum

PARALLEL_ELEMENTS = 8
"""From this many elements on, a family's element loops (forces, tangent blocks) run as parallel loops
(on one thread too: the same bits), and Beam2's forces as its vectorised loop; below, on the calling
thread, one element after the other, without the cost of starting a parallel region (the loops' times
cross between a few elements and a dozen: docs/benchmarks.md §5, §10)."""

CLASS_OF_DATA: dict[type, type] = {}
"""A family's data class → its formulation class (filled by :func:`reference.elements.families.register`)."""

REQUIRED = ("forces", "triads", "moments", "energy")
"""The fields every work row has: section-frame forces (6n), section triads (4n), node-frame moments (3n),
strain energy (1)."""


def row_layout(n_nodes: int, name: str, **sizes: int) -> tuple:
    """A family's work row declared once: ``sizes`` its fields' lengths in the row's order (the
    :data:`REQUIRED` fields among them, ``energy`` of length 1).  Returns an instance of a named tuple
    (class ``name``) of the fields' slices, but ``energy``, an index, with ``nodes`` (n) and ``width`` (the
    row's length) and ``moment_column`` (where the moments start) added: compiled code reads them as
    constants (``w[ROW.forces]``)."""
    missing = [field for field in REQUIRED if field not in sizes]
    if missing or sizes["energy"] != 1 or sizes["forces"] != 6 * n_nodes or sizes["moments"] != 3 * n_nodes:
        raise ValueError(f"{name}: a work row needs forces (6n), triads, moments (3n) and energy (1): {sizes}")
    start, fields = 0, {}
    for field, size in sizes.items():
        fields[field] = start if field == "energy" else slice(start, start + size)
        start += size
    cls = NamedTuple(name, [(field, type(value)) for field, value in fields.items()]
                     + [("nodes", int), ("width", int), ("moment_column", int)])
    return cls(*fields.values(), n_nodes, start, fields["moments"].start)


def formulation_of(data) -> type:
    """The formulation class whose plain data ``data`` is."""
    return CLASS_OF_DATA[type(data)]


def _forces(data, e, X, P, w):
    return formulation_of(data).element_forces(data, e, X, P, w)


@overload(_forces, inline="always")
def _forces_typing(data, e, X, P, w):
    function = CLASS_OF_DATA[data.instance_class].element_forces
    return lambda data, e, X, P, w: function(data, e, X, P, w)


def _tangent(data, e, X, P, w, K):
    return formulation_of(data).element_tangent(data, e, X, P, w, K)


@overload(_tangent, inline="always")
def _tangent_typing(data, e, X, P, w, K):
    function = CLASS_OF_DATA[data.instance_class].element_tangent
    return lambda data, e, X, P, w, K: function(data, e, X, P, w, K)


def _layout(data):
    return formulation_of(data).ROW


@overload(_layout, inline="always")
def _layout_typing(data):
    row = CLASS_OF_DATA[data.instance_class].ROW
    return lambda data: row


def _resultants(data, w, N, M):
    return formulation_of(data).element_resultants(w, N, M)


@overload(_resultants, inline="always")
def _resultants_typing(data, w, N, M):
    function = CLASS_OF_DATA[data.instance_class].element_resultants
    return lambda data, w, N, M: function(w, N, M)


@inlined
def gather(data, x, q, e, X, P):
    """Element e's node positions into ``X`` (n, 3) and section triads ``p_a = q_a ⊗ o_a`` into ``P`` (n, 4)
    (the node's own Euler parameters where the offset is the identity); returns True where every offset is
    the identity (the section frames are the node frames)."""
    straight = True
    for a in range(P.shape[0]):
        i, o = data.conn[e, a], data.offset[e, a]
        for k in range(3):
            X[a, k] = x[i, k]
        if is_identity(o):
            for k in range(4):
                P[a, k] = q[i, k]
        else:
            straight = False
            section_quaternion(q[i], o, P[a])
    return straight


@inlined
def element_row(data, x, q, e, w, X):
    """Element e's work row ``w``: section triads, the family's forces and energy, and the moments in the
    node frames (``A(o_a) m_a``, :func:`~reference.elements.formulation.to_node_frame`); returns the energy.
    ``X`` (n, 3) scratch."""
    row = _layout(data)
    P = w[row.triads].reshape((row.nodes, 4))
    straight = gather(data, x, q, e, X, P)
    w[row.energy] = _forces(data, e, X, P, w)
    s, m = w[row.forces], w[row.moments]
    for a in range(row.nodes):
        if straight:
            for k in range(3):
                m[3 * a + k] = s[6 * a + 3 + k]
        else:
            to_node_frame(data.offset[e, a], s[6 * a + 3:6 * a + 6], m[3 * a:3 * a + 3])
    return w[row.energy]


@inlined
def _rows_range(data, x, q, W, lo, hi):
    """The work rows of the elements ``lo … hi − 1``."""
    X = np.empty((_layout(data).nodes, 3))
    for e in range(lo, hi):
        element_row(data, x, q, e, W[e], X)


@parallel_kernel
def rows_parallel(data, x, q, W):
    """Every element's work row (:func:`element_row`), chunks of elements in parallel."""
    E = data.conn.shape[0]
    for k in prange(element_chunks(E)):
        _rows_range(data, x, q, W, k * ELEMENT_CHUNK, min(E, (k + 1) * ELEMENT_CHUNK))


@kernel
def rows_serial(data, x, q, W):
    """Every element's work row on the calling thread: a kernel of its own, so that the family's element code
    is compiled once, not again inside every algorithm's kernel."""
    _rows_range(data, x, q, W, 0, data.conn.shape[0])


@inlined
def assemble(data, W, x, q, S):
    """A family's forces: every element's row of ``W`` (a parallel loop from :data:`PARALLEL_ELEMENTS`
    elements on), added into ``S`` (N, 6; inertial forces, node-frame moments) in element order
    (:func:`reference.parallel.accumulate`); returns the strain energy [J] (element order)."""
    row = _layout(data)
    if data.conn.shape[0] >= PARALLEL_ELEMENTS:
        rows_parallel(data, x, q, W)
    else:
        rows_serial(data, x, q, W)
    accumulate(data.conn, data.node_start, data.node_item, W, row.moment_column, S)
    return energy_sum(W, row.energy)


@inlined
def _tangent_range(data, W, x, q, psi, ck, values, p0, Jr, K, X, lo, hi):
    """``ck`` times the tangent blocks of the elements ``lo … hi − 1`` in the node frames, element e's into
    ``values`` from ``p0 + (6n)² e`` on, its rotation columns times each node's ``J_r(ψ)``
    (:func:`reference.newton_blocks.store_block`); ``Jr`` (9,), ``K`` (at least (6n)²), ``X`` (n, 3) scratch.

    Takes 13 parameters: an element range of the generic driver, inlined into its serial and its parallel loop with
    the family's data and each thread's scratch.
    """
    row = _layout(data)
    size = 6 * row.nodes
    Kb = K[:size * size].reshape((size, size))
    for e in range(lo, hi):
        w = W[e]
        if ck != 0.0:
            P = w[row.triads].reshape((row.nodes, 4))
            straight = gather(data, x, q, e, X, P)
            _tangent(data, e, X, P, w, K)
            if not straight:
                m = w[row.moments]
                tangent_to_node_frames(data.offset[e], Kb, m[0:3], m[3:6])
        else:
            Kb[:, :] = 0.0
        store_block(Kb, data.conn[e], row.nodes, psi, Jr, ck, values, p0 + size * size * e)


@parallel_kernel
def _tangent_parallel(data, W, x, q, psi, ck, values, p):
    E, n = data.conn.shape[0], _layout(data).nodes
    for k in prange(element_chunks(E)):
        Jr, K, X = np.empty(9), np.empty(36 * n * n), np.empty((n, 3))
        _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K, X, k * ELEMENT_CHUNK, min(E, (k + 1) * ELEMENT_CHUNK))


@inlined
def tangent_values(data, W, x, q, psi, ck, values, p, Jr, K):
    """A family's tangent blocks: ``ck`` times every element's (6n × 6n) tangent in the node frames into
    ``values`` from position ``p`` on, in the order of ``conn`` (a parallel loop from
    :data:`PARALLEL_ELEMENTS` elements on, each element writing its own slice); returns the position after
    the last.  ``Jr`` (9,), ``K`` (at least (6n)²) scratch."""
    E, n = data.conn.shape[0], _layout(data).nodes
    if E >= PARALLEL_ELEMENTS:
        _tangent_parallel(data, W, x, q, psi, ck, values, p)
    else:
        _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K, np.empty((n, 3)), 0, E)
    return p + 36 * n * n * E


@inlined
def resultants(data, W, x, q, N, M):
    """A family's section resultants: every element's (:func:`element_row`, the family's
    ``element_resultants``) into the rows ``data.index`` of ``N``, ``M`` (E, 3), section frame (returns 0)."""
    X = np.empty((_layout(data).nodes, 3))
    for e in range(data.conn.shape[0]):
        w = W[e]
        element_row(data, x, q, e, w, X)
        r = data.index[e]
        _resultants(data, w, N[r], M[r])
    return 0.0


def work(data) -> np.ndarray:
    """A family's work array: one row of ``ROW.width`` per element."""
    return np.zeros((data.conn.shape[0], formulation_of(data).ROW.width))
