"""Observables written for particular decks: the three-bar's rocker and crank angles, and the signed
midspan deflection of its coupler (or of any beam), for the report's checks, the tests and the lessons.

The general grammar is the engine's (:mod:`reference.observables`); these add what a deck's
geometry fixes: the rocker's pivot (4, 0) and the crank's pivot at the origin of
``models/three_bar.toml``, the plane of its motion.
"""

from __future__ import annotations

import numpy as np

from reference.observables import parse, relative_angle


def rocker_angle(results, rocker="rocker", pivot=(4.0, 0.0)) -> np.ndarray:
    """Angle [rad] of the line pivot → rocker centre from the x axis: its initial value plus the
    rocker's rotation about z since (``angle.z:rocker``)."""
    c0 = results.position(rocker)[0]
    return np.arctan2(c0[1] - pivot[1], c0[0] - pivot[0]) + relative_angle(results, rocker, None, 2)


def crank_angle(results, crank="crank") -> np.ndarray:
    """Angle [rad] of the crank (O1 = origin → its centre of mass) from the x axis, unwrapped."""
    c = results.position(crank)
    return np.unwrap(np.arctan2(c[:, 1], c[:, 0]))


def midspan_deflection(results, beam="coupler", normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Signed transverse deflection [m] of a beam's middle node from the chord of its end nodes
    (default: the three-bar's coupler).

    The deflection vector (``midspan_deflection:BEAM``) projected on ``normal × chord``: for the
    default normal z, positive towards the left of the chord in the x–y plane.  The beam needs an
    even number of elements; a chord along ``normal`` has no such direction (an error).
    """
    obs = parse(f"midspan_deflection:{beam}", results)
    d = obs.evaluate(results)
    a, b = results.position(f"{beam}:start"), results.position(f"{beam}:end")
    side = np.cross(np.asarray(normal, dtype=float), b - a)
    size = np.linalg.norm(side, axis=1)
    if np.any(size <= 1e-12 * np.linalg.norm(b - a, axis=1)):
        raise ValueError(f"the chord of {beam!r} is along the normal {tuple(normal)}: give another normal, "
                         "or use the deflection vector (observable 'midspan_deflection:BEAM')")
    return np.sum(d * side, axis=1) / size
