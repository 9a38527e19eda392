"""The elements placed at t = 0 and their lumped masses, all the elements of a family at once (paper §4.3:
``Initialization``).

:meth:`reference.domain.Domain.initialization` places every element on its nodes' initial positions and
Euler parameters (:func:`place`: the section triads at rest and the end offsets ``o_a = q_a⁰* ⊗ p_a⁰``,
:class:`reference.state.Model`) and adds the elements' lumped masses and rotary inertias to the nodes
(:func:`add_lumped_masses`); each family's ``pack`` then takes its :class:`PlacedElements`.  The numbers are
those of the element-by-element loop these functions replace, bit for bit: the same generated arithmetic,
norms and matrix products per element, the sums into the nodes in element order.
"""

from __future__ import annotations

import numpy as np

from reference.elements.formulation import PlacedElements, end_offsets, rotation_matrices


def place(elements: list, x: np.ndarray, q: np.ndarray) -> dict:
    """Each family's elements (in the order of ``elements``) placed at t = 0, by family name
    (:class:`PlacedElements`), from the nodes' positions ``x`` (N, 3) [m] and Euler parameters ``q`` (N, 4);
    an element's section triads are its ``frames``, or its nodes' frames without them."""
    by_family: dict[str, list] = {}
    for e, element in enumerate(elements):
        by_family.setdefault(element.formulation.family, []).append(e)
    placed = {}
    for family, numbers in by_family.items():
        members = [elements[e] for e in numbers]
        conn = np.array([element.nodes for element in members], dtype=np.int64).reshape(len(numbers), -1)
        p = q[conn]
        for k, element in enumerate(members):
            if element.frames is not None:
                p[k] = element.frames
        placed[family] = PlacedElements(np.array(numbers, dtype=np.int64), members, conn, x[conn], p,
                                         end_offsets(q[conn], p))
    return placed


def no_elements(family) -> PlacedElements:
    """No element of ``family`` (a family the engine packs even when the model has none)."""
    n = family.n_nodes
    return PlacedElements(np.zeros(0, dtype=np.int64), [], np.zeros((0, n), dtype=np.int64), np.zeros((0, n, 3)),
                          np.zeros((0, n, 4)), np.zeros((0, n, 4)))


def lumped_family(placed: PlacedElements) -> tuple[np.ndarray, np.ndarray]:
    """The lumped masses (E, n) [kg] and rotary inertias (E, n, 3, 3) [kg m²], node frames, of one family's
    placed elements: each formulation's
    :meth:`~reference.elements.formulation.ElementFormulation.lumped_masses` for its elements, the
    section-frame inertias rotated into the node frames, ``O J Oᵀ`` (``O`` the end offset's matrix), where the
    offset is not the identity (there ``O J Oᵀ`` is J, bit for bit)."""
    x, offset = placed.x, placed.offset
    mass, inertia = np.empty(x.shape[:2]), np.empty(x.shape[:2] + (3, 3))
    for formulation, members in placed.groups():
        mass[members], inertia[members] = formulation.lumped_masses(x[members])
    turned = ~((offset[..., 0] == 1.0) & ~offset[..., 1:].any(axis=-1))
    if turned.any():
        O = rotation_matrices(offset[turned])
        inertia[turned] = O @ inertia[turned] @ O.transpose(0, 2, 1)
    return mass, inertia


def add_lumped_masses(mass: np.ndarray, inertia: np.ndarray, placed: dict) -> None:
    """Add the lumped masses and rotary inertias (node frames, :func:`lumped_family`) of the placed elements of
    every family into the nodes' ``mass`` (N,) and ``inertia`` (N, 3, 3), in place: element after element in
    the Domain's order, each element's ends in order (the sums round as the element loop's)."""
    ends = []
    for item in placed.values():
        m, J = lumped_family(item)
        n = item.x.shape[1]
        ends.append((np.repeat(item.index, n), item.conn.ravel(), m.ravel(), J.reshape(-1, 3, 3)))
    if ends:
        number, node, m, J = (np.concatenate(column) for column in zip(*ends))
        order = np.argsort(number, kind="stable")
        np.add.at(mass, node[order], m[order])
        np.add.at(inertia, node[order], J[order])
