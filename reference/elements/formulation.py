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
from reference.jit import kernel


@dataclass
class Element:
    """One element placed in the Domain: a formulation and its node ids."""

    formulation: "ElementFormulation"
    nodes: tuple
    label: str = ""


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
    ``J_i = (L0/2) diag(ρJ1, ρJ2, ρJ3)`` in the nodal (section) frame, constant
    because rotary motion is written in the body frame (paper §3.1).

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
def beam2_assemble(x, q, conn, L0, psi0, gamma0, stiff, S, s_el):
    """Add the internal forces of all Beam2 elements into ``S`` (N, 6); return ΣU.

    ``S`` is zeroed first; ``s_el`` (24,) is scratch (forces, strains,
    resultants).  Loops over the elements in compiled code and allocates nothing.
    """
    S[:, :] = 0.0
    U = 0.0
    for e in range(conn.shape[0]):
        i, j = conn[e, 0], conn[e, 1]
        U += generated_beam2.internal_forces(x[i], x[j], q[i], q[j], L0[e], psi0[e], gamma0[e], stiff[e],
                                             s_el[:12], s_el[12:18], s_el[18:])
        for k in range(6):
            S[i, k] += s_el[k]
            S[j, k] += s_el[6 + k]
    return U


@kernel
def beam2_resultants(x, q, conn, L0, psi0, gamma0, stiff, N, M, s_el):
    """Section resultants of all Beam2 elements at their midpoints, section frame.

    ``N`` (E, 3) the force resultant ``C_Γ (Γ − Γ0)`` [N] (component 1 the axial
    force, positive in tension; 2, 3 the shear forces) and ``M`` (E, 3) the moment
    ``C_K K`` [N m] (1 torsion, 2, 3 bending), in the midpoint section frame
    ``A_m`` of the generated kernel (``derivations/beam2.py``); ``s_el`` (24,) scratch.
    """
    for e in range(conn.shape[0]):
        i, j = conn[e, 0], conn[e, 1]
        generated_beam2.internal_forces(x[i], x[j], q[i], q[j], L0[e], psi0[e], gamma0[e], stiff[e],
                                        s_el[:12], s_el[12:18], s_el[18:])
        for k in range(3):
            N[e, k] = s_el[18 + k]
            M[e, k] = s_el[21 + k]
