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

import reference.elements.driver as driver
from reference.elements.beam2 import ROW, Beam2Formulation
from reference.elements.formulation import vector_norms
from reference.generated import beam2_se3 as generated
from reference.generated import rotation_maps as rm
from reference.jit import inlined
from reference.scalar import build_time_form, remembered


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
def element_forces(data, e, X, P, w):
    """Element e's section-frame forces, strains and resultants into ``w`` (Beam2's row,
    :data:`~reference.elements.beam2.ROW`) from its ends' positions ``X`` (2, 3) and section triads
    ``P`` (2, 4); returns its strain energy [J] (the generated ``internal_forces``)."""
    return _internal_forces(X[0], X[1], P[0], P[1], data.L0[e], data.psi0[e], data.gamma0[e], data.stiff[e],
                            w[ROW.forces], w[ROW.strains], w[ROW.stresses])


@inlined
def element_tangent(data, e, X, P, w, K):
    """Element e's 12×12 section-frame tangent into ``K`` (144,) (the generated ``tangent``)."""
    generated.tangent(X[0], X[1], P[0], P[1], data.L0[e], data.psi0[e], data.gamma0[e], data.stiff[e],
                      w[ROW.forces], K)


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
    element_forces = staticmethod(element_forces)
    element_tangent = staticmethod(element_tangent)
    # element_resultants: Beam2's, the stresses of the row (here constant along the helicoid)
    assemble = staticmethod(driver.assemble)
    """The generic element loop (Beam2's own is its vectorised generated code)."""

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
    @remembered
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
