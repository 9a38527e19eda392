"""The two-node helicoidal beam (SE(3) interpolation, Sonneville, Cardona & Brüls 2014): element family ``"beam2_se3"``.

The ends' section frames ``H_a = (Λ_a, x_a)`` are joined by the helicoid
``H(s) = H_1 exp(s ε̂)``: the strains ``ε = log(H_1⁻¹H_2)/L0`` are constant on the
element, so every constant-strain state (a straight beam, the roll-up circle, a
helix) is represented exactly with any number of elements (docs/formulation.md §3.4).
The per-element arithmetic is the sympy-generated code of
``reference/generated/beam2_se3.py`` (``derivations/beam2_se3.py``): forces, energy,
resultants and the tangent.  Like Beam2 it works in its section frames
``p_a = q_a ⊗ o_a`` and maps its rotational forces and tangent back to the node frames.

Beside the kernels the family differs from Beam2 in its reference only: its section
frames at rest are the beam's own frames at its nodes (on the arc's tangent for an arc),
not the chord frames, so an arc is meshed as the exact circle (:meth:`Beam2SE3Formulation.rest_frames`).
Mass lumping and the critical step are Beam2's: linearised about a straight state the two
elements are the same (``B(ψ) d/L0 ≈ (d − ψ × d/2)/L0``, Beam2's midpoint-triad shear).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.elements.beam2 import PARALLEL_ELEMENTS, Beam2Formulation
from reference.elements.formulation import section_quaternion, tangent_to_node_frames, to_node_frame, vector_norms
from reference.generated import beam2_se3 as generated
from reference.generated import rotation_maps as rm
from reference.jit import inlined, kernel, parallel_kernel, prange
from reference.newton_blocks import store_block
from reference.parallel import ELEMENT_CHUNK, accumulate, element_chunks, energy_sum
from reference.scalar import build_time_form


class Beam2SE3Data(NamedTuple):
    """The beam2_se3 elements of a model (E elements): the fields of
    :class:`~reference.elements.beam2.Beam2Data`, with ``L0`` the helicoid's arc length,
    ``psi0`` the relative rotation of the section frames at rest and ``gamma0`` ``B(ψ0) d0/L0``."""

    conn: np.ndarray
    index: np.ndarray
    offset: np.ndarray
    L0: np.ndarray
    psi0: np.ndarray
    gamma0: np.ndarray
    stiff: np.ndarray
    node_start: np.ndarray
    node_item: np.ndarray


_internal_forces = inlined(generated.internal_forces)


@inlined
def _element(data, x, q, e, w):
    """Forces of element e into ``w`` (40,) in Beam2's layout (``beam2.beam2_element``): node-frame
    moments in ``w[32:38]``, the section quaternions in ``w[24:32]``; returns the strain energy."""
    i, j = data.conn[e, 0], data.conn[e, 1]
    o1, o2 = data.offset[e, 0], data.offset[e, 1]
    section_quaternion(q[i], o1, w[24:28])
    section_quaternion(q[j], o2, w[28:32])
    w[39] = _internal_forces(x[i], x[j], w[24:28], w[28:32], data.L0[e], data.psi0[e], data.gamma0[e],
                             data.stiff[e], w[:12], w[12:18], w[18:24])
    to_node_frame(o1, w[3:6], w[32:35])
    to_node_frame(o2, w[9:12], w[35:38])
    return w[39]


@parallel_kernel
def _elements(data, x, q, W):
    for e in prange(data.conn.shape[0]):
        _element(data, x, q, e, W[e])


_elements_serial = kernel(getattr(_elements, "py_func", _elements))
""":func:`_elements` on the calling thread (a mesh below ``PARALLEL_ELEMENTS``): a kernel of its own, so that
the generated element code is compiled once, not again inside every algorithm's kernel."""


@inlined
def _assemble(data, W, x, q, S):
    """:meth:`Beam2SE3Formulation.assemble`: each element's forces into its row of ``W`` (a parallel loop
    from ``PARALLEL_ELEMENTS`` elements on), added into ``S`` (N, 6) in element order
    (:func:`reference.parallel.accumulate`); returns the strain energy [J]."""
    if data.conn.shape[0] >= PARALLEL_ELEMENTS:
        _elements(data, x, q, W)
    else:
        _elements_serial(data, x, q, W)
    accumulate(data.conn, data.node_start, data.node_item, W, 32, S)
    return energy_sum(W, 39)


