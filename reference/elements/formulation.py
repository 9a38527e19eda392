"""Element formulations (the paper's ``Element_Formulation``, §4.2.2, Fig. 4).

A formulation turns nodal coordinates into element arrays: lumped mass and
rotary inertia, internal forces ``S`` of eq. (3), strain energy.  It holds an
:class:`~reference.elements.element_type.ElementType` for its kinematics, as
the paper's ``Beam2_Formulation`` holds a pointer to ``Beam2``.

The per-element arithmetic is the sympy-generated code of
``reference/generated/beam2.py``; :func:`beam2_assemble` runs it over all
elements of the kind at once (compiled, allocation-free), which is what the
time-stepping kernel calls every step.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from reference.elements.element_type import Beam2, ElementType
from reference.elements.section import Section
from reference.generated import beam2 as generated_beam2
from reference.generated import rotation_maps as rm
from reference.jit import inlined, kernel, parallel_kernel, prange


@dataclass
class Element:
    """One element placed in the Domain: a formulation, its node ids and section frames.

    ``frames`` (n_nodes, 4): Euler parameters of the element's own section
    triad at each end in the initial configuration (for a Beam2 both equal
    its straight triad); ``None``: the node frames are the section frames.
    The constant offsets ``o_a = q_a⁰* ⊗ p_a⁰`` follow from them
    (:class:`reference.state.Model`).
    """

    formulation: "ElementFormulation"
    nodes: tuple
    label: str = ""
    frames: object = None


class ElementFormulation(ABC):
    """Abstract element formulation.

    Subclasses provide:

    - ``lumped_mass(x_nodes)`` → list of ``(mass, inertia 3×3 body frame)`` per node;
    - ``internal_forces(x, q, reference)`` → ``(S (n_nodes·6,), U)`` for one element;
    - ``reference_state(x, q)`` → what the unstrained configuration needs;
    - ``critical_time_step(length)`` → stability limit of the explicit scheme [s].
    """

    element_type: ElementType

    @abstractmethod
    def lumped_mass(self, x_nodes: np.ndarray) -> list: ...

    @abstractmethod
    def reference_state(self, x_nodes: np.ndarray, q_nodes: np.ndarray) -> dict: ...

    @abstractmethod
    def internal_forces(self, x_nodes, q_nodes, reference) -> tuple[np.ndarray, float]: ...

    @abstractmethod
    def critical_time_step(self, length: float) -> float: ...


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

    def __init__(self, section: Section, element_type: ElementType | None = None):
        self.section = section
        self.element_type = element_type or Beam2()

    def lumped_mass(self, x_nodes):
        length = float(np.linalg.norm(x_nodes[1] - x_nodes[0]))
        xi, w = self.element_type.mass_points()
        out = []
        for i in range(self.element_type.n_nodes):
            share = sum(wk * self.element_type.shape_functions(xk)[i] for xk, wk in zip(xi, w)) * length / 2
            out.append((self.section.rhoA * share, np.diag(self.section.rotary_inertia * share)))
        return out

    def reference_state(self, x_nodes, q_nodes):
        """Reference length ``L0``, relative rotation ``ψ0`` and ``Γ0 = Amᵀ x'``.

        With these the element is unstrained in its initial configuration
        (a curved or kinked reference is allowed).
        """
        length = float(np.linalg.norm(x_nodes[1] - x_nodes[0]))
        if length <= 0.0:
            raise ValueError("Beam2 element of zero length")
        r = np.empty(4)
        rm.quat_product(q_nodes[0] * np.array([1, -1, -1, -1]), q_nodes[1], r)
        psi0 = np.empty(3)
        rm.log_quaternion(r, psi0)
        # Γ0 = Am^T x' with the reference itself: evaluate with Γ0 = 0 and read Γ.
        _, _, strain, _ = self._evaluate(x_nodes, q_nodes, {"L0": length, "psi0": psi0, "gamma0": np.zeros(3)})
        return {"L0": length, "psi0": psi0, "gamma0": strain[:3].copy()}

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

    def section_resultants(self, x_nodes, q_nodes, reference):
        """Strains ``(Γ, K)`` and resultants ``(N, M)`` at the midpoint, section frame."""
        _, _, strain, stress = self._evaluate(x_nodes, q_nodes, reference)
        return strain, stress

    def critical_time_step(self, length):
        """Stability limit of central differences for one lumped element [s].

        The minimum of the axial ``L0 √(ρA/EA)``, torsional ``L0 √(ρJ1/GJ)``,
        bending–rotation ``L0 √(ρJ/EI)`` limits and the coupled shear–rotation
        mode ``2/√((GA/ρA)(4/L0² + ρA/ρJ))`` (docs/formulation.md §3; each matched the
        eigenvalue limit within 0.5 %, the last is ~9 % conservative).
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


@kernel
def section_quaternion(q_node, o, out):
    """Section triad of an element end: ``p = q ⊗ o``, i.e. ``Λ = A(q) A(o)``.

    ``q_node`` (4,) the node's Euler parameters, ``o`` (4,) the end's constant
    offset (node frame → the element's section frame, see
    :class:`reference.state.Model`), ``out`` (4,).
    """
    rm.quat_product(q_node, o, out)


@kernel
def to_node_frame(o, v, out):
    """Body-frame moment of an element end from its section frame to the node frame: ``A(o) v``.

    A body-frame rotation perturbation of the node, ``δθ_node``, is
    ``δθ_section = A(o)ᵀ δθ_node`` in the section frame, so the virtual work
    ``S_secᵀ δθ_section`` gives ``S_node = A(o) S_sec`` (``out`` may not be ``v``).
    """
    e0, e1, e2, e3 = o[0], o[1], o[2], o[3]
    a = 2.0 * e0 * e0 - 1.0
    d = 2.0 * (e1 * v[0] + e2 * v[1] + e3 * v[2])
    out[0] = a * v[0] + d * e1 + 2.0 * e0 * (e2 * v[2] - e3 * v[1])
    out[1] = a * v[1] + d * e2 + 2.0 * e0 * (e3 * v[0] - e1 * v[2])
    out[2] = a * v[2] + d * e3 + 2.0 * e0 * (e1 * v[1] - e2 * v[0])


