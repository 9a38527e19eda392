"""Closed-form solutions that the verification measures the engine against."""

from __future__ import annotations

import numpy as np


def elastica_tip(length: float, k: float) -> np.ndarray:
    """Tip of a cantilever along +x under an end moment ``M = k π EI/L`` bending it towards +z.

    The elastica is a circular arc of curvature ``M/EI`` (exact for any EA, GA):
    with ``t = k π``, ``x = L sin t / t``, ``z = L (1 − cos t)/t`` (docs/benchmarks.md §1).
    """
    t = k * np.pi
    if abs(t) < 1e-12:
        return np.array([length, 0.0, 0.0])
    return np.array([length * np.sin(t) / t, 0.0, length * (1.0 - np.cos(t)) / t])


def polygon_tip(length: float, n_elements: int, k: float) -> np.ndarray:
    """Tip of the converged Beam2 discretisation of the same problem.

    With a pure end moment every element carries the same curvature and no
    force, so its chord is unstrained and points along the midpoint triad:
    a regular polygon whose i-th chord has direction angle ``(i + ½) k π / n``.
    """
    L0 = length / n_elements
    a = (np.arange(n_elements) + 0.5) * k * np.pi / n_elements
    return L0 * np.array([np.cos(a).sum(), 0.0, np.sin(a).sum()])


def cantilever_tip_deflection(P: float, L: float, EI: float, GA: float) -> float:
    """Timoshenko cantilever under a tip load P: ``P L³/(3 EI) + P L/GA``."""
    return P * L**3 / (3.0 * EI) + P * L / GA


def cantilever_first_frequency(L: float, EI: float, rhoA: float) -> float:
    """First bending eigenfrequency [rad/s] of a clamped–free Euler–Bernoulli beam."""
    return 1.8751040687119611**2 * np.sqrt(EI / (rhoA * L**4))


def fourbar_rocker_angle(theta, crank=1.0, coupler=5.0, rocker=4.0, ground=4.0, branch=1.0) -> np.ndarray:
    """Rocker angle of a planar four-bar linkage from its crank angle (closed-form position analysis).

    Ground pivots O1 = (0, 0) and O3 = (ground, 0); crank O1 → A, coupler A → B,
    rocker B → O3.  B is the intersection of the circle of radius ``coupler``
    about A with the circle of radius ``rocker`` about O3; ``branch = +1``
    takes the assembly with B to the left of the line A → O3 (the three-bar
    deck's: A = (0, 1), B = (4, 4) at θ = 90°).  Returns the angle of O3 → B
    from the x axis [rad], one per crank angle ``theta`` [rad].
    """
    theta = np.asarray(theta, dtype=float)
    ax, ay = crank * np.cos(theta), crank * np.sin(theta)
    dx, dy = ground - ax, -ay
    dist = np.hypot(dx, dy)
    along = (coupler**2 - rocker**2 + dist**2) / (2.0 * dist)
    across = np.sqrt(np.maximum(coupler**2 - along**2, 0.0))
    ux, uy = dx / dist, dy / dist
    bx = ax + along * ux - branch * across * uy
    by = ay + along * uy + branch * across * ux
    return np.arctan2(by, bx - ground)
