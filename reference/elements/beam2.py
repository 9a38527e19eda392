"""The geometrically exact two-node beam (``Beam2_Formulation`` of the paper, §4.2.2, Fig. 4): element family ``"beam2"``.

The per-element arithmetic is the sympy-generated code of
``reference/generated/beam2.py`` (``derivations/beam2.py``) and its tangent
``reference/generated/tangents.py`` (``derivations/tangents.py``).  The element
works in its section frames ``p_a = q_a ⊗ o_a``
(:func:`~reference.elements.formulation.section_quaternion`); its rotational forces
and tangent go back to the node frames.  :func:`beam2_assemble` runs it over all
elements at once (compiled, allocation-free); from :data:`PARALLEL_ELEMENTS` elements on, the element loop runs the
structure-of-arrays form of the same generated arithmetic (``reference/generated/beam2_soa.py``,
``derivations/soa.py``: blocks of 64 elements, loops vectorised across the elements;
:mod:`reference.elements.beam2_blocks`) and gives every element's forces bit for bit as the per-element
kernel does.  The family's compiled calls
(:meth:`Beam2Formulation.assemble`, ``tangent_values``, ``resultants``) are what the
algorithms reach through :mod:`reference.elements.families`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.elements.element_type import Beam2, ElementType
from reference.elements.formulation import (
    ElementFormulation, PlacedElements, end_offsets, is_identity, section_quaternion, tangent_to_node_frames,
    to_node_frame, vector_norms,
)
from reference.elements.section import Section
from reference.generated import beam2 as generated_beam2
from reference.generated import rotation_maps as rm
from reference.generated import tangents as generated_tangents
from reference.jit import inlined, kernel, parallel_kernel, prange
from reference.newton_blocks import store_block
from reference.elements.beam2_blocks import add_element, soa_fixed_rows, soa_forces, soa_rows, straight_elements
from reference.parallel import (
    ELEMENT_CHUNK, PARALLEL_NODES, accumulate, element_chunks, energy_sum, node_incidence, scatter,
)

PARALLEL_ELEMENTS = 8
"""From this many elements on, the forces are computed by the structure-of-arrays element loop
(:mod:`reference.elements.beam2_blocks`; no per-view reference counts) instead of the per-element one:
the two loops' times cross between a few elements and a dozen (docs/benchmarks.md §10); both give the
same numbers.  Below :data:`reference.parallel.PARALLEL_NODES` nodes the blocks run on one
thread, their forces added into the nodes' sums as each block is done
(:func:`~reference.elements.beam2_blocks.soa_forces`); from there on the parallel loop over blocks."""


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
_section_quaternion = inlined(section_quaternion)
_to_node_frame = inlined(to_node_frame)


@inlined
def beam2_element(x, q, conn, offset, L0, psi0, gamma0, stiff, e, w):
    """Internal forces of Beam2 element e into ``w`` (40,), node frames; returns its strain energy.

    ``w[0:3]``, ``w[6:9]`` the forces on the two nodes (inertial), ``w[32:35]``,
    ``w[35:38]`` their moments in the node frames, ``w[39]`` the energy; the rest
    is the generated kernel's scratch (section-frame forces, strains,
    resultants) and the two section quaternions ``p_a = q_a ⊗ o_a``
    (:func:`section_quaternion`, ``offset`` (E,2,4); not composed where both
    offsets are the identity).  Inlined where it is called (:func:`reference.jit.inlined`).
    """
    i, j = conn[e, 0], conn[e, 1]
    o1, o2 = offset[e, 0], offset[e, 1]
    straight = is_identity(o1) and is_identity(o2)
    p1, p2 = q[i], q[j]  # section frames are the node frames (straight beams): same numbers
    if not straight:
        p1, p2 = w[24:28], w[28:32]
        _section_quaternion(q[i], o1, p1)
        _section_quaternion(q[j], o2, p2)
    # one call site: the generated kernel is inlined once
    w[39] = _internal_forces(x[i], x[j], p1, p2, L0[e], psi0[e], gamma0[e], stiff[e], w[:12], w[12:18], w[18:24])
    if straight:
        for k in range(3):
            w[32 + k] = w[3 + k]
            w[35 + k] = w[9 + k]
    else:
        _to_node_frame(o1, w[3:6], w[32:35])
        _to_node_frame(o2, w[9:12], w[35:38])
    return w[39]


@kernel
def beam2_assemble(x, q, conn, offset, L0, psi0, gamma0, stiff, S, s_el):
    """Add the internal forces of all Beam2 elements into ``S`` (N, 6); return ΣU.

    Each end's section triad is ``p_a = q_a ⊗ o_a`` (:func:`section_quaternion`,
    ``offset`` (E,2,4)); the generated kernel works in the section frames and its
    rotational forces are mapped back to the node frames (:func:`to_node_frame`).
    ``S`` is zeroed first; ``s_el`` (40,) is scratch (:func:`beam2_element`).
    Loops over the elements in compiled code and allocates nothing.
    """
    S[:, :] = 0.0
    U = 0.0
    W = s_el.reshape((1, 40))
    for e in range(conn.shape[0]):
        U += beam2_element(x, q, conn, offset, L0, psi0, gamma0, stiff, e, s_el)
        add_element(conn, e, W, 0, S)
    return U


@kernel
def _beam2_rows(x, q, conn, offset, L0, psi0, gamma0, stiff, W):
    """Every element's row of ``W`` (E, 40), one element after the other (:func:`beam2_element`): the
    element loop of a mesh too small for :func:`soa_rows`' blocks and threads.  A kernel of its own,
    so that the generated element code is compiled once, not again inside every algorithm's kernel."""
    for e in range(conn.shape[0]):
        beam2_element(x, q, conn, offset, L0, psi0, gamma0, stiff, e, W[e])


