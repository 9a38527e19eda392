"""Element kinematics: shape functions and quadrature (the paper's ``Element_Type``).

An :class:`ElementType` knows nothing about mechanics; a formulation
(:mod:`reference.elements.formulation`) asks it for shape functions, their
derivatives and the integration points (paper §4.2.2, Fig. 4).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


class ElementType(ABC):
    """Abstract element kinematics.

    Subclasses provide ``n_nodes`` and:

    - ``shape_functions(xi)`` → values ``N_i(ξ)`` at the natural coordinate ξ;
    - ``shape_derivatives(xi, length)`` → ``dN_i/ds`` with respect to arc length;
    - ``integration_points()`` → ``(ξ_k, w_k)`` for the stiffness terms;
    - ``mass_points()`` → ``(ξ_k, w_k)`` exact for the (lumped) mass.
    """

    n_nodes: int

    @abstractmethod
    def shape_functions(self, xi: float) -> np.ndarray: ...

    @abstractmethod
    def shape_derivatives(self, xi: float, length: float) -> np.ndarray: ...

    @abstractmethod
    def integration_points(self) -> tuple[np.ndarray, np.ndarray]: ...

    @abstractmethod
    def mass_points(self) -> tuple[np.ndarray, np.ndarray]: ...


class Beam2(ElementType):
    """Two-node linear beam element on ξ ∈ [−1, 1].

    ``N1 = (1 − ξ)/2``, ``N2 = (1 + ξ)/2``.  Stiffness uses **one-point
    (reduced) integration** at ξ = 0, which avoids shear locking and leaves no
    spurious zero-energy mode for the two-node beam (Simo & Vu-Quoc 1986).  At
    ξ = 0 the interpolated position derivative is ``(x2 − x1)/L0`` and the
    interpolated relative rotation ``N2(0) ψ = ψ/2``: exactly what the
    generated Beam2 kernel evaluates.
    """

    n_nodes = 2

    def shape_functions(self, xi):
        return np.array([(1.0 - xi) / 2.0, (1.0 + xi) / 2.0])

    def shape_derivatives(self, xi, length):
        return np.array([-1.0 / length, 1.0 / length])

    def integration_points(self):
        return np.array([0.0]), np.array([2.0])

    def mass_points(self):
        g = 1.0 / np.sqrt(3.0)
        return np.array([-g, g]), np.array([1.0, 1.0])
