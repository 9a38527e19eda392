"""What the building API checks and resolves before it touches the model.

The ``Domain.add_*`` calls take the model in the deck's words: nodes named by a label or a beam
reference (``"rod:start"``, ``"b:mid"``, ``"rod:3"``, :func:`resolve_node`), a beam's element count,
section and family (:func:`beam_arguments`), a section axis hint that may be parallel to the beam
(:func:`with_axis2`).  Each refusal is one sentence in the deck reader's wording, with a fix (a
close label, a known family) — the language a user writes a model in.  It is its own module
because that language is not the paper's Domain (§4.3: the lists and their resolution,
:mod:`reference.domain`): the Domain asks here, then builds.
"""

from __future__ import annotations

import difflib

import numpy as np

from reference.elements import Section
from reference.elements.families import ELEMENT_FAMILIES
from reference.mesh import DEFAULT_AXIS2
from reference.nodes import Node
from reference import validation
from reference.validation import LabelError, direction, vector


def resolve_node(key, nodes: list[Node], labels: dict[str, Node], beams: dict[str, list[Node]]) -> Node:
    """The node that ``key`` names (:meth:`reference.domain.Domain.node`): a Node, an id into ``nodes``, a
    label of ``labels`` or a beam reference ``BEAM:start``, ``BEAM:mid``, ``BEAM:end``, ``BEAM:i`` of ``beams``.

    Raises
    ------
    reference.validation.LabelError
        A ``KeyError`` of one line, the deck's wording: what is wrong and the fix (a close label).
    """
    if isinstance(key, Node):
        return key
    if isinstance(key, (int, np.integer)) and not isinstance(key, (bool, np.bool_)):
        if 0 <= key < len(nodes):
            return nodes[int(key)]
        raise LabelError(f"no node with id {key}", f"ids run from 0 to {len(nodes) - 1}")
    if not isinstance(key, str):
        raise LabelError(f"expected a node reference (a label like 'beam:end'), got {key!r}")
    if key in labels:
        return labels[key]
    beam, _, which = key.rpartition(":")
    if beam in beams:
        members = beams[beam]
        if which in ("start", "end"):
            return members[0 if which == "start" else -1]
        if which == "mid":
            if len(members) % 2 == 0:
                raise LabelError(f"beam '{beam}' has no node at mid-span ({len(members) - 1} segments)",
                                 f"give it an even number of segments, or use an index 0…{len(members) - 1}")
            return members[len(members) // 2]
        if which.isascii() and which.isdigit() and int(which) < len(members):
            return members[int(which)]
        raise LabelError(f"beam '{beam}' has no node {which!r}",
                         f"use '{beam}:start', '{beam}:mid', '{beam}:end' or an index 0…{len(members) - 1}")
    if key in beams:  # a bare beam label: which of its nodes?
        raise LabelError(f"{key!r} is a beam, not a node",
                         f"use '{key}:start', '{key}:end' or an index '{key}:0'…'{key}:{len(beams[key]) - 1}'")
    ends = [f"{b}:{w}" for b in beams for w in ("start", "end")]
    close = difflib.get_close_matches(key, list(labels) + ends, n=1)
    raise LabelError(f"no node {key!r}", f"did you mean '{close[0]}'?" if close else
                     "reference a node label or '<beam>:start', '<beam>:end', '<beam>:<i>'")


def beam_arguments(label, beams: dict, n_elements, section, element, start, end, center) -> tuple:
    """The arguments of :meth:`reference.domain.Domain.add_beam` checked, in its order:
    ``(n_elements, start, end, center)`` as an int and arrays (``center`` None for a straight beam).

    Raises
    ------
    ValueError
        One sentence in the deck reader's wording (``beam 'rod': n_elements: expected an integer ≥ 1,
        got 8.0``): a label already in ``beams``, a missing or non-integer ``n_elements``, a missing
        section or one without its stiffness, an unknown ``element`` family (with a close name),
        coinciding end points.
    """
    what = f"beam {label!r}"
    validation.label(label, "beam label")
    if label in beams:
        raise ValueError(f"{what}: a beam of this label exists; give each beam its own label")
    if n_elements is None or isinstance(n_elements, Section):  # add_beam(label, start, end, section)
        raise ValueError(f"{what}: missing n_elements (the number of elements, e.g. 8)")
    if section is None:
        raise ValueError(f"{what}: missing section (a reference.elements.Section)")
    n_elements = validation.integer(n_elements, f"{what}: n_elements")
    if not isinstance(section, Section):
        raise ValueError(f"{what}: section: expected a reference.elements.Section, got {type(section).__name__}")
    if section.missing_stiffness:
        raise ValueError(f"{what}: the section has no {', '.join(section.missing_stiffness)}: a flexible beam "
                         "needs its ten properties (a section of mass data alone is for rigid bars)")
    if not isinstance(element, str) or element not in ELEMENT_FAMILIES:
        close = difflib.get_close_matches(element, list(ELEMENT_FAMILIES), n=1) if isinstance(element, str) else []
        raise ValueError(f"{what}: unknown element {element!r}; "
                         + (f"did you mean '{close[0]}'?" if close else f"known: {', '.join(ELEMENT_FAMILIES)}"))
    start, end = vector(start, f"{what}: start"), vector(end, f"{what}: end")
    center = None if center is None else vector(center, f"{what}: center")
    if np.linalg.norm(end - start) <= 0.0:
        raise ValueError(f"{what}: start and end coincide")
    return n_elements, start, end, center


def with_axis2(what: str, axis2, frames, fallback):
    """``frames(hint)`` for the section axis hint ``axis2`` of a beam or rigid bar (``what``, e.g.
    ``"beam 'rod'"``), or for :data:`reference.mesh.DEFAULT_AXIS2` where it is not given.

    ``frames`` raises a ``ValueError`` when the hint is parallel to the beam; then the default gives way to
    ``fallback()`` (:func:`reference.mesh.default_axis2`), and a hint the user gave is refused with that
    direction as the fix (``…; give another axis2, e.g. axis2 = [0.0, 1.0, 0.0]``).
    """
    hint = DEFAULT_AXIS2 if axis2 is None else direction(axis2, f"{what}: axis2")
    try:
        return frames(hint)
    except ValueError as exc:
        other = fallback()
        if axis2 is not None:
            raise ValueError(f"{what}: {exc}; give another axis2, e.g. axis2 = {other.tolist()}") from None
        return frames(other)