@kernel
def tangent_to_node_frame(o1, o2, K, v, out):
    """A section-frame element tangent (12×12) to the node frames, in place: ``K ← T K Tᵀ``.

    ``T = blockdiag(I, A(o1), I, A(o2))``: ``S_node = T s_sec`` and
    ``δθ_section = A(o_a)ᵀ δθ_node`` exactly, so ``∂S_node/∂δ_node = T K_sec Tᵀ``.
    ``v``, ``out`` (3,) scratch.
    """
    for pass_ in range(2):
        for c in range(12):
            for blk in range(2):
                o = o1 if blk == 0 else o2
                r0 = 3 + 6 * blk
                for k in range(3):
                    v[k] = K[r0 + k, c] if pass_ == 0 else K[c, r0 + k]
                to_node_frame(o, v, out)
                for k in range(3):
                    if pass_ == 0:
                        K[r0 + k, c] = out[k]
                    else:
                        K[c, r0 + k] = out[k]


@inlined
def is_identity(o):
    """True for the identity offset (1, 0, 0, 0), with which ``q ⊗ o = q`` and ``A(o) v = v`` exactly."""
    return o[0] == 1.0 and o[1] == 0.0 and o[2] == 0.0 and o[3] == 0.0


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
    if is_identity(o1) and is_identity(o2):  # section frames are the node frames (straight beams): same numbers
        w[39] = _internal_forces(x[i], x[j], q[i], q[j], L0[e], psi0[e], gamma0[e], stiff[e],
                                 w[:12], w[12:18], w[18:24])
        for k in range(3):
            w[32 + k] = w[3 + k]
            w[35 + k] = w[9 + k]
        return w[39]
    _section_quaternion(q[i], o1, w[24:28])
    _section_quaternion(q[j], o2, w[28:32])
    w[39] = _internal_forces(x[i], x[j], w[24:28], w[28:32], L0[e], psi0[e], gamma0[e], stiff[e],
                             w[:12], w[12:18], w[18:24])
    _to_node_frame(o1, w[3:6], w[32:35])
    _to_node_frame(o2, w[9:12], w[35:38])
    return w[39]


@inlined
def _add_element(conn, e, W, r, S):
    """Add the node-frame forces of element e (row r of ``W``, see :func:`beam2_element`) into ``S``."""
    i, j = conn[e, 0], conn[e, 1]
    for k in range(3):
        S[i, k] += W[r, k]
        S[i, 3 + k] += W[r, 32 + k]
    for k in range(3):
        S[j, k] += W[r, 6 + k]
        S[j, 3 + k] += W[r, 35 + k]



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
        _add_element(conn, e, W, 0, S)
    return U


@parallel_kernel
def _beam2_elements(x, q, conn, offset, L0, psi0, gamma0, stiff, W):
    for e in prange(conn.shape[0]):
        beam2_element(x, q, conn, offset, L0, psi0, gamma0, stiff, e, W[e])


@kernel
def beam2_assemble_parallel(x, q, conn, offset, L0, psi0, gamma0, stiff, S, W):
    """:func:`beam2_assemble` with the elements computed in parallel, bit for bit the same result.

    The elements are independent: each writes its own row of ``W`` (E, 40)
    (:func:`beam2_element`) on the threads of :func:`reference.jit.use_threads`;
    then one thread adds the rows into ``S`` and ΣU in element order — the
    serial kernel's order — so the result does not depend on the thread count.
    This is the algorithms' path also on one thread: measured at 768 elements,
    0.08 µs per element against 0.21 µs for the serial :func:`beam2_assemble`,
    whose loop spends the difference on atomic reference-count updates of the
    element's array views (``perf``; numba removes fewer of them there).
    """
    _beam2_elements(x, q, conn, offset, L0, psi0, gamma0, stiff, W)
    S[:, :] = 0.0
    U = 0.0
    for e in range(conn.shape[0]):
        U += W[e, 39]
        _add_element(conn, e, W, e, S)
    return U


@kernel
def beam2_resultants(x, q, conn, offset, L0, psi0, gamma0, stiff, N, M, s_el):
    """Section resultants of all Beam2 elements at their midpoints, section frame.

    ``N`` (E, 3) the force resultant ``C_Γ (Γ − Γ0)`` [N] (component 1 the axial
    force, positive in tension; 2, 3 the shear forces) and ``M`` (E, 3) the moment
    ``C_K K`` [N m] (1 torsion, 2, 3 bending), in the midpoint section frame
    ``A_m`` of the generated kernel (``derivations/beam2.py``), evaluated with the
    ends' section triads ``p_a = q_a ⊗ o_a`` (``offset`` (E,2,4)); ``s_el`` (32,) scratch.
    """
    p1, p2 = s_el[24:28], s_el[28:32]
    for e in range(conn.shape[0]):
        i, j = conn[e, 0], conn[e, 1]
        section_quaternion(q[i], offset[e, 0], p1)
        section_quaternion(q[j], offset[e, 1], p2)
        generated_beam2.internal_forces(x[i], x[j], p1, p2, L0[e], psi0[e], gamma0[e], stiff[e],
                                        s_el[:12], s_el[12:18], s_el[18:24])
        for k in range(3):
            N[e, k] = s_el[18 + k]
            M[e, k] = s_el[21 + k]
