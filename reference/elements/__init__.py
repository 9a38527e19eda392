"""Element interpolations (ElementType) and formulations (ElementFormulation), kept apart as in the paper.

Each formulation class is an element family of the engine, registered by name in
:data:`reference.elements.families.ELEMENT_FAMILIES`: its physics, per element, executed by the generic
driver :mod:`reference.elements.driver`.
"""

from reference.elements.beam2 import Beam2Formulation
from reference.elements.element_type import Beam2, Beam3, ElementType
from reference.elements.formulation import Element, ElementFormulation
from reference.elements.section import Section

__all__ = ["Beam2", "Beam2Formulation", "Beam3", "Element", "ElementFormulation", "ElementType", "Section"]
