"""Element formulations (the paper's ``Element_Formulation``, §4.2.2, Fig. 4): the abstract base.

A formulation turns nodal coordinates into element arrays: lumped mass and
rotary inertia, internal forces ``S`` of eq. (3), strain energy.  It holds an
:class:`~reference.elements.element_type.ElementType` for its kinematics, as
the paper's ``Beam2_Formulation`` holds a pointer to ``Beam2``.  Each concrete
formulation is an element family of the engine (what it provides:
:class:`ElementFormulation`; the registry: :mod:`reference.elements.families`);
the first is :class:`reference.elements.beam2.Beam2Formulation`.

Beside the base, the section-frame offsets every family with section frames uses:
an element end's section triad ``p_a = q_a ⊗ o_a`` (:func:`section_quaternion`),
and body-frame moments and tangents from the section frames back to the nodes'
(:func:`to_node_frame`, :func:`tangent_to_node_frames`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from reference.elements.element_type import ElementType
from reference.generated import rotation_maps as rm
from reference.jit import inlined, kernel


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


class PlacedElement(NamedTuple):
    """One element as its family packs it: its number in the Domain, the element, and at t = 0 the
    positions ``x`` (n, 3) of its nodes, its section triads ``p`` (n, 4) and the constant offsets
    ``offset`` (n, 4) from each node's frame to the section frame (``p_a = q_a ⊗ o_a``)."""

    index: int
    element: "Element"
    x: np.ndarray
    p: np.ndarray
    offset: np.ndarray


class PlacedElements(Sequence):
    """The elements of one family placed at t = 0, as arrays over the family's E elements (Domain order):
    ``index`` (E,) their numbers in the Domain, ``elements`` the :class:`Element` objects, ``x`` (E, n, 3)
    node positions, ``p`` (E, n, 4) section triads, ``offset`` (E, n, 4) the end offsets.  A family's
    ``pack`` may take the arrays at once or iterate: item e is element e's :class:`PlacedElement`; ``conn``
    (E, n) the elements' node numbers."""

    def __init__(self, index, elements, conn, x, p, offset):
        self.index, self.elements, self.conn, self.x, self.p, self.offset = index, elements, conn, x, p, offset

    def __len__(self) -> int:
        return len(self.elements)

    def __getitem__(self, e):
        if isinstance(e, slice):
            return [self[k] for k in range(len(self))[e]]
        return PlacedElement(int(self.index[e]), self.elements[e], self.x[e], self.p[e], self.offset[e])

    def groups(self) -> list:
        """``[(formulation, element numbers (k,))]``: the family's elements by formulation
        (:func:`formulation_groups`), computed once."""
        if not hasattr(self, "_groups"):
            self._groups = formulation_groups(self.elements)
        return self._groups

    def sections(self, attribute: str, k: int) -> np.ndarray:
        """(E, k) a section property array (``"stiffness"``, k = 6; ``"rotary_inertia"``, k = 3) of every
        element, read once per formulation."""
        out = np.empty((len(self), k))
        for formulation, members in self.groups():
            out[members] = getattr(formulation.section, attribute)
        return out


def formulation_groups(elements: list) -> list:
    """``[(formulation, numbers)]``: the positions (k,) in ``elements`` of the elements of each formulation
    (an object shared by the elements of a beam), in increasing order; the formulations in the order of their
    first element."""
    formulations = [element.formulation for element in elements]
    ids = np.fromiter(map(id, formulations), dtype=np.int64, count=len(formulations))
    _, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    members = np.split(order, np.cumsum(np.bincount(inverse, minlength=len(first)))[:-1])
    return [(formulations[first[g]], members[g]) for g in np.argsort(first)]


