"""The element families the engine knows, and the compiled calls that reach every family of a model.

A *family* is an :class:`~reference.elements.formulation.ElementFormulation`
subclass registered here by its deck name (``[[beams]] element = "beam2"``): the
paper's promise (§2, §4.2.2, Fig. 4) that a new element is a new class.  The
Domain packs the elements of each family present in a model (and of the engine's own
families, :data:`ALWAYS_PACKED`, present or not) into that family's plain data
(``family.pack``), and :class:`reference.state.Model` carries them as the tuple
``Model.elements``, one entry per family, in registry order.

The algorithms never name a family.  They call the three functions below, which
numba resolves at compile time, for the model's tuple of family data, into a
straight sequence of calls of each family's own kernels (no run-time dispatch;
the code of each sequence is generated from the registry when a kernel using it
is compiled): :func:`assemble_forces`, :func:`tangent_values` and
:func:`resultants`.  With ``NUMBA_DISABLE_JIT=1`` the same functions loop over the
tuple in Python.

What a family provides is listed in
:class:`~reference.elements.formulation.ElementFormulation`.
"""

from __future__ import annotations

import numpy as np
from numba.extending import overload

from reference.elements.beam2 import Beam2Formulation
from reference.elements.beam2_se3 import Beam2SE3Formulation
from reference.elements.beam3 import Beam3Formulation
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

_BY_DATA: dict[type, type] = {}


def register(formulation: type, always: bool = False) -> type:
    """Add an element formulation class to :data:`ELEMENT_FAMILIES` (usable as a class decorator);
    ``always``: carried by every Model (:data:`ALWAYS_PACKED`, for the engine's own families)."""
    name = formulation.family
    known = ELEMENT_FAMILIES.get(name)
    if known is not None and known is not formulation:
        raise ValueError(f"an element family named {name!r} is already registered ({known.__name__})")
    ELEMENT_FAMILIES[name] = formulation
    kernel_cache.FAMILIES[name] = formulation  # a compiled kernel's cache key holds the families it carries
    _BY_DATA[formulation.Data] = formulation
    if always:
        ALWAYS_PACKED.add(name)
        kernel_cache.ALWAYS.add(name)
    else:
        # two families' data of the same field types must not pass for each other in a compiled kernel
        # (reference.jit.boundary): the families a model carries only where it uses them are tagged
        setattr(formulation.Data, TAG, f"flexmbs_family_{name}")
    return formulation


def family_of(data) -> type:
    """The formulation class whose plain data ``data`` is."""
    return _BY_DATA[type(data)]


def _calls(method: str, arguments: str, through: str | None = None):
    """A function ``f(elements, works, <arguments>)`` calling ``family.<method>(data, work, <arguments>)``
    for every family's data and work arrays in turn.

    It returns the sum of what the calls return or, with ``through`` (an argument's
    name), passes each call's return value to the next as that argument and returns
    the last.  Compiled, it is resolved for the type of the tuple ``elements`` (numba
    ``overload``) into one call per family, the tuple indexed by constants; in plain
    Python it loops.
    """
    into = f"{through} = " if through else "total += "
    result = through or "total"

    def source(name: str, calls: list[str]) -> str:
        lines = [f"def {name}(elements, works, {arguments}):", "    total = 0.0"]
        lines += [f"    {into}{call}(elements[{k}], works[{k}], {arguments})" for k, call in enumerate(calls)]
        return "\n".join(lines + [f"    return {result}", ""])

    scope: dict = {"family_of": family_of}
    loop = (f"def all_{method}(elements, works, {arguments}):\n    total = 0.0\n"
            f"    for data, work in zip(elements, works):\n"
            f"        {into}getattr(family_of(data), {method!r})(data, work, {arguments})\n"
            f"    return {result}\n")
    exec(loop, scope)  # noqa: S102 - generated from this module's own strings
    python = scope[f"all_{method}"]

    def implementation(elements):
        kinds = [_BY_DATA[t.instance_class] for t in getattr(elements, "types", ())]
        local = {f"f{k}": getattr(kind, method) for k, kind in enumerate(kinds)}
        exec(source("call", [f"f{k}" for k in range(len(kinds))]), local)  # noqa: S102 - from the registry
        return local["call"]

    # numba's typing function must have the overloaded function's own signature
    typing = {"implementation": implementation}
    exec(f"def typed(elements, works, {arguments}):\n    return implementation(elements)\n", typing)  # noqa: S102
    overload(python, inline="always")(typing["typed"])
    return python


assemble_forces = _calls("assemble", "x, q, S")
"""``assemble_forces(elements, works, x, q, S) → U``: every family adds its internal forces into
``S`` (N, 6: inertial forces, body-frame moments; not zeroed here) and returns its strain energy [J]."""

tangent_values = _calls("tangent_values", "x, q, psi, ck, values, p, Jr, K", through="p")
"""``tangent_values(elements, works, x, q, psi, ck, values, p, Jr, K) → count``: every family writes
``c_k`` times its elements' tangent blocks (node frames, columns times ``J_r(ψ)`` of each node)
into ``values`` from position ``p`` on, in the order of its ``conn``, and returns the position after
its last value; ``Jr`` (9,) and ``K`` (flat, at least (6n)² entries) are scratch."""

resultants = _calls("resultants", "x, q, N, M")
"""``resultants(elements, works, x, q, N, M)``: section resultants of every element into the rows
``data.index`` of ``N``, ``M`` (E, 3), in its section frame (returns 0)."""

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
