"""Observables of the paper's examples, computed from results (either engine's)."""

from __future__ import annotations

import numpy as np


def rocker_angle(results, rocker="rocker", pivot=(4.0, 0.0)) -> np.ndarray:
    """Angle [rad] of the rocker (pivot → its centre of mass) from the x axis, per output."""
    c = results.position(rocker)
    return np.arctan2(c[:, 1] - pivot[1], c[:, 0] - pivot[0])


def crank_angle(results, crank="crank") -> np.ndarray:
    """Angle [rad] of the crank (O1 = origin → its centre of mass) from the x axis, unwrapped."""
    c = results.position(crank)
    return np.unwrap(np.arctan2(c[:, 1], c[:, 0]))


def midspan_deflection(results, beam="coupler") -> np.ndarray:
    """In-plane transverse deflection of a beam's middle node from the chord of its end nodes.

    Positive towards the left of the chord (x–y plane); the beam needs an even
    number of elements.
    """
    nodes = sorted((int(lbl.rsplit(":", 1)[1]), lbl) for lbl in results.labels if lbl.startswith(beam + ":"))
    n = nodes[-1][0]
    if n % 2:
        raise ValueError(f"{beam} has an odd number of elements ({n}): no middle node")
    a, b, m = (results.position(f"{beam}:{k}")[:, :2] for k in (0, n, n // 2))
    chord = b - a
    normal = np.stack([-chord[:, 1], chord[:, 0]], axis=1) / np.linalg.norm(chord, axis=1)[:, None]
    return np.sum((m - 0.5 * (a + b)) * normal, axis=1)


def wrap(angle) -> np.ndarray:
    """Angle differences wrapped to (−π, π]."""
    return np.angle(np.exp(1j * np.asarray(angle)))