def beam2_assemble_parallel(x, q, conn, offset, L0, psi0, gamma0, stiff, S, W):
    """:func:`beam2_assemble` with the elements computed in parallel, bit for bit the same result
    (``S``, ΣU and every row's forces and energy; the strains and resultants of ``W[:, 12:24]`` are not
    written).

    The elements are independent: each writes its own row of ``W`` (E, 40)
    (:func:`beam2_element`) on the threads of :func:`reference.jit.use_threads`;
    then one thread adds the rows into ``S`` and ΣU in element order — the
    serial kernel's order, :func:`reference.parallel.scatter` — so the result does not
    depend on the thread count.  The algorithms' path (:meth:`Beam2Formulation.assemble`)
    computes the rows the same way: faster than the serial :func:`beam2_assemble`
    even on one thread, whose loop spends the difference on atomic reference-count
    updates of the element's array views (numba removes fewer of them there); the
    structure-of-arrays loop of :func:`soa_rows` is faster still (docs/benchmarks.md §5, §10).
    """
    return _assemble_parallel(x, q, conn, offset, straight_elements(offset), soa_fixed_rows(L0, psi0, gamma0, stiff),
                              S, W)


@kernel
def _assemble_parallel(x, q, conn, offset, straight, blocked, S, W):
    soa_rows(x, q, conn, offset, straight, blocked, W)
    S[:, :] = 0.0
    scatter(conn, W, 32, S)
    return energy_sum(W, 39)


