"""Modes of a meshed beam from its own linearisation: Craig–Bampton and free-free bases, floating-frame modes.

The beam's stiffness K is the element families' tangent at the unloaded rest configuration
(:func:`reference.plain.elements.element_tangent`, the matrix every linear analysis of the project starts from)
and its mass M the model's lumped node masses and rotary inertias (:class:`reference.plain.model.Evaluation`),
both restricted to the beam's nodes.  Coordinates are six per node in the beam's order, ``[δx (3), δθ (3)]``,
both in the components of the body frame, which is the inertial frame at rest: the engine's node-frame
rotation increments are turned by each node's rest rotation ``A_n`` (``δθ = A_n δθ_node``), so the modes do
not depend on the section frames (a kinked or curved beam included).

Two bases (Craig & Bampton, AIAA J. 6 (1968) 1313; Géradin & Rixen, *Mechanical Vibrations*, 3rd ed., §4.4):

- :func:`craig_bampton`: the six coordinates of each interface node kept (subscript b), the others (i)
  condensed by the constraint modes ``Ψ = −K_ii⁻¹ K_ib`` and spanned by the ``n`` lowest fixed-interface modes
  ``K_ii φ = ω² M_ii φ``; basis ``T = [[I, 0], [Ψ, Φ]]``.  With the interface held, the reduced model's
  frequencies are the fixed-interface ones, exactly: the reduction of a linear model is exact in its kept modes.
- :func:`free_free`: the ``n`` lowest elastic modes of the unsupported beam (the six rigid motions skipped).

A floating-frame body (Shabana, *Dynamics of Multibody Systems*, 4th ed., ch. 5) needs modes without rigid
motion: :func:`floating_modes` orthogonalises a basis on ``(K, M)`` and drops its six rigid-body vectors.
:func:`invariants` then sums the nodes' lumped masses into the inertia shape integrals the body's mass matrix
is built from (:class:`Invariants`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from reference.generated import rotation_maps as rm
from reference.modal import undamped
from reference.plain.elements import element_tangent
from reference.plain.vectorise import plain
from reference.validation import LabelError

_rotation_matrix = plain(rm.rotation_matrix)


class BeamMatrices(NamedTuple):
    """A beam's linearisation about its rest state (:func:`beam_matrices`).

    ``label``; ``nodes`` (n,) the model's node ids along the beam; ``x`` (n,3) their rest positions [m];
    ``K`` and ``M`` (6n, 6n) dense, the stiffness [N/m, N, N m] and mass [kg, kg m²] on the coordinates of the
    module docstring; ``names`` (n,) the nodes' labels."""

    label: str
    nodes: np.ndarray
    x: np.ndarray
    K: np.ndarray
    M: np.ndarray
    names: tuple


class Basis(NamedTuple):
    """A reduced basis of a beam: ``T`` (6n, r) maps the reduced coordinates to the nodes' six;
    ``K``, ``M`` (r, r) the reduced matrices ``Tᵀ K T``, ``Tᵀ M T``; ``interfaces`` the positions along the
    beam of the interface nodes (the first 6 × len(interfaces) reduced coordinates are theirs, Craig–Bampton);
    ``frequencies`` (n_modes,) [Hz] the fixed-interface (Craig–Bampton) or free-free modes kept."""

    T: np.ndarray
    K: np.ndarray
    M: np.ndarray
    interfaces: tuple
    frequencies: np.ndarray


def rotation_matrices(q) -> np.ndarray:
    """Rotation matrices (n, 3, 3), node frame to inertial, of Euler parameters ``q`` (n, 4)."""
    A = np.empty((9, len(q)))
    _rotation_matrix(np.ascontiguousarray(q.T), A)
    return A.T.reshape(len(q), 3, 3)


def node_coordinates(nodes) -> np.ndarray:
    """The indices of the six coordinates of each of ``nodes`` (node ids in the model, or positions along a beam),
    node by node."""
    return (6 * np.asarray(nodes, dtype=np.int64)[:, None] + np.arange(6)).reshape(-1)


def frame_map(A) -> np.ndarray:
    """``T`` (6n, 6n) from the engine's node-frame coordinates ``[δx, δθ_node]`` to those of the module docstring,
    ``[δx, A_n δθ_node]``, ``A`` (n, 3, 3) the nodes' rest rotations: a matrix ``K`` of the former is ``T K Tᵀ`` in
    the latter."""
    T = np.zeros((6 * len(A), 6 * len(A)))
    for a, R in enumerate(A):
        T[6 * a:6 * a + 3, 6 * a:6 * a + 3] = np.eye(3)
        T[6 * a + 3:6 * a + 6, 6 * a + 3:6 * a + 6] = R
    return T


