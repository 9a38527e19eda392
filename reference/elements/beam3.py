"""The three-node quadratic beam (Crisfield & Jelenić 1999): element family ``"beam3"``.

Positions and *local* rotations ``ψ_i = log(Λ3ᵀΛ_i)`` (relative to the middle node's section
triad, so the strains are objective and path independent) are interpolated quadratically;
the energy is integrated at the two Gauss points ``ξ = ∓1/√3`` (reduced integration of the
quadratic element: free of shear and membrane locking).  Forces, energy, resultants and the
tangent are the sympy-generated ``reference/generated/beam3.py`` (``derivations/beam3.py``,
docs/formulation.md §3.5).  Nodes of an element in the order (end 1, end 2, middle); like Beam2
it works in its section frames ``p_a = q_a ⊗ o_a`` and maps its rotational forces and tangent
back to the node frames.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.elements.driver import row_layout
from reference.elements.element_type import Beam3
from reference.elements.formulation import BeamFormulation, PlacedElements, vector_norms
from reference.generated import beam3 as generated
from reference.jit import inlined
from reference.parallel import node_incidence
from reference.scalar import scalar_twin

ROW = row_layout(3, "Beam3Row", forces=18, strains=12, stresses=12, triads=12, moments=9, energy=1, u=18,
                 hessians=162)
"""The work row of a beam3 element (:func:`reference.elements.driver.row_layout`): section-frame forces (18),
the strains ``Γ, K`` (12) and resultants ``N, M`` (12) at the two Gauss points (6 each), the section triads
(12), the node-frame moments (9), the strain energy, the Gauss points' inputs ``u`` (18: 9 each) and their
Hessians (162: 81 each) of the generated kernels."""
GAUSS = tuple(Beam3().integration_points()[0])
"""The element type's two Gauss points ξ = ∓1/√3."""


class Beam3Data(NamedTuple):
    """The beam3 elements of a model (E elements), as the compiled kernels take them.

    ``conn`` (E, 3) node numbers (end 1, end 2, middle); ``index`` (E,) the elements' numbers in the
    Domain; ``offset`` (E, 3, 4) the constant Euler parameters from each node's frame to the element's
    section frame there; ``L0`` (E,) reference length; ``gamma0``, ``kappa0`` (E, 6) the strains at
    the two Gauss points at rest; ``stiff`` (E, 6) = EA, GA2, GA3, GJ, EI2, EI3.
    """

    conn: np.ndarray
    index: np.ndarray
    offset: np.ndarray
    L0: np.ndarray
    gamma0: np.ndarray
    kappa0: np.ndarray
    stiff: np.ndarray
    node_start: np.ndarray
    node_item: np.ndarray


_internal_forces = inlined(generated.internal_forces)


@inlined
def element_forces(data, e, X, P, w):
    """Element e's section-frame forces, its Gauss points' strains, resultants and inputs ``u`` into its row
    ``w`` (:data:`ROW`) from its nodes' positions ``X`` (3, 3) [m] and section triads ``P`` (3, 4), node
    order (end 1, end 2, middle); returns its strain energy [J] (the generated ``internal_forces``)."""
    return _internal_forces(X[0], X[1], X[2], P[0], P[1], P[2], data.L0[e], data.gamma0[e], data.kappa0[e],
                            data.stiff[e], w[ROW.forces], w[ROW.u], w[ROW.strains], w[ROW.stresses])


@inlined
def element_tangent(data, e, X, P, w, K):
    """Element e's 18×18 section-frame tangent into ``K`` (324,): the forces' inputs at the Gauss points
    (:func:`element_forces`), each point's Hessian of the energy density (``gauss_hessian``), then the
    generated ``tangent``."""
    element_forces(data, e, X, P, w)
    u, hessians = w[ROW.u].reshape((2, 9)), w[ROW.hessians].reshape((2, 81))
    gamma0, kappa0 = data.gamma0[e].reshape((2, 3)), data.kappa0[e].reshape((2, 3))
    for g in range(2):
        generated.gauss_hessian(u[g], gamma0[g], kappa0[g], data.stiff[e], data.L0[e], hessians[g])
    generated.tangent(X[0], X[1], X[2], P[0], P[1], P[2], data.L0[e], data.gamma0[e], data.kappa0[e],
                      data.stiff[e], w[ROW.hessians], w[ROW.forces], K)


