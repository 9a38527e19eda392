"""Cross-section properties of a beam (stiffness and inertia per unit length)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np


@dataclass(frozen=True, kw_only=True)
class Section:
    """Elastic and inertial properties of a beam cross-section.

    Axis 1 is the beam axis, axes 2 and 3 the principal section axes.

    Parameters
    ----------
    EA, GA2, GA3 : float
        Axial and shear stiffness [N].
    GJ, EI2, EI3 : float
        Torsional and bending stiffness [N m²].
    rhoA : float
        Mass per unit length [kg/m].
    rhoJ1, rhoJ2, rhoJ3 : float
        Rotary inertia per unit length about the section axes [kg m].
    """

    EA: float
    GA2: float
    GA3: float
    GJ: float
    EI2: float
    EI3: float
    rhoA: float
    rhoJ1: float
    rhoJ2: float
    rhoJ3: float

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value) or value <= 0.0:
                raise ValueError(f"section property {f.name} = {value!r} must be a positive number")

    @property
    def stiffness(self) -> np.ndarray:
        """``[EA, GA2, GA3, GJ, EI2, EI3]``, the diagonals of C_Γ and C_K."""
        return np.array([self.EA, self.GA2, self.GA3, self.GJ, self.EI2, self.EI3])

    @property
    def rotary_inertia(self) -> np.ndarray:
        """``[ρJ1, ρJ2, ρJ3]`` [kg m]."""
        return np.array([self.rhoJ1, self.rhoJ2, self.rhoJ3])
