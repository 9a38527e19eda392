"""The element families the engine knows, and the compiled calls that reach every family of a model.

A *family* is an :class:`~reference.elements.formulation.ElementFormulation`
subclass registered here by its deck name (``[[beams]] element = "beam2"``): the
paper's promise (§2, §4.2.2, Fig. 4) that a new element is a new class.  The
Domain packs the elements of each family present in a model (and of the engine's own
families, :data:`ALWAYS_PACKED`, present or not) into that family's plain data
(``family.pack``), and :class:`reference.state.Model` carries them as the tuple
``Model.elements``, one entry per family, in registry order.

The algorithms never name a family.  They call the three functions below,
:func:`assemble_forces`, :func:`tangent_values` and :func:`resultants`: in Python a loop over
the model's tuple of family data; compiled, the same loop unrolled at compile time for the
tuple's type (numba ``overload``: the first family's call, then the rest of the tuple), a
straight sequence of calls of each family's own functions with no run-time dispatch.

What a family provides is listed in
:class:`~reference.elements.formulation.ElementFormulation`; a family that gives per-element
functions only is executed by the generic driver (:mod:`reference.elements.driver`).
"""

from __future__ import annotations

import numpy as np
from numba.extending import overload

from reference.elements.beam2 import Beam2Formulation
from reference.elements.beam2_se3 import Beam2SE3Formulation
from reference.elements.beam3 import Beam3Formulation
import reference.elements.driver as driver
from reference.elements.formulation import end_offsets, section_quaternion
import reference.kernel_cache as kernel_cache
from reference.jit import TAG

ELEMENT_FAMILIES: dict[str, type] = {}
"""Element formulation classes by deck name (``ElementFormulation.family``)."""

ALWAYS_PACKED: set[str] = set()
"""The families every Model carries, empty where a model has none of their elements: the engine's own.
The compiled kernels are specialised to the type of ``Model.elements``; with these always present every
model of the engine's families has one type, so each kernel compiles once (not once per combination of
families, e.g. again for a model of rigid bodies only).  A family registered from outside is packed only
where a model uses it."""

_BY_DATA = driver.CLASS_OF_DATA


def register(formulation: type, always: bool = False) -> type:
    """Add an element formulation class to :data:`ELEMENT_FAMILIES` (usable as a class decorator);
    ``always``: carried by every Model (:data:`ALWAYS_PACKED`, for the engine's own families).  The calls
    the family does not give itself (``assemble``, ``tangent_values``, ``resultants``, ``work``) are the
    generic driver's (:mod:`reference.elements.driver`)."""
    name = formulation.family
    known = ELEMENT_FAMILIES.get(name)
    if known is not None and known is not formulation:
        raise ValueError(f"an element family named {name!r} is already registered ({known.__name__})")
    ELEMENT_FAMILIES[name] = formulation
    kernel_cache.FAMILIES[name] = formulation  # a compiled kernel's cache key holds the families it carries
    _BY_DATA[formulation.Data] = formulation
    for call in ("assemble", "tangent_values", "resultants", "work"):
        if getattr(formulation, call, None) is None:  # the generic driver executes the per-element functions
            setattr(formulation, call, staticmethod(getattr(driver, call)))
    if always:
        ALWAYS_PACKED.add(name)
        kernel_cache.ALWAYS.add(name)
    else:
        # two families' data of the same field types must not pass for each other in a compiled kernel
        # (reference.jit.boundary): the families a model carries only where it uses them are tagged
        setattr(formulation.Data, TAG, f"flexmbs_family_{name}")
    return formulation


family_of = driver.formulation_of


def assemble_forces(elements, works, x, q, S):
    """Every family adds its internal forces into ``S`` (N, 6: inertial forces, body-frame moments; not
    zeroed here); returns the sum of their strain energies [J], ``((0 + U_1) + U_2) + …`` in tuple order."""
    return _assemble_from(elements, works, x, q, S, 0.0)


def _assemble_from(elements, works, x, q, S, U):
    for data, work in zip(elements, works):
        U += family_of(data).assemble(data, work, x, q, S)
    return U