@inlined
def _tangent_range(data, W, x, q, psi, ck, values, p0, Jr, K144, lo, hi):
    """The 12×12 tangents times ``ck`` of the elements ``lo … hi − 1``, element e's into ``values`` from
    ``p0 + 144 e`` on (``Jr`` (9,), ``K144`` scratch)."""
    K12 = K144.reshape((12, 12))
    for e in range(lo, hi):
        i, j = data.conn[e, 0], data.conn[e, 1]
        w = W[e]
        if ck != 0.0:
            section_quaternion(q[i], data.offset[e, 0], w[24:28])
            section_quaternion(q[j], data.offset[e, 1], w[28:32])
            generated.tangent(x[i], x[j], w[24:28], w[28:32], data.L0[e], data.psi0[e], data.gamma0[e],
                              data.stiff[e], w[:12], K144)
            tangent_to_node_frames(data.offset[e], K12, w[32:35], w[35:38])
        else:
            K12[:, :] = 0.0
        store_block(K12, data.conn[e], 2, psi, Jr, ck, values, p0 + 144 * e)


@parallel_kernel
def _tangent_parallel(data, W, x, q, psi, ck, values, p):
    E = data.conn.shape[0]
    for k in prange(element_chunks(E)):
        Jr, K144 = np.empty(9), np.empty(144)
        _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K144, k * ELEMENT_CHUNK, min(E, (k + 1) * ELEMENT_CHUNK))


@inlined
def _tangent_values(data, W, x, q, psi, ck, values, p, Jr, K):
    """:meth:`Beam2SE3Formulation.tangent_values`: each element's 12×12 tangent (the generated
    ``tangent``, section frames taken back to the node frames) times ``ck``;
    from ``PARALLEL_ELEMENTS`` elements on a parallel loop, each element writing its own slice."""
    E = data.conn.shape[0]
    if E >= PARALLEL_ELEMENTS:
        _tangent_parallel(data, W, x, q, psi, ck, values, p)
        return p + 144 * E
    _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K[:144], 0, E)
    return p + 144 * E


@inlined
def _resultants(data, W, x, q, N, M):
    """:meth:`Beam2SE3Formulation.resultants`: the element's constant section resultants ``N = C_Γ Γ``
    [N] (1 axial, 2, 3 shear) and ``M = C_K K`` [N m] (1 torsion, 2, 3 bending) in section-frame
    components, the same at every section of the helicoid (constant strains), into the rows ``data.index``."""
    for e in range(data.conn.shape[0]):
        w = W[e]
        _element(data, x, q, e, w)
        r = data.index[e]
        for k in range(3):
            N[r, k] = w[18 + k]
            M[r, k] = w[21 + k]
    return 0.0