@inlined
def _family_assemble(data, W, x, q, S):
    """:meth:`Beam2Formulation.assemble`: each element's forces into its row of ``W`` (the
    structure-of-arrays loop from :data:`PARALLEL_ELEMENTS` elements on, the same numbers either way), then
    added into ``S`` in element order (:func:`reference.parallel.accumulate`: a per-node gather on a
    large mesh, bit for bit the serial scatter); returns the strain energy (element order).  Below
    :data:`~reference.parallel.PARALLEL_NODES` nodes both in one serial pass (:func:`soa_forces`, the same
    bits; no parallel launch, and the forces go from the blocks' rows into ``S`` without ``W``)."""
    conn, offset, L0, psi0, gamma0, stiff = data.conn, data.offset, data.L0, data.psi0, data.gamma0, data.stiff
    if conn.shape[0] >= PARALLEL_ELEMENTS and S.shape[0] < PARALLEL_NODES:
        return soa_forces(x, q, conn, offset, data.straight, data.blocked, W, S)
    if conn.shape[0] >= PARALLEL_ELEMENTS:
        soa_rows(x, q, conn, offset, data.straight, data.blocked, W)
    else:
        _beam2_rows(x, q, conn, offset, L0, psi0, gamma0, stiff, W)
    accumulate(conn, data.node_start, data.node_item, W, 32, S)
    return energy_sum(W, 39)


@inlined
def _tangent_range(data, W, x, q, psi, ck, values, p0, Jr, K144, lo, hi):
    """The 12×12 tangents times ``ck`` of the elements ``lo … hi − 1``, element e's into ``values`` from
    ``p0 + 144 e`` on (``Jr`` (9,), ``K144`` scratch)."""
    conn, offset, L0, psi0, gamma0, stiff = data.conn, data.offset, data.L0, data.psi0, data.gamma0, data.stiff
    K12 = K144.reshape((12, 12))
    for e in range(lo, hi):
        i, j = conn[e, 0], conn[e, 1]
        s_el = W[e]
        if ck != 0.0 and is_identity(offset[e, 0]) and is_identity(offset[e, 1]):
            # section frames are the node frames (straight beams): p_a = q_a and T = I exactly
            generated_tangents.beam2_tangent(x[i], x[j], q[i], q[j], L0[e], psi0[e], gamma0[e], stiff[e],
                                             s_el[:12], K144)
        elif ck != 0.0:
            p1, p2 = s_el[24:28], s_el[28:32]
            section_quaternion(q[i], offset[e, 0], p1)
            section_quaternion(q[j], offset[e, 1], p2)
            generated_tangents.beam2_tangent(x[i], x[j], p1, p2, L0[e], psi0[e], gamma0[e], stiff[e], s_el[:12],
                                             K144)
            tangent_to_node_frames(offset[e], K12, s_el[32:35], s_el[35:38])
        else:
            K12[:, :] = 0.0
        store_block(K12, conn[e], 2, psi, Jr, ck, values, p0 + 144 * e)


@parallel_kernel
def _tangent_parallel(data, W, x, q, psi, ck, values, p):
    E = data.conn.shape[0]
    for k in prange(element_chunks(E)):
        Jr, K144 = np.empty(9), np.empty(144)
        _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K144, k * ELEMENT_CHUNK, min(E, (k + 1) * ELEMENT_CHUNK))


@inlined
def _family_tangent_values(data, W, x, q, psi, ck, values, p, Jr, K):
    """:meth:`Beam2Formulation.tangent_values`: each element's 12×12 tangent (material + geometric,
    the generated ``beam2_tangent``, section frames taken back to the node frames) times ``ck``;
    from :data:`PARALLEL_ELEMENTS` elements on a parallel loop, each element writing its own slice."""
    E = data.conn.shape[0]
    if E >= PARALLEL_ELEMENTS:
        _tangent_parallel(data, W, x, q, psi, ck, values, p)
        return p + 144 * E
    _tangent_range(data, W, x, q, psi, ck, values, p, Jr, K[:144], 0, E)
    return p + 144 * E