@overload(_assemble_from, inline="always")
def _assemble_typing(elements, works, x, q, S, U):
    if len(elements) == 0:
        return lambda elements, works, x, q, S, U: U
    first = _BY_DATA[elements[0].instance_class].assemble
    return lambda elements, works, x, q, S, U: _assemble_from(elements[1:], works[1:], x, q, S,
                                                              U + first(elements[0], works[0], x, q, S))


@overload(assemble_forces, inline="always")
def _assemble_forces_typing(elements, works, x, q, S):
    return lambda elements, works, x, q, S: _assemble_from(elements, works, x, q, S, 0.0)


def tangent_values(elements, works, x, q, psi, ck, values, p, Jr, K):
    """Every family writes ``c_k`` times its elements' tangent blocks (node frames, columns times ``J_r(ψ)``
    of each node) into ``values`` from position ``p`` on, in the order of its ``conn``; returns the position
    after the last family's last value.  ``Jr`` (9,) and ``K`` (flat, at least (6n)² entries) are scratch."""
    for data, work in zip(elements, works):
        p = family_of(data).tangent_values(data, work, x, q, psi, ck, values, p, Jr, K)
    return p


@overload(tangent_values, inline="always")
def _tangent_typing(elements, works, x, q, psi, ck, values, p, Jr, K):
    if len(elements) == 0:
        return lambda elements, works, x, q, psi, ck, values, p, Jr, K: p
    first = _BY_DATA[elements[0].instance_class].tangent_values

    def implementation(elements, works, x, q, psi, ck, values, p, Jr, K):
        p = first(elements[0], works[0], x, q, psi, ck, values, p, Jr, K)
        return tangent_values(elements[1:], works[1:], x, q, psi, ck, values, p, Jr, K)
    return implementation


def resultants(elements, works, x, q, N, M):
    """Section resultants of every family's elements into the rows ``data.index`` of ``N``, ``M`` (E, 3),
    each in its section frame (returns 0)."""
    for data, work in zip(elements, works):
        family_of(data).resultants(data, work, x, q, N, M)
    return 0.0


@overload(resultants, inline="always")
def _resultants_typing(elements, works, x, q, N, M):
    if len(elements) == 0:
        return lambda elements, works, x, q, N, M: 0.0
    first = _BY_DATA[elements[0].instance_class].resultants

    def implementation(elements, works, x, q, N, M):
        first(elements[0], works[0], x, q, N, M)
        return resultants(elements[1:], works[1:], x, q, N, M)
    return implementation


def integration_point_resultants(domain, x, q) -> list:
    """Section resultants at every element's integration points, every family (plain Python; a results
    file stores one row per element: the midpoint's, or beam3's mean of its two Gauss points).

    ``x`` (N, 3), ``q`` (N, 4): a configuration of ``domain``'s nodes (e.g. ``results.positions[k]``,
    ``results.rotations[k]``).  Returns per element ``(s, N, M)``: the points' arc-length parameters ξ (G,)
    ∈ [0, 1] from the element's first end, and the force and moment resultants (G, 3) [N, N m] in the
    section frame (the family's ``integration_points``, at the section triads ``q ⊗ o``).
    """
    out = []
    for element in domain.elements:
        ids = list(element.nodes)
        q0 = [domain.nodes[i].rotation for i in ids]
        p0 = np.array(q0 if element.frames is None else element.frames, dtype=float)
        offsets = end_offsets(q0, p0)
        f = element.formulation
        reference = f.reference_state(np.array([domain.nodes[i].position for i in ids], dtype=float), p0)
        triads = np.empty((len(ids), 4))
        for a, i in enumerate(ids):
            section_quaternion(np.asarray(q[i], dtype=float), offsets[a], triads[a])
        xi, _, stress = f.integration_points(np.asarray(x, dtype=float)[ids], triads, reference)
        out.append((xi, stress[:, :3], stress[:, 3:]))
    return out


DEFAULT_FAMILY = "beam2"
"""The family of a beam that names none (``[[beams]] element``)."""

register(Beam2Formulation, always=True)
register(Beam2SE3Formulation)
register(Beam3Formulation)

__all__ = ["ALWAYS_PACKED", "DEFAULT_FAMILY", "ELEMENT_FAMILIES", "assemble_forces", "family_of",
           "integration_point_resultants", "register", "resultants", "tangent_values"]