@inlined
def element_resultants(w, N, M):
    """The mean of the two Gauss points' resultants ``N`` [N] and ``M`` [N m] (section-frame components; the
    midpoint value to second order)."""
    stress = w[ROW.stresses].reshape((2, 6))
    for k in range(3):
        N[k] = 0.5 * (stress[0, k] + stress[1, k])
        M[k] = 0.5 * (stress[0, 3 + k] + stress[1, 3 + k])


class Beam3Formulation(BeamFormulation):
    """Three-node geometrically exact beam, quadratic interpolation, two-point Gauss integration.

    Lumped mass: the row sums of the consistent quadratic mass, ``ρA L0 (1/6, 1/6, 2/3)`` and the
    same shares of the rotary inertia (Simpson's weights; node order end, end, middle).  Critical
    step: the exact limit ``2/√λ_max`` of one free lumped element, computed from its tangent.

    Parameters
    ----------
    section : Section
    """

    family = "beam3"
    n_nodes = 3
    Data = Beam3Data
    exact_curvature = False
    """Constant stretch, shear and twist exact; a constant curvature only to the quadratic's accuracy."""
    default_type = Beam3
    ROW = ROW
    element_forces = staticmethod(element_forces)
    element_tangent = staticmethod(element_tangent)
    element_resultants = staticmethod(element_resultants)

    @classmethod
    def pack(cls, placed: PlacedElements) -> Beam3Data:
        """The family's plain data from its elements placed at t = 0 (element by element)."""
        E = len(placed)
        conn = np.array([item.element.nodes for item in placed], dtype=np.int64).reshape(E, 3)
        data = Beam3Data(conn, np.zeros(E, dtype=np.int64), np.zeros((E, 3, 4)), np.zeros(E), np.zeros((E, 6)),
                         np.zeros((E, 6)), np.zeros((E, 6)), *node_incidence(conn))
        for e, item in enumerate(placed):
            ref = item.element.formulation.reference_state(item.x, item.p)
            data.index[e], data.offset[e] = item.index, item.offset
            data.L0[e], data.gamma0[e], data.kappa0[e] = ref["L0"], ref["gamma0"], ref["kappa0"]
            data.stiff[e] = item.element.formulation.section.stiffness
        return data

    curve_segments = 8
    node_xi = (0.0, 1.0, 0.5)

    def curve(self, x_nodes, p_nodes, xi):
        """Centre-line points at ``xi`` ∈ [0, 1]: the quadratic Lagrange interpolation of the nodes (end, end,
        middle at ξ = 0, 1, ½), the element's own position interpolation."""
        x = np.asarray(x_nodes, dtype=float)
        t = np.asarray(xi, dtype=float)[:, None]
        return (1 - t) * (1 - 2 * t) * x[0] + t * (2 * t - 1) * x[1] + 4 * t * (1 - t) * x[2]

    @staticmethod
    def mesh_nodes(nodes: list, i: int) -> tuple:
        """Element i of a beam meshed with 2 segments per element: (end, end, middle)."""
        return nodes[2 * i], nodes[2 * i + 2], nodes[2 * i + 1]

    @staticmethod
    def rest_frames(node_frames, chord_frames, i):
        """The beam's own triads at the element's three nodes (on an arc, its tangent frames)."""
        return node_frames[2 * i], node_frames[2 * i + 2], node_frames[2 * i + 1]

    def lumped_masses(self, x):
        """E elements' (``x`` (E, 3, 3)) shares 1/6, 1/6, 2/3 of ``ρA L`` (E, 3) [kg] and of
        ``diag(ρJ1, ρJ2, ρJ3) L`` (E, 3, 3) [kg m²] (Simpson's weights, the element type's
        :data:`~reference.elements.element_type.Beam3.MASS_SHARES`), ``L`` the Gauss length (:meth:`_lengths`)."""
        length = self._lengths(x)[:, None]
        share = np.array(self.element_type.MASS_SHARES)[None, :]
        inertia = np.zeros(length.shape[:1] + (3, 3, 3))
        for k, rho_j in enumerate(self.section.rotary_inertia):
            inertia[..., k, k] = rho_j * share * length
        return self.section.rhoA * share * length, inertia

    @staticmethod
    def _length(x_nodes) -> float:
        """Two-point Gauss length of the quadratic curve through the nodes (exact for a straight element)."""
        return float(Beam3Formulation._lengths(np.asarray(x_nodes, dtype=float)[None])[0])

    @staticmethod
    def _lengths(x) -> np.ndarray:
        """:meth:`_length` of E elements, ``x`` (E, 3, 3)."""
        x1, x2, x3 = x[:, 0], x[:, 1], x[:, 2]
        return sum(vector_norms((xi - 0.5) * x1 + (xi + 0.5) * x2 - 2 * xi * x3) for xi in GAUSS)

    def reference_state(self, x_nodes, q_nodes):
        """``L0`` (:meth:`_length`) and the strains ``Γ0``, ``K0`` at the Gauss points at rest."""
        length = self._length(x_nodes)
        if length <= 0.0:
            raise ValueError("beam3 element of zero length")
        _, _, strain, _ = self._evaluate(x_nodes, q_nodes, {"L0": length, "gamma0": np.zeros(6),
                                                            "kappa0": np.zeros(6)})
        return {"L0": length, "gamma0": np.concatenate([strain[0:3], strain[6:9]]),
                "kappa0": np.concatenate([strain[3:6], strain[9:12]])}

    def _evaluate(self, x_nodes, q_nodes, reference, u=None):
        s, strain, stress, u = np.empty(18), np.empty(12), np.empty(12), np.empty(18) if u is None else u
        x, q = np.asarray(x_nodes, float), np.asarray(q_nodes, float)
        forces = scalar_twin(generated.internal_forces)  # one element from Python: nothing to compile
        U = forces(x[0], x[1], x[2], q[0], q[1], q[2], reference["L0"], reference["gamma0"], reference["kappa0"],
                   self.section.stiffness, s, u, strain, stress)
        return s, U, strain, stress

    def tangent(self, x_nodes, q_nodes, reference) -> np.ndarray:
        """The 18×18 tangent ``∂S/∂[δx1, δθ1, δx2, δθ2, δx3, δθ3]`` of one element, section frames."""
        u, hess, s, K = np.empty(18), np.empty(162), np.empty(18), np.empty(324)
        self._evaluate(x_nodes, q_nodes, reference, u)
        g0, k0, c = np.asarray(reference["gamma0"], float), np.asarray(reference["kappa0"], float), self.section.stiffness
        gauss_hessian = scalar_twin(generated.gauss_hessian)
        for g in range(2):
            gauss_hessian(u[9 * g:9 * g + 9], g0[3 * g:3 * g + 3], k0[3 * g:3 * g + 3], c, reference["L0"],
                          hess[81 * g:81 * g + 81])
        x, q = np.asarray(x_nodes, float), np.asarray(q_nodes, float)
        scalar_twin(generated.tangent)(x[0], x[1], x[2], q[0], q[1], q[2], reference["L0"], g0, k0, c, hess, s, K)
        return K.reshape(18, 18)

    def section_resultants(self, x_nodes, q_nodes, reference):
        """Strains ``(Γ, K)`` and resultants ``(N, M)``: the means of the two Gauss points, section frame."""
        _, _, strain, stress = self._evaluate(x_nodes, q_nodes, reference)
        return 0.5 * (strain[:6] + strain[6:]), 0.5 * (stress[:6] + stress[6:])

    def integration_points(self, x_nodes, q_nodes, reference):
        """The two Gauss points ``ξ = ½ ∓ ½/√3`` (along the element from its first end) and their strains and
        resultants (2, 6), section frame, each at its own point (:meth:`section_resultants` gives their mean)."""
        _, _, strain, stress = self._evaluate(x_nodes, q_nodes, reference)
        return 0.5 + 0.5 * np.array(GAUSS), strain.reshape(2, 6), stress.reshape(2, 6)

    def critical_time_step(self, length):
        """``2/√λ_max`` of one free straight lumped element of this length (its 18×18 tangent at rest
        against the lumped masses and rotary inertias): the stability limit of central differences [s]."""
        ident = np.array([1.0, 0.0, 0.0, 0.0])
        x = np.array([[0.0, 0, 0], [length, 0, 0], [0.5 * length, 0, 0]])
        q = np.array([ident] * 3)
        K = self.tangent(x, q, self.reference_state(x, q))
        m = np.concatenate([np.concatenate([[mass] * 3, np.diag(J)]) for mass, J in self.lumped_mass(x)])
        lam = np.linalg.eigvalsh(0.5 * (K + K.T) / np.sqrt(np.outer(m, m)))
        return float(2.0 / np.sqrt(lam.max()))