class ElementFormulation(ABC):
    """Abstract element formulation; each subclass is an element *family* of the engine.

    Per element (Python, used at assembly and by tests and lessons):

    - ``lumped_mass(x_nodes)`` → list of ``(mass, inertia 3×3 section frame)`` per node;
    - ``lumped_masses(x)`` → the same of E elements at once, arrays (by default element by element);
    - ``internal_forces(x, q, reference)`` → ``(S (n_nodes·6,), U)`` for one element;
    - ``reference_state(x, q)`` → what the unstrained configuration needs;
    - ``critical_time_step(length)`` → stability limit of the explicit scheme [s];
    - ``rest_frames``, ``mesh_nodes`` → how :meth:`reference.domain.Domain.add_beam` meshes a beam of
      the family (defaults: chord frames; ``n_nodes − 1`` segments per element, nodes in beam order).

    Per family (class attributes; the registry is :mod:`reference.elements.families`):

    - ``family``: the deck name; ``n_nodes``; ``Data``: the NamedTuple of the family's plain
      data in :attr:`reference.state.Model.elements`, whose first fields are ``conn`` (E, n)
      node numbers, ``index`` (E,) the elements' numbers in the Domain and ``offset`` (E, n, 4) the
      ends' offsets, with ``node_start``, ``node_item`` the node incidence
      (:func:`reference.parallel.node_incidence`);
    - ``pack(placed)`` → ``Data`` from the family's :class:`PlacedElements` (arrays over its elements, or
      one :class:`PlacedElement` after the other);
    - ``characteristic_energy(data)`` → the strain energy of a unit strain (and curvature) in every
      element [J], the scale of the energy guard's round-off floor (:func:`reference.monitor.energy_floor`);
    - its physics, per element and compiled (numba, inlined), in the element's section frames:
      ``element_forces(data, e, X, P, w) → U``, ``element_tangent(data, e, X, P, w, K)``,
      ``element_resultants(w, N, M)`` and ``ROW``, its work row as named slices
      (:mod:`reference.elements.driver`, which executes them: gathering, frames, loops, sums,
      tangent blocks).  A family may give its own ``assemble``, ``tangent_values``, ``resultants``
      or ``work`` (Beam2 gives its vectorised ``assemble``); those it does not give are the driver's.
    """

    assemble = None
    tangent_values = None
    resultants = None
    work = None
    element_type: ElementType
    family: str
    n_nodes: int
    Data: type

    @staticmethod
    def rest_frames(node_frames: list, chord_frames: list, i: int) -> tuple:
        """The section triads at rest (Euler parameters) of the nodes of element i of a meshed beam
        (:meth:`reference.domain.Domain.add_beam`), given the beam's triads at its mesh points and on
        the chords between them: by default the chord's at both ends (an element straight in its own
        section frame)."""
        return chord_frames[i], chord_frames[i]

    @classmethod
    def mesh_nodes(cls, nodes: list, i: int) -> tuple:
        """The nodes of element i of a beam meshed with ``n_nodes − 1`` segments per element, from the
        beam's nodes in order along it, in the element's order (default: as along the beam)."""
        k = (cls.n_nodes - 1) * i
        return tuple(nodes[k:k + cls.n_nodes])

    curve_segments: int = 1
    """Segments per element of the centre line the ParaView output draws (:meth:`curve`)."""
    node_xi: tuple = (0.0, 1.0)
    """Each node's parameter ξ on the centre line (0 at the first end, 1 at the second), element order."""

    def curve(self, x_nodes: np.ndarray, p_nodes: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """Centre-line points (k, 3) [m] at the parameters ``xi`` (k,) ∈ [0, 1] from the element's own
        interpolation, given its nodes' positions ``x_nodes`` (n, 3) and section triads ``p_nodes`` (n, 4)
        (Euler parameters).  Default: the straight chord between the two ends (Beam2's linear
        interpolation, docs/formulation.md §3)."""
        x = np.asarray(x_nodes, dtype=float)
        xi = np.asarray(xi, dtype=float)[:, None]
        return (1.0 - xi) * x[0] + xi * x[1]

    @abstractmethod
    def lumped_mass(self, x_nodes: np.ndarray) -> list: ...

    def lumped_masses(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The lumped masses (E, n) [kg] and rotary inertias (E, n, 3, 3) [kg m²], section frames, of E
        elements of this formulation with node positions ``x`` (E, n, 3): by default :meth:`lumped_mass`
        element by element (a family may compute them at once, with the same numbers)."""
        E, n = x.shape[0], x.shape[1]
        mass, inertia = np.zeros((E, n)), np.zeros((E, n, 3, 3))
        for e in range(E):
            for a, (m, J) in enumerate(self.lumped_mass(x[e])):
                mass[e, a], inertia[e, a] = m, J
        return mass, inertia

    @abstractmethod
    def reference_state(self, x_nodes: np.ndarray, q_nodes: np.ndarray) -> dict: ...

    @abstractmethod
    def internal_forces(self, x_nodes, q_nodes, reference) -> tuple[np.ndarray, float]: ...

    @abstractmethod
    def critical_time_step(self, length: float) -> float: ...


class BeamFormulation(ElementFormulation):
    """What every beam family shares: a :class:`~reference.elements.section.Section`, the element type
    (interpolation) its formulation is derived with (``default_type`` unless given), the energy scale and
    the per-element Python calls built on the family's ``_evaluate(x, q, reference) → (S, U, strain,
    stress)`` and ``lumped_masses``."""

    default_type: type = ElementType

    def __init__(self, section, element_type: ElementType | None = None):
        self.section = section
        self.element_type = element_type or self.default_type()
        self._shape_integrals = None

    @staticmethod
    def characteristic_energy(data) -> float:
        """The strain energy of a unit strain and curvature in every element [J],
        ``½ Σ ((EA + GA₂ + GA₃) L0 + (GJ + EI₂ + EI₃)/L0)`` (:func:`reference.monitor.energy_floor`)."""
        L, stiff = data.L0, data.stiff
        return 0.5 * float(np.sum(stiff[:, :3].sum(axis=1) * L + stiff[:, 3:].sum(axis=1) / L))

    def lumped_mass(self, x_nodes):
        """The lumped masses and rotary inertias (section frame) of one element (:meth:`lumped_masses`)."""
        mass, inertia = self.lumped_masses(np.asarray(x_nodes, dtype=float)[None])
        return [(mass[0, a], inertia[0, a]) for a in range(mass.shape[1])]

    def internal_forces(self, x_nodes, q_nodes, reference):
        s, U, _, _ = self._evaluate(x_nodes, q_nodes, reference)
        return s, U


@kernel
def section_quaternion(q_node, o, out):
    """Section triad of an element end: ``p = q ⊗ o``, i.e. ``Λ = A(q) A(o)``.

    ``q_node`` (4,) the node's Euler parameters, ``o`` (4,) the end's constant
    offset (node frame → the element's section frame, see
    :class:`reference.state.Model`), ``out`` (4,).
    """
    rm.quat_product(q_node, o, out)


def end_offsets(q_nodes, p_nodes) -> np.ndarray:
    """The constant offsets ``o_a = q_a⁰* ⊗ p_a⁰`` (…, 4) of element ends from their nodes' Euler
    parameters ``q_nodes`` and section triads ``p_nodes`` (…, 4) at rest (:class:`reference.state.Model`):
    the generated ``quat_product`` on the arrays of each component at once (the same arithmetic,
    the same numbers as the compiled kernel one end at a time)."""
    q = np.asarray(q_nodes, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])
    p = np.asarray(p_nodes, dtype=float)
    out = np.empty(np.broadcast_shapes(q.shape, p.shape))
    _quat_product(np.moveaxis(q, -1, 0), np.moveaxis(p, -1, 0), np.moveaxis(out, -1, 0))
    return out


def vector_norms(v) -> np.ndarray:
    """Euclidean norms (…,) of the vectors ``v`` (…, k): ``np.linalg.norm`` of each, bit for bit (the same
    BLAS dot product per vector, through a stacked ``matmul``; a sum of squares may round differently)."""
    v = np.asarray(v, dtype=float)
    return np.sqrt(np.matmul(v[..., None, :], v[..., :, None])[..., 0, 0])


def rotation_matrices(q) -> np.ndarray:
    """``EulerParameters(q).matrix()`` (…, 3, 3) of Euler parameters ``q`` (…, 4), normalised first, bit for
    bit (the generated ``rotation_matrix`` on the arrays of each component at once)."""
    q = np.asarray(q, dtype=float)
    q = q / vector_norms(q)[..., None]
    out = np.empty(q.shape[:-1] + (9,))
    _rotation_matrix(np.moveaxis(q, -1, 0), np.moveaxis(out, -1, 0))
    return out.reshape(q.shape[:-1] + (3, 3))


_quat_product = getattr(rm.quat_product, "py_func", rm.quat_product)
_rotation_matrix = getattr(rm.rotation_matrix, "py_func", rm.rotation_matrix)


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
def tangent_to_node_frames(offsets, K, v, out):
    """A section-frame element tangent (6n×6n, n ends) to the node frames, in place: ``K ← T K Tᵀ``.

    ``T = blockdiag(I, A(o_1), …, I, A(o_n))`` with ``o_a = offsets[a]`` ((n, 4): the element's end
    offsets): ``S_node = T s_sec`` and ``δθ_section = A(o_a)ᵀ δθ_node`` exactly, so
    ``∂S_node/∂δ_node = T K_sec Tᵀ``.  ``v``, ``out`` (3,) scratch.
    """
    ends = offsets.shape[0]
    for pass_ in range(2):
        for c in range(6 * ends):
            for blk in range(ends):
                r0 = 3 + 6 * blk
                for k in range(3):
                    v[k] = K[r0 + k, c] if pass_ == 0 else K[c, r0 + k]
                to_node_frame(offsets[blk], v, out)
                for k in range(3):
                    if pass_ == 0:
                        K[r0 + k, c] = out[k]
                    else:
                        K[c, r0 + k] = out[k]


@inlined
def is_identity(o):
    """True for the identity offset (1, 0, 0, 0), with which ``q ⊗ o = q`` and ``A(o) v = v`` exactly."""
    return o[0] == 1.0 and o[1] == 0.0 and o[2] == 0.0 and o[3] == 0.0