def beam_matrices(domain, label: str) -> BeamMatrices:
    """K and M of the flexible beam ``label`` of ``domain`` about its rest state (module docstring).

    Raises
    ------
    ValueError
        One line: no flexible beam of that label (a rigid bar is one rigid body, it has no modes), or a beam
        whose nodes other elements share (a reduced beam is a body of its own, joined by joints).
    """
    if label not in domain.beams:
        fix = f"flexible beams: {', '.join(domain.beams) or 'none'}"
        raise ValueError(f"reduce: no flexible beam {label!r} (a rigid bar has no modes); {fix}")
    members = domain.beams[label]
    nodes = np.array([n.id for n in members], dtype=np.int64)
    shared = [e.label for e in domain.elements if set(e.nodes) & set(nodes.tolist())
              and not e.label.startswith(f"{label}/")]
    if shared:
        raise ValueError(f"reduce: beam {label!r} shares nodes with element {shared[0]!r}; "
                         "give it its own end nodes and join it with [[joints]]")
    model = domain.model
    x_all = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3)
    q_all = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4)
    idx = node_coordinates(nodes)
    K_node = element_tangent(model, x_all, q_all)[idx][:, idx].toarray()
    A = rotation_matrices(q_all[nodes])
    T = frame_map(A)
    M = np.zeros_like(T)
    for a, (n, R) in enumerate(zip(nodes, A)):
        M[6 * a:6 * a + 3, 6 * a:6 * a + 3] = model.nodes.mass[n] * np.eye(3)
        M[6 * a + 3:6 * a + 6, 6 * a + 3:6 * a + 6] = R @ model.nodes.inertia[n] @ R.T
    K = T @ K_node @ T.T
    return BeamMatrices(label, nodes, x_all[nodes], 0.5 * (K + K.T), M, tuple(n.label for n in members))


def interface_positions(domain, beam: BeamMatrices, interfaces) -> tuple:
    """The positions along ``beam`` of the interface nodes named by ``interfaces`` (deck references such as
    ``"coupler:start"``, :meth:`reference.domain.Domain.node`); a ValueError of one line for a node that does
    not exist, one of another body, or one named twice."""
    found = []
    for ref in interfaces:
        try:
            node = domain.node(ref)
        except LabelError as exc:
            raise ValueError(f"reduce.interfaces: {exc}") from None
        hits = np.flatnonzero(beam.nodes == node.id)
        if hits.size == 0:
            raise ValueError(f"reduce.interfaces: node {ref!r} is not a node of beam {beam.label!r}; "
                             f"name one of {beam.names[0]} … {beam.names[-1]} (or {beam.label}:start, :mid, :end)")
        if int(hits[0]) in found:
            raise ValueError(f"reduce.interfaces: node {ref!r} named twice; name each interface once")
        found.append(int(hits[0]))
    return tuple(found)


def _pairs(K, M, n: int) -> tuple:
    """The ``n`` lowest ``(ω², φ, kind)`` of ``K φ = ω² M φ``, mass-normalised, by the project's modal solver
    (:func:`reference.modal.undamped`: shift-invert, so the low pairs keep their digits on a stiff beam whose
    rotary inertias make ``K``/``M`` span 1e17), then a Rayleigh–Ritz step on the pairs found (the shifted
    solver leaves close pairs M-orthogonal only to ~1e-6; the projected problem, M near I, restores it to
    round-off); ``kind`` "zero" marks a rigid motion (:data:`reference.modal.ZERO_MODE`)."""
    if n == 0:
        return np.zeros(0), np.zeros((K.shape[0], 0)), np.zeros(0, dtype=str)
    found = undamped(sps.csr_matrix(M), sps.csr_matrix(K), n)
    w2, z = sla.eigh(found.phi.T @ K @ found.phi, found.phi.T @ M @ found.phi)  # Rayleigh–Ritz: M-orthonormal
    return w2, found.phi @ z, found.kind


def _frequencies(w2) -> np.ndarray:
    """[Hz] of eigenvalues ``ω²`` (a round-off negative rigid one reads 0)."""
    return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)


def _reduced(beam: BeamMatrices, T, interfaces, w2) -> Basis:
    return Basis(T, T.T @ beam.K @ T, T.T @ beam.M @ T, tuple(interfaces), _frequencies(w2))


def kept_modes(modes) -> tuple[int, list | None]:
    """``modes`` of a reduction, a count (the lowest that many) or mode numbers (1 the lowest, in frequency order):
    ``(how many of the lowest to compute, the positions kept among them or None for all)``."""
    if isinstance(modes, (int, np.integer)):
        return int(modes), None
    numbers = sorted(int(m) for m in modes)
    return (numbers[-1] if numbers else 0), [m - 1 for m in numbers]


