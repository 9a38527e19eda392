"""Cross-section properties of a beam (stiffness and inertia per unit length)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

STIFFNESS = ("EA", "GA2", "GA3", "GJ", "EI2", "EI3")
"""The stiffness properties: a flexible beam needs them, a rigid bar only the mass data."""


@dataclass(frozen=True, kw_only=True)
class Section:
    """Elastic and inertial properties of a beam cross-section.

    Axis 1 is the beam axis, axes 2 and 3 the principal section axes.  A section used only by
    rigid bars (:meth:`reference.domain.Domain.add_rigid_bar`) needs only its mass data, as in a
    deck (``docs/deck.md``); a flexible beam refuses a section without the six stiffnesses.

    Parameters
    ----------
    EA, GA2, GA3 : float, optional
        Axial and shear stiffness [N].
    GJ, EI2, EI3 : float, optional
        Torsional and bending stiffness [N m²].
    rhoA : float
        Mass per unit length [kg/m].
    rhoJ1, rhoJ2, rhoJ3 : float
        Rotary inertia per unit length about the section axes [kg m].

    Raises
    ------
    ValueError
        ``Section: EA = '1e7' must be a positive number``: one line naming the property, for a value
        that is not a positive finite number (a string, a boolean, NaN, zero …).
    """

    EA: float | None = None
    GA2: float | None = None
    GA3: float | None = None
    GJ: float | None = None
    EI2: float | None = None
    EI3: float | None = None
    rhoA: float
    rhoJ1: float
    rhoJ2: float
    rhoJ3: float

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None and f.name in STIFFNESS:
                continue
            number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
            if not number or not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"Section: {f.name} = {value!r} must be a positive number"
                                 + (" (a number, not a string)" if isinstance(value, str) else ""))
            object.__setattr__(self, f.name, float(value))

    @property
    def missing_stiffness(self) -> list[str]:
        """The stiffness properties not given (a flexible beam needs none missing)."""
        return [name for name in STIFFNESS if getattr(self, name) is None]

    @property
    def stiffness(self) -> np.ndarray:
        """``[EA, GA2, GA3, GJ, EI2, EI3]``, the diagonals of C_Γ and C_K."""
        return np.array([self.EA, self.GA2, self.GA3, self.GJ, self.EI2, self.EI3])

    @property
    def rotary_inertia(self) -> np.ndarray:
        """``[ρJ1, ρJ2, ρJ3]`` [kg m]."""
        return np.array([self.rhoJ1, self.rhoJ2, self.rhoJ3])
