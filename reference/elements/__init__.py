"""Element kinematics (ElementType) and formulations (ElementFormulation), kept apart as in the paper."""

from reference.elements.element_type import Beam2, ElementType
from reference.elements.formulation import Beam2Formulation, Element, ElementFormulation
from reference.elements.section import Section

__all__ = ["Beam2", "Beam2Formulation", "Element", "ElementFormulation", "ElementType", "Section"]
