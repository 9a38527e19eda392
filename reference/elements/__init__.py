"""Element kinematics (ElementType) and formulations (ElementFormulation), kept apart as in the paper.

Each formulation class is an element family of the engine, registered by name in
:data:`reference.elements.families.ELEMENT_FAMILIES`.
"""

from reference.elements.beam2 import Beam2Formulation
from reference.elements.element_type import Beam2, ElementType
from reference.elements.formulation import Element, ElementFormulation
from reference.elements.section import Section

__all__ = ["Beam2", "Beam2Formulation", "Element", "ElementFormulation", "ElementType", "Section"]
