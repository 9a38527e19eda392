"""The geometrically exact two-node beam (``Beam2_Formulation`` of the paper, §4.2.2, Fig. 4): element family ``"beam2"``.

The per-element arithmetic is the sympy-generated code of
``reference/generated/beam2.py`` (``derivations/beam2.py``) and its tangent
``reference/generated/tangents.py`` (``derivations/tangents.py``), called by the family's
per-element functions :func:`element_forces`, :func:`element_tangent` and :func:`element_resultants`
in the element's section frames ``p_a = q_a ⊗ o_a``; the generic driver
(:mod:`reference.elements.driver`) gathers, takes the moments and tangents back to the node frames,
sums and stores the tangent blocks.  The family's own :func:`assemble` runs, on a model below
:data:`~reference.parallel.PARALLEL_NODES` nodes or from :data:`~reference.elements.driver.PARALLEL_ELEMENTS`
elements on, the structure-of-arrays form of the same generated arithmetic
(``reference/generated/beam2_soa.py``, ``derivations/soa.py``: blocks of 64 elements, loops vectorised across the
elements; :mod:`reference.elements.beam2_blocks`), bit for bit the per-element rows.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

import reference.elements.driver as driver
from reference.elements.beam2_blocks import ROW, add_element, soa_fixed_rows, soa_forces, soa_rows, straight_elements
from reference.elements.element_type import Beam2
from reference.elements.formulation import BeamFormulation, PlacedElements, end_offsets, vector_norms
from reference.generated import beam2 as generated_beam2
from reference.generated import rotation_maps as rm
from reference.generated import tangents as generated_tangents
from reference.jit import inlined, kernel
from reference.parallel import PARALLEL_NODES, accumulate, energy_sum, node_incidence, scatter
from reference.scalar import build_time_form, remembered

class Beam2Data(NamedTuple):
    """The Beam2 elements of a model (E elements), as the compiled kernels take them.

    ``conn`` (E, 2) node numbers; ``index`` (E,) the elements' numbers in the Domain;
    ``offset`` (E, 2, 4) the constant Euler parameters ``o_a`` from the frame of node
    ``conn[e, a]`` to the element's section frame at that end (``p_a = q_a ⊗ o_a``, fixed at
    t = 0 as ``o_a = q_a⁰* ⊗ p_a⁰``; the identity where the node frame is the section frame);
    ``L0`` (E,) reference length [m]; ``psi0``, ``gamma0`` (E, 3) the reference relative
    rotation and ``Γ0`` of the section frames (0 and E1 for a straight element);
    ``stiff`` (E, 6) = EA, GA2, GA3, GJ, EI2, EI3; ``node_start``, ``node_item`` the node → (element,
    end) incidence (:func:`reference.parallel.node_incidence`) of the element → node gather;
    ``straight`` (E,) 1 where both offsets are the identity (:func:`straight_elements`); ``blocked`` the
    values that never change, ``L0``, ``psi0``, ``gamma0``, ``stiff``, in the structure-of-arrays rows
    of the vectorised element loop (:func:`soa_fixed_rows`), filled once here instead of gathered at
    every step.
    """

    conn: np.ndarray
    index: np.ndarray
    offset: np.ndarray
    L0: np.ndarray
    psi0: np.ndarray
    gamma0: np.ndarray
    stiff: np.ndarray
    node_start: np.ndarray
    node_item: np.ndarray
    straight: np.ndarray
    blocked: np.ndarray


_internal_forces = inlined(generated_beam2.internal_forces)


@inlined
def element_forces(data, e, X, P, w):
    """Element e's section-frame forces (12), strains ``Γ, K`` and resultants ``N, M`` at the midpoint into
    its row ``w`` (:data:`~reference.elements.beam2_blocks.ROW`), from its ends' positions ``X`` (2, 3) [m]
    and section triads ``P`` (2, 4); returns its strain energy [J] (the generated ``internal_forces``,
    ``derivations/beam2.py``)."""
    return _internal_forces(X[0], X[1], P[0], P[1], data.L0[e], data.psi0[e], data.gamma0[e], data.stiff[e],
                            w[ROW.forces], w[ROW.strains], w[ROW.stresses])


@inlined
def element_tangent(data, e, X, P, w, K):
    """Element e's 12×12 section-frame tangent, material and geometric, into ``K`` (144,) (the generated
    ``beam2_tangent``, ``derivations/tangents.py``)."""
    generated_tangents.beam2_tangent(X[0], X[1], P[0], P[1], data.L0[e], data.psi0[e], data.gamma0[e],
                                     data.stiff[e], w[ROW.forces], K)


@inlined
def element_resultants(w, N, M):
    """The section resultants at the element's midpoint, section frame: ``N = C_Γ (Γ − Γ0)`` [N] (component 1
    the axial force, positive in tension; 2, 3 the shear forces) and ``M = C_K K`` [N m] (1 torsion, 2, 3
    bending), in the midpoint frame ``A_m`` of the generated kernel."""
    stress = w[ROW.stresses]
    for k in range(3):
        N[k] = stress[k]
        M[k] = stress[3 + k]


@kernel
def _assemble_serial(data, x, q, S, W):
    """``S`` zeroed, then every element's forces (:func:`reference.elements.driver.element_row`, one row
    ``W`` (1, ROW.width) reused) added into it in element order; returns ΣU."""
    S[:, :] = 0.0
    U = 0.0
    X = np.empty((2, 3))
    for e in range(data.conn.shape[0]):
        U += driver.element_row(data, x, q, e, W[0], X)
        add_element(data.conn, e, W, 0, S)
    return U


def beam2_assemble(x, q, conn, offset, L0, psi0, gamma0, stiff, S, s_el):
    """Add the internal forces of all Beam2 elements into ``S`` (N, 6); return ΣU.

    Each end's section triad is ``p_a = q_a ⊗ o_a`` (:func:`~reference.elements.formulation.section_quaternion`,
    ``offset`` (E,2,4)); the generated kernel works in the section frames and its rotational forces are mapped
    back to the node frames (:func:`~reference.elements.formulation.to_node_frame`).  ``S`` is zeroed first;
    ``s_el`` (``ROW.width``,) is the last element's row (:data:`~reference.elements.beam2_blocks.ROW`).
    One element after the other, the generic driver's element (the reference the vectorised loop is
    checked against).
    """
    conn = np.asarray(conn, dtype=np.int64)
    data = Beam2Data(conn, np.arange(conn.shape[0], dtype=np.int64), offset, L0, psi0, gamma0, stiff,
                     *node_incidence(conn), straight_elements(offset), soa_fixed_rows(L0, psi0, gamma0, stiff))
    return _assemble_serial(data, x, q, S, s_el.reshape((1, ROW.width)))


def beam2_assemble_parallel(x, q, conn, offset, L0, psi0, gamma0, stiff, S, W):
    """:func:`beam2_assemble` with the elements computed in parallel, bit for bit the same result
    (``S``, ΣU and every row's forces and energy; the strains and resultants of ``W`` are not written).

    The elements are independent: the structure-of-arrays loop (:func:`soa_rows`) writes each element's
    row of ``W`` (E, ``ROW.width``) on the threads of :func:`reference.jit.use_threads`; then one thread
    adds the rows into ``S`` and ΣU in element order (:func:`reference.parallel.scatter`), so the result
    does not depend on the thread count (docs/benchmarks.md §5, §10).
    """
    return _assemble_parallel(x, q, conn, offset, straight_elements(offset), soa_fixed_rows(L0, psi0, gamma0, stiff),
                              S, W)


@kernel
def _assemble_parallel(x, q, conn, offset, straight, blocked, S, W):
    soa_rows(x, q, conn, offset, straight, blocked, W)
    S[:, :] = 0.0
    scatter(conn, W, ROW.moment_column, S)
    return energy_sum(W, ROW.energy)


@inlined
def assemble(data, W, x, q, S):
    """:meth:`Beam2Formulation.assemble`: each element's forces into ``S`` (N, 6), returning the strain energy
    (element order).  Below :data:`~reference.parallel.PARALLEL_NODES` nodes, whatever the element count, one
    serial pass of the structure-of-arrays form adds the blocks' forces into ``S`` (:func:`soa_forces`: no
    parallel launch, no round trip through ``W``; on the three-bar's four elements it is also cheaper than the
    generic driver's element rows).  On a larger model each element's row of ``W`` (the vectorised parallel
    loop from :data:`~reference.elements.driver.PARALLEL_ELEMENTS` elements on, the generic driver's below),
    then added into ``S`` in element order (:func:`reference.parallel.accumulate`).  The same numbers every
    way."""
    if S.shape[0] < PARALLEL_NODES:
        return soa_forces(x, q, data.conn, data.offset, data.straight, data.blocked, W, S)
    if data.conn.shape[0] >= driver.PARALLEL_ELEMENTS:
        soa_rows(x, q, data.conn, data.offset, data.straight, data.blocked, W)
    else:
        driver.rows_serial(data, x, q, W)
    accumulate(data.conn, data.node_start, data.node_item, W, ROW.moment_column, S)
    return energy_sum(W, ROW.energy)


@kernel
def _rest_strains(x, p, L0, rel, stiff, psi0, gamma0):
    """Each element's ``ψ0 = log(rel)`` (``rel = p1* ⊗ p2``) and ``Γ0``: the strain Γ of the generated
    kernel at rest with ``ψ0`` and ``Γ0 = 0`` (:meth:`Beam2Formulation.rest_states`), into ``psi0``, ``gamma0``
    (E, 3)."""
    s, strain, stress, zero = np.empty(12), np.empty(6), np.empty(6), np.zeros(3)
    for e in range(x.shape[0]):
        rm.log_quaternion(rel[e], psi0[e])
        generated_beam2.internal_forces(x[e, 0], x[e, 1], p[e, 0], p[e, 1], L0[e], psi0[e], zero, stiff[e], s,
                                        strain, stress)
        for k in range(3):
            gamma0[e, k] = strain[k]


class Beam2Formulation(BeamFormulation):
    """Geometrically exact two-node beam, one-point integration, lumped mass.

    Strains and internal forces: see ``derivations/beam2.py`` (the internal
    force is the exact gradient of the element strain energy).  Mass: row-sum
    lumping ``m_i = ∫ N_i ρA ds = ρA L0/2`` and rotary inertia
    ``J_i = (L0/2) diag(ρJ1, ρJ2, ρJ3)`` in the element's section frame; the
    Domain adds ``O_a J_i O_aᵀ`` to the node (``O_a`` the end's offset, a full
    tensor at a kinked node), constant because rotary motion is written in the
    body frame (paper §3.1).  ``q_nodes`` passed to the methods below are the
    section triads of the ends (``p_a = q_a ⊗ o_a``).

    Parameters
    ----------
    section : Section
    element_type : ElementType, default Beam2()
    """

    family = "beam2"
    n_nodes = 2
    Data = Beam2Data
    exact_curvature = False
    """Constant-strain states represented exactly: stretch, shear and twist; a constant curvature only
    as the polygon of chords (second order)."""
    ROW = ROW
    element_forces = staticmethod(element_forces)
    element_tangent = staticmethod(element_tangent)
    element_resultants = staticmethod(element_resultants)
    assemble = staticmethod(assemble)
    tangent_values = staticmethod(driver.tangent_values)
    resultants = staticmethod(driver.resultants)

    default_type = Beam2

    @classmethod
    def pack(cls, placed: PlacedElements) -> Beam2Data:
        """The family's plain data from its elements placed at t = 0 (reference states of the section frames,
        :meth:`rest_states`, all elements at once)."""
        conn = np.asarray(placed.conn, dtype=np.int64).reshape(len(placed), 2)
        stiff = placed.sections("stiffness", 6)
        L0, psi0, gamma0 = cls.rest_states(placed.x, placed.p, stiff)
        offset = np.array(placed.offset, dtype=float).reshape(len(placed), 2, 4)
        return Beam2Data(conn, np.asarray(placed.index, dtype=np.int64), offset, L0, psi0, gamma0, stiff,
                         *node_incidence(conn), straight_elements(offset), soa_fixed_rows(L0, psi0, gamma0, stiff))

    work = staticmethod(driver.work)

    def lumped_masses(self, x):
        """Row-sum lumping of E elements, ``x`` (E, n, 3): ``m_i = ρA ∫ N_i ds`` (E, n) [kg] and
        ``J_i = diag(ρJ1, ρJ2, ρJ3) ∫ N_i ds`` (E, n, 3, 3) [kg m²], section frame (the element type's mass
        points; its integrals of ``N_i`` over [−1, 1] are computed once per formulation; ds = L/2 dξ)."""
        length = vector_norms(x[:, 1] - x[:, 0])
        if self._shape_integrals is None:
            xi, w = self.element_type.mass_points()
            self._shape_integrals = [sum(wk * self.element_type.shape_functions(xk)[i] for xk, wk in zip(xi, w))
                                     for i in range(self.element_type.n_nodes)]
        share = np.array(self._shape_integrals, dtype=float)[None, :] * length[:, None] / 2
        inertia = np.zeros(share.shape + (3, 3))
        for k, rho_j in enumerate(self.section.rotary_inertia):
            inertia[..., k, k] = rho_j * share
        return self.section.rhoA * share, inertia

    def reference_state(self, x_nodes, q_nodes):
        """Reference length ``L0``, relative rotation ``ψ0`` and ``Γ0 = Amᵀ x'`` of one element
        (:meth:`rest_states`).

        With these the element is unstrained in its initial configuration
        (a curved or kinked reference is allowed).
        """
        L0, psi0, gamma0 = self.rest_states(np.asarray(x_nodes, dtype=float)[None],
                                            np.asarray(q_nodes, dtype=float)[None], self.section.stiffness[None])
        return {"L0": float(L0[0]), "psi0": psi0[0], "gamma0": gamma0[0]}

    @staticmethod
    @remembered
    def rest_states(x, p, stiff):
        """``L0`` (E,) [m], ``ψ0 = log(p1* ⊗ p2)`` and ``Γ0`` (E, 3) of E elements at rest, node positions
        ``x`` (E, 2, 3), section triads ``p`` (E, 2, 4), stiffnesses ``stiff`` (E, 6): ``Γ0 = Amᵀ x'``
        is the generated kernel's Γ evaluated with the reference itself and Γ0 = 0 (:func:`_rest_strains`)."""
        x, p = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(p, dtype=float)
        L0 = vector_norms(x[:, 1] - x[:, 0])
        if (L0 <= 0.0).any():
            raise ValueError("Beam2 element of zero length")
        psi0, gamma0 = np.empty((len(L0), 3)), np.empty((len(L0), 3))
        rest_strains = build_time_form(_rest_strains, len(L0))  # a small model: Python, nothing to compile
        rest_strains(x, p, L0, end_offsets(p[:, 0], p[:, 1]), np.ascontiguousarray(stiff, dtype=float), psi0, gamma0)
        return L0, psi0, gamma0

    def _evaluate(self, x_nodes, q_nodes, reference):
        s, strain, stress = np.empty(12), np.empty(6), np.empty(6)
        U = generated_beam2.internal_forces(
            x_nodes[0], x_nodes[1], q_nodes[0], q_nodes[1], reference["L0"], reference["psi0"],
            reference["gamma0"], self.section.stiffness, s, strain, stress,
        )
        return s, U, strain, stress

    def tangent(self, x_nodes, q_nodes, reference) -> np.ndarray:
        """The 12×12 tangent ``∂S/∂[δx1, δθ1, δx2, δθ2]`` of one element in its section frames
        (the generated ``beam2_tangent``)."""
        s, K = np.empty(12), np.empty(144)
        generated_tangents.beam2_tangent(x_nodes[0], x_nodes[1], q_nodes[0], q_nodes[1], reference["L0"],
                                         reference["psi0"], reference["gamma0"], self.section.stiffness, s, K)
        return K.reshape(12, 12)

    def section_resultants(self, x_nodes, q_nodes, reference):
        """Strains ``(Γ, K)`` and resultants ``(N, M)`` at the midpoint, section frame."""
        _, _, strain, stress = self._evaluate(x_nodes, q_nodes, reference)
        return strain, stress

    def integration_points(self, x_nodes, q_nodes, reference):
        """The integration points' parameters ξ (G,) ∈ [0, 1] along the element and their strains and
        resultants (G, 6), section frame (``q_nodes`` the section triads): Beam2's one point at the
        midpoint; a family whose strains are constant on the element (beam2_se3) has the same one row."""
        strain, stress = self.section_resultants(x_nodes, q_nodes, reference)
        return np.array([0.5]), np.asarray(strain, float)[None, :6], np.asarray(stress, float)[None, :6]

    def critical_time_step(self, length):
        """Stability limit of central differences for one lumped element [s].

        The minimum of the axial ``L0 √(ρA/EA)``, torsional ``L0 √(ρJ1/GJ)``,
        bending–rotation ``L0 √(ρJ/EI)`` limits and the coupled shear–rotation
        mode ``2/√((GA/ρA)(4/L0² + ρA/ρJ))`` (docs/formulation.md §3 compares each with the
        eigenvalue limit of the lumped element; the last is on the safe side).
        """
        s = self.section
        limits = [
            length * np.sqrt(s.rhoA / s.EA),
            length * np.sqrt(s.rhoJ1 / s.GJ),
            length * np.sqrt(s.rhoJ2 / s.EI2),
            length * np.sqrt(s.rhoJ3 / s.EI3),
        ]
        for GA, rhoJ in ((s.GA3, s.rhoJ2), (s.GA2, s.rhoJ3)):
            limits.append(2.0 / np.sqrt((GA / s.rhoA) * (4.0 / length**2 + s.rhoA / rhoJ)))
        return float(min(limits))