class Beam2SE3Formulation(Beam2Formulation):
    """Two-node beam with the helicoidal (SE(3)) interpolation: exact for every constant-strain state.

    Energy ``½ L0 (ε − ε0)ᵀ C (ε − ε0)`` with ``ε = (Γ, K) = log(H_1⁻¹H_2)/L0`` in the section frame
    (no quadrature: the strains are constant on the element), forces its exact gradient and the
    tangent its exact derivative (``derivations/beam2_se3.py``).  Lumped mass and critical step:
    :class:`~reference.elements.beam2.Beam2Formulation`'s (the chord length for an arc, a second-order
    difference in the mass only).

    Parameters
    ----------
    section : Section
    """

    family = "beam2_se3"
    n_nodes = 2
    Data = Beam2SE3Data
    exact_curvature = True
    """Every constant-strain state (curvature included: a circle, a helix) is represented exactly."""
    assemble = staticmethod(_assemble)
    tangent_values = staticmethod(_tangent_values)
    resultants = staticmethod(_resultants)

    curve_segments = 8

    def curve(self, x_nodes, p_nodes, xi):
        """Centre-line points at ``xi`` ∈ [0, 1] on the element's helicoid ``H(ξ) = H_1 exp(ξ η)``,
        ``η = (U, ψ) = log(H_1⁻¹H_2)``: ``ψ = log(Λ1ᵀΛ2)``, ``U = J_r(ψ)⁻ᵀ Λ1ᵀ(x2 − x1)`` and
        ``x(ξ) = x1 + Λ1 J_r(ξψ)ᵀ ξU`` (docs/formulation.md §3.4; ``p_nodes`` the section triads)."""
        x1, x2 = (np.asarray(v, dtype=float) for v in x_nodes)
        p1, p2 = (np.asarray(v, dtype=float) for v in p_nodes)
        A1, rel, psi, jr = np.empty(9), np.empty(4), np.empty(3), np.empty(9)
        rm.rotation_matrix(p1, A1)
        rm.quat_product(p1 * np.array([1.0, -1.0, -1.0, -1.0]), p2, rel)
        rm.log_quaternion(rel, psi)
        rm.right_jacobian(psi, jr)
        A1 = A1.reshape(3, 3)
        U = np.linalg.solve(jr.reshape(3, 3).T, A1.T @ (x2 - x1))
        out = np.empty((len(xi), 3))
        for k, t in enumerate(np.asarray(xi, dtype=float)):
            rm.right_jacobian(t * psi, jr)
            out[k] = x1 + A1 @ (jr.reshape(3, 3).T @ (t * U))
        return out

    @classmethod
    def pack(cls, placed) -> Beam2SE3Data:
        """The family's plain data: Beam2's fields (but those of its vectorised loop, which this family has
        not), with this family's reference state."""
        return Beam2SE3Data(*super().pack(placed)[:len(Beam2SE3Data._fields)])

    @staticmethod
    def rest_frames(node_frames, chord_frames, i):
        """The section triads at rest of element i's two ends: the beam's own triads at its nodes
        (the arc's tangent frames), so the reference helicoid is the arc itself."""
        return node_frames[i], node_frames[i + 1]

    @staticmethod
    def rest_states(x, p, stiff):
        """``L0 = |U0|`` (E,) (the helicoid's arc length, the chord for a straight element),
        ``ψ0 = log(Λ1ᵀΛ2)`` and ``Γ0 = U0/L0`` (E, 3) with ``U0 = B(ψ0) Λ1ᵀ(x2 − x1)`` at rest, of E elements
        (``x`` (E, 2, 3), ``p`` (E, 2, 4)): the generated kernel's strains with ``L0 = 1`` and a zero
        reference, element by element (the per-element :meth:`reference_state` is this with E = 1)."""
        x, p = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(p, dtype=float)
        stiff = np.ascontiguousarray(stiff, dtype=float)
        strain, s, stress = np.empty((x.shape[0], 6)), np.empty(12), np.empty(6)
        forces = build_time_form(generated.internal_forces, x.shape[0])  # a small model: nothing to compile
        for e in range(x.shape[0]):
            forces(x[e, 0], x[e, 1], p[e, 0], p[e, 1], 1.0, np.zeros(3), np.zeros(3), stiff[e], s, strain[e], stress)
        L0 = vector_norms(strain[:, :3])
        if (L0 <= 0.0).any():
            raise ValueError("beam2_se3 element of zero length")
        return L0, strain[:, 3:].copy(), strain[:, :3] / L0[:, None]

    def _evaluate(self, x_nodes, q_nodes, reference):
        s, strain, stress = np.empty(12), np.empty(6), np.empty(6)
        U = generated.internal_forces(
            np.asarray(x_nodes[0], float), np.asarray(x_nodes[1], float), np.asarray(q_nodes[0], float),
            np.asarray(q_nodes[1], float), reference["L0"], reference["psi0"], reference["gamma0"],
            self.section.stiffness, s, strain, stress,
        )
        return s, U, strain, stress

    def tangent(self, x_nodes, q_nodes, reference) -> np.ndarray:
        """The 12×12 tangent ``∂S/∂[δx1, δθ1, δx2, δθ2]`` of one element in its section frames."""
        s, K = np.empty(12), np.empty(144)
        generated.tangent(np.asarray(x_nodes[0], float), np.asarray(x_nodes[1], float), np.asarray(q_nodes[0], float),
                          np.asarray(q_nodes[1], float), reference["L0"], reference["psi0"], reference["gamma0"],
                          self.section.stiffness, s, K)
        return K.reshape(12, 12)

    def section_resultants(self, x_nodes, q_nodes, reference):
        """Strains ``(Γ, K)`` and resultants ``(N, M)`` of the element (constant on it), section frame."""
        _, _, strain, stress = self._evaluate(x_nodes, q_nodes, reference)
        return strain, stress