def craig_bampton(beam: BeamMatrices, interfaces: tuple, n_modes) -> Basis:
    """The Craig–Bampton basis of ``beam``: its interface nodes' coordinates (positions along the beam,
    :func:`interface_positions`) and ``n_modes`` fixed-interface normal modes, mass-normalised
    (module docstring): the lowest ``n_modes``, or the modes of those numbers when it is a list
    (:func:`kept_modes`: a mode that frequency order puts late may carry what a response needs, e.g. a bent
    coupler's axial stretching).

    Raises
    ------
    ValueError
        One line: no interface (use :func:`free_free`), or more modes than the interior has coordinates.
    """
    if not interfaces:
        raise ValueError("reduce: Craig–Bampton needs at least one interface node; name one, or reduce by "
                         "free-free modes")
    size = beam.K.shape[0]
    b = node_coordinates(interfaces)
    i = np.setdiff1d(np.arange(size), b)
    lowest, keep = kept_modes(n_modes)
    if not 0 <= lowest <= i.size:
        raise ValueError(f"reduce.modes: {lowest} modes asked of beam {beam.label!r}, whose "
                         f"{len(beam.nodes)} nodes less {len(interfaces)} interface nodes have {i.size} coordinates; "
                         f"ask 0 to {i.size} (or refine the mesh)")
    K_ii, K_ib = beam.K[np.ix_(i, i)], beam.K[np.ix_(i, b)]
    psi = -sla.solve(K_ii, K_ib, assume_a="sym")
    w2, phi, _ = _pairs(K_ii, beam.M[np.ix_(i, i)], lowest)
    if keep is not None:
        w2, phi = w2[keep], phi[:, keep]
    T = np.zeros((size, b.size + phi.shape[1]))
    T[b, :b.size] = np.eye(b.size)
    T[i, :b.size] = psi
    T[i, b.size:] = phi
    return _reduced(beam, T, interfaces, w2)


def enriched(beam: BeamMatrices, basis: Basis, vectors, tolerance: float = 1e-6) -> Basis:
    """``basis`` with the columns of ``vectors`` (6n, k) added (e.g. the modal derivatives of
    :func:`reference.reduced.stiffening.derivative_modes`), each first scaled to unit mass norm, then made
    M-orthogonal to the basis and to each other.  Dropped: a vector whose mass norm is below ``tolerance`` × the
    largest one's (zero by symmetry but for the difference quotients' truncation, e.g. the derivative of an in-plane
    mode along an out-of-plane one), and a direction whose mass norm is below ``tolerance`` once made orthogonal (one
    the basis already spans).  Interfaces and frequencies stay the basis's (:func:`floating_modes` finds the
    enriched body's own)."""
    T, M = basis.T, beam.M
    V = np.asarray(vectors, dtype=float)
    norms = np.sqrt(np.einsum("ik,ij,jk->k", V, M, V))
    kept = norms > tolerance * norms.max(initial=0.0)
    V = V[:, kept] / norms[kept]
    V = V - T @ np.linalg.solve(T.T @ M @ T, T.T @ M @ V)
    gram = V.T @ M @ V
    lam, U = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = lam > tolerance ** 2
    T = np.hstack([T, V @ (U[:, keep] / np.sqrt(lam[keep]))])
    return Basis(T, T.T @ beam.K @ T, T.T @ M @ T, basis.interfaces, basis.frequencies)


def free_free(beam: BeamMatrices, n_modes) -> Basis:
    """The ``n_modes`` lowest elastic modes of the unsupported ``beam`` (or those of the numbers in a list,
    :func:`kept_modes`), mass-normalised (its rigid motions, the zero modes of :func:`_pairs`, skipped).  A
    ValueError of one line when the beam has fewer elastic modes."""
    w2, phi, kind = _pairs(beam.K, beam.M, beam.K.shape[0])
    elastic = np.flatnonzero(kind != "zero")
    lowest, numbers = kept_modes(n_modes)
    if not 1 <= lowest <= elastic.size:
        raise ValueError(f"reduce.modes: {lowest} modes asked of beam {beam.label!r}, which has {elastic.size} "
                         f"elastic modes; ask 1 to {elastic.size} (or refine the mesh)")
    keep = elastic[:lowest] if numbers is None else elastic[numbers]
    return _reduced(beam, phi[:, keep], (), w2[keep])


def floating_modes(beam: BeamMatrices, basis: Basis) -> Basis:
    """The elastic part of ``basis`` as modes of a floating frame: the eigenvectors of the reduced
    ``(Tᵀ K T, Tᵀ M T)``, mass-normalised, less the rigid-body ones (a Craig–Bampton basis spans the six rigid
    motions through its constraint modes, exactly: they are its six lowest pairs, dropped by their rank, since a
    relative zero test misses some where the spectrum spans 1e15, a slender blade's; the frame carries them).
    Each column of the result's ``T`` is a mode shape on the beam's coordinates; ``frequencies`` are the
    unsupported reduced body's."""
    w2, z, _ = _pairs(basis.K, basis.M, basis.K.shape[0])
    elastic = np.argsort(w2)[6:]
    return _reduced(beam, basis.T @ z[:, elastic], basis.interfaces, w2[elastic])


def clamped_modes(beam: BeamMatrices, node: int, n_modes: int) -> Basis:
    """The frame attached to one node (position ``node`` along the beam): the ``n_modes`` fixed-interface modes
    of that node alone, the body reference condition "clamped" of a floating frame (Shabana, §5.7).  Unlike
    :func:`floating_modes` (mean axes) they move the centre of mass (``S₁ ≠ 0``)."""
    basis = craig_bampton(beam, (node,), n_modes)
    return _reduced(beam, basis.T[:, 6:], (node,), (2.0 * np.pi * basis.frequencies) ** 2)
