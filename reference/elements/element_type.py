"""Element interpolations: shape functions and quadrature (the paper's ``Element_Type``).

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


class Beam3(ElementType):
    """Three-node quadratic beam element on ξ ∈ [−1, 1], nodes in the order (end 1, end 2, middle)
    at ξ = −1, 1, 0 (Crisfield & Jelenić 1999).

    ``N1 = ξ(ξ − 1)/2``, ``N2 = ξ(ξ + 1)/2``, ``N3 = 1 − ξ²``.  Stiffness uses the **two Gauss points**
    ``ξ = ∓1/√3`` (reduced integration of the quadratic element: free of shear and membrane locking),
    the points the generated beam3 kernels evaluate (``derivations/beam3.py``); the lumped mass takes
    Simpson's rule (weights 1/3, 1/3, 4/3 at the nodes), whose shares of the length are
    :data:`MASS_SHARES`.
    """

    n_nodes = 3
    MASS_SHARES = (1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0)
    """Each node's share of the element's length in the lumped mass, ``∫ N_i dξ / 2`` with Simpson's rule."""

    def shape_functions(self, xi):
        return np.array([xi * (xi - 1.0) / 2.0, xi * (xi + 1.0) / 2.0, 1.0 - xi * xi])

    def shape_derivatives(self, xi, length):
        return np.array([xi - 0.5, xi + 0.5, -2.0 * xi]) * (2.0 / length)

    def integration_points(self):
        g = 1.0 / np.sqrt(3.0)
        return np.array([-g, g]), np.array([1.0, 1.0])

    def mass_points(self):
        return np.array([-1.0, 1.0, 0.0]), np.array([1.0, 1.0, 4.0]) / 3.0