@inlined
def _family_resultants(data, W, x, q, N, M):
    """:meth:`Beam2Formulation.resultants`: the section resultants at every element's midpoint, section
    frame, into the rows ``data.index`` of ``N``, ``M`` (E, 3).

    ``N`` the force resultant ``C_Γ (Γ − Γ0)`` [N] (component 1 the axial force, positive in
    tension; 2, 3 the shear forces) and ``M`` the moment ``C_K K`` [N m] (1 torsion, 2, 3
    bending), in the midpoint section frame ``A_m`` of the generated kernel
    (``derivations/beam2.py``), evaluated with the ends' section triads ``p_a = q_a ⊗ o_a``.
    """
    conn, offset, L0, psi0, gamma0, stiff = data.conn, data.offset, data.L0, data.psi0, data.gamma0, data.stiff
    for e in range(conn.shape[0]):
        s_el = W[e]
        p1, p2 = s_el[24:28], s_el[28:32]
        i, j = conn[e, 0], conn[e, 1]
        section_quaternion(q[i], offset[e, 0], p1)
        section_quaternion(q[j], offset[e, 1], p2)
        generated_beam2.internal_forces(x[i], x[j], p1, p2, L0[e], psi0[e], gamma0[e], stiff[e],
                                        s_el[:12], s_el[12:18], s_el[18:24])
        r = data.index[e]
        for k in range(3):
            N[r, k] = s_el[18 + k]
            M[r, k] = s_el[21 + k]
    return 0.0


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


class Beam2Formulation(ElementFormulation):
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
    assemble = staticmethod(_family_assemble)
    tangent_values = staticmethod(_family_tangent_values)
    resultants = staticmethod(_family_resultants)

    def __init__(self, section: Section, element_type: ElementType | None = None):
        self.section = section
        self.element_type = element_type or Beam2()
        self._shape_integrals = None

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

    @staticmethod
    def characteristic_energy(data: Beam2Data) -> float:
        """The strain energy of a unit strain and curvature in every element [J],
        ``½ Σ ((EA + GA₂ + GA₃) L0 + (GJ + EI₂ + EI₃)/L0)`` (:func:`reference.monitor.energy_floor`)."""
        L, stiff = data.L0, data.stiff
        return 0.5 * float(np.sum(stiff[:, :3].sum(axis=1) * L + stiff[:, 3:].sum(axis=1) / L))

    @staticmethod
    def work(data: Beam2Data) -> np.ndarray:
        """One row of 40 per element (:func:`beam2_element`)."""
        return np.zeros((data.conn.shape[0], 40))

    def lumped_mass(self, x_nodes):
        """Row-sum lumping ``m_i = ∫ N_i ρA ds`` and ``J_i`` likewise, one element (:meth:`lumped_masses`)."""
        mass, inertia = self.lumped_masses(np.asarray(x_nodes, dtype=float)[None])
        return [(mass[0, a], inertia[0, a]) for a in range(mass.shape[1])]

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
    def rest_states(x, p, stiff):
        """``L0`` (E,) [m], ``ψ0 = log(p1* ⊗ p2)`` and ``Γ0`` (E, 3) of E elements at rest, node positions
        ``x`` (E, 2, 3), section triads ``p`` (E, 2, 4), stiffnesses ``stiff`` (E, 6): ``Γ0 = Amᵀ x'``
        is the generated kernel's Γ evaluated with the reference itself and Γ0 = 0 (:func:`_rest_strains`)."""
        x, p = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(p, dtype=float)
        L0 = vector_norms(x[:, 1] - x[:, 0])
        if (L0 <= 0.0).any():
            raise ValueError("Beam2 element of zero length")
        psi0, gamma0 = np.empty((len(L0), 3)), np.empty((len(L0), 3))
        _rest_strains(x, p, L0, end_offsets(p[:, 0], p[:, 1]), np.ascontiguousarray(stiff, dtype=float), psi0, gamma0)
        return L0, psi0, gamma0

    def _evaluate(self, x_nodes, q_nodes, reference):
        s, strain, stress = np.empty(12), np.empty(6), np.empty(6)
        U = generated_beam2.internal_forces(
            x_nodes[0], x_nodes[1], q_nodes[0], q_nodes[1], reference["L0"], reference["psi0"],
            reference["gamma0"], self.section.stiffness, s, strain, stress,
        )
        return s, U, strain, stress

    def internal_forces(self, x_nodes, q_nodes, reference):
        s, U, _, _ = self._evaluate(x_nodes, q_nodes, reference)
        return s, U

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
