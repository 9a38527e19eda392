"""The registry of joint formulations: the deck's ``formulation = "NAME"`` → its class.

A formulation (:class:`reference.joints.formulation.JointFormulation`) is registered here by
name; the deck reader looks names up in :data:`REGISTRY` (with "did you mean" for a
misspelt one) and reads the keys the class declares (``deck_keys``, :meth:`from_deck`); the
Domain lays out the Model field of each layout of :data:`LAYOUTS` from the joints of that
layout; :func:`refusal` says, in one line, which joint an algorithm cannot run.  Adding a
formulation is its module and one line of :data:`REGISTRY` (a new layout, with its own
stage in the algorithms, also one line of :data:`LAYOUTS`).
"""

from __future__ import annotations

from reference.joints.augmented_lagrangian import AugmentedLagrangian
from reference.joints.formulation import Jacobian, MasterSlave, Multipliers

REGISTRY = {cls.name: cls for cls in (Jacobian, MasterSlave, AugmentedLagrangian)}
"""Formulation name (the deck's ``formulation``) → class."""

LAYOUTS = (Multipliers, MasterSlave)
"""The layouts, in the order their Model fields are laid out: each formulation is a subclass of one."""

DEFAULT = "jacobian"
"""The formulation of a joint that names none (Lagrange multipliers)."""


def layout_of(formulation) -> type:
    """The layout (an entry of :data:`LAYOUTS`) that ``formulation`` (an instance) belongs to."""
    for layout in LAYOUTS:
        if isinstance(formulation, layout):
            return layout
    raise ValueError(f"formulation {type(formulation).__name__} is none of the registered layouts "
                     f"({', '.join(layout.__name__ for layout in LAYOUTS)})")


def deck_keys() -> dict:
    """Every formulation's own ``[[joints]]`` keys: key → the formulation's name."""
    return {key: cls.name for cls in REGISTRY.values() for key in cls.deck_keys}


def refusal(joints: list, algorithm: str) -> str | None:
    """One line naming the first joint whose formulation ``algorithm`` cannot run, or None."""
    for joint in joints:
        problem = type(joint.formulation).refusal(algorithm)
        if problem:
            return f"joint {joint.label!r}: {problem}"
    return None
