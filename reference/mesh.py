"""Beam geometry for meshing: nodes on a line or an arc, and section triads.

:meth:`reference.domain.Domain.add_beam` meshes a beam into Beam2 elements
with these: the node points (:func:`straight_line` or :func:`arc_geometry`),
the section triad of each node (from the tangent of the line or arc) and of
each element (from its chord), as Euler parameters (:func:`section_frames`).
A straight rigid bar takes its body frame from :func:`beam_triad`.
"""

from __future__ import annotations

import math

import numpy as np

from reference.elements.formulation import vector_norms
from reference.rotation import check_rotation_matrices, shepperd

ARC_TOLERANCE = 1e-6
"""Largest relative difference of the distances of an arc's two ends from its centre."""


DEFAULT_AXIS2 = (0.0, 1.0, 0.0)
"""The section axis 2 hint of a beam without ``axis2``, unless it is parallel to the beam
(:func:`default_axis2`)."""


def default_axis2(start, end, center=None) -> np.ndarray:
    """The section axis 2 hint of a beam along which :data:`DEFAULT_AXIS2` is parallel somewhere (a straight
    beam along y, an arc with a tangent or chord along y), never parallel to it: for a straight beam
    ``z × e1``, the beam axis turned by +90° about z (``[-1, 0, 0]`` along +y, so that axis 3 is +z, as it is
    for a beam along x with the default); for an arc the normal of its plane, ``(start − c) × (end − c)``,
    orthogonal to every tangent and chord.  (A beam along z gets ``DEFAULT_AXIS2``, never parallel to it.)
    Also the axis the messages suggest when a given ``axis2`` is parallel."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    if center is None:
        hint = np.cross([0.0, 0.0, 1.0], end - start)
    else:
        hint = np.cross(start - np.asarray(center, dtype=float), end - np.asarray(center, dtype=float))
    norm = np.linalg.norm(hint)
    if not norm > 1e-9 * np.linalg.norm(end - start):
        return np.array(DEFAULT_AXIS2)
    return np.round(hint / norm, 12) + 0.0


def beam_triad(axis: np.ndarray, axis2_hint) -> np.ndarray:
    """Section triad ``[e1 e2 e3]`` (columns) of a straight beam (:func:`beam_triads`).

    ``e1`` along the beam, ``e2`` the hint made orthogonal to ``e1``,
    ``e3 = e1 × e2``.
    """
    return beam_triads(np.asarray(axis, dtype=float)[None], axis2_hint)[0]


def beam_triads(axes: np.ndarray, axis2_hint) -> np.ndarray:
    """Section triads (K, 3, 3), columns ``e1 e2 e3``, of K straight beams along ``axes`` (K, 3): ``e1`` along
    the axis, ``e2`` the hint made orthogonal to ``e1``, ``e3 = e1 × e2``; each the numbers of one beam alone
    (the same norms and dot products, :func:`reference.elements.formulation.vector_norms`)."""
    e1 = np.asarray(axes, dtype=float)
    e1 = e1 / vector_norms(e1)[:, None]
    hint = np.asarray(axis2_hint, dtype=float)
    e2 = hint - np.matmul(hint, e1[:, :, None])[:, 0][:, None] * e1
    bad = np.flatnonzero(vector_norms(e2) < 1e-9 * max(np.linalg.norm(hint), 1.0))
    if bad.size:
        raise ValueError(f"section axis 2 {hint.tolist()} is parallel to the beam axis {e1[bad[0]].tolist()}")
    e2 = e2 / vector_norms(e2)[:, None]
    return np.stack([e1, e2, np.cross(e1, e2)], axis=-1)


def straight_line(start: np.ndarray, end: np.ndarray, n_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and tangents of a straight beam: ``n_elements + 1`` equally spaced points, the end points exact."""
    points = start + np.outer(np.arange(n_elements + 1) / n_elements, end - start)
    points[0], points[-1] = start, end
    return points, np.tile(end - start, (n_elements + 1, 1))


def arc_geometry(start, end, center, n_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and unit tangents of the shorter circular arc from ``start`` to ``end`` about ``center``.

    ``n_elements + 1`` points at equal angles ``φ_i = i θ/n`` on the arc
    (``θ < π`` the angle between the radii), tangents in the direction of
    travel.  ``start`` and ``end`` must be equidistant from ``center`` to a
    relative ``ARC_TOLERANCE`` (1e-6) of the radius, so that decimal
    coordinates with 7 significant digits are accepted; the radius is then
    interpolated linearly between the two so the end points are kept exactly.

    Raises
    ------
    ValueError
        Not equidistant, the centre on an end point, or start and end
        diametrically opposite (the arc's plane is undefined).
    """
    c = np.asarray(center, dtype=float)
    r1, r2 = np.asarray(start, dtype=float) - c, np.asarray(end, dtype=float) - c
    R1, R2 = np.linalg.norm(r1), np.linalg.norm(r2)
    if min(R1, R2) <= 0.0:
        raise ValueError("the center coincides with an end point")
    if abs(R1 - R2) > ARC_TOLERANCE * max(R1, R2):
        raise ValueError(f"start and end are not equidistant from center ({R1:.9g} and {R2:.9g}, relative "
                         f"difference {abs(R1 - R2) / max(R1, R2):.2g} > {ARC_TOLERANCE:g}); put both on one circle")
    e1, e2 = r1 / R1, r2 / R2
    normal = np.cross(e1, e2)
    sin_t, cos_t = np.linalg.norm(normal), float(e1 @ e2)
    if sin_t < ARC_TOLERANCE:
        raise ValueError("start and end are diametrically opposite about center (or coincide): the arc's plane is "
                         "undefined; split it into two arcs")
    theta = math.atan2(sin_t, cos_t)
    normal /= sin_t
    f1 = np.cross(normal, e1)
    phi = theta * np.arange(n_elements + 1) / n_elements
    radius = R1 + (R2 - R1) * np.arange(n_elements + 1) / n_elements
    radial = np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), f1)
    points = c + radius[:, None] * radial
    points[0], points[-1] = start, end
    tangents = np.cross(normal, radial)
    return points, tangents


def section_frames(points: np.ndarray, tangents: np.ndarray, axis2) -> tuple[np.ndarray, np.ndarray]:
    """Euler parameters of the section triads (:func:`beam_triad` with the hint ``axis2``).

    Returns the nodes' triads, on the ``tangents`` (n + 1), and the elements'
    triads, on the chords ``points[i + 1] − points[i]`` (n).

    Raises
    ------
    ValueError
        ``axis2`` parallel to a tangent or a chord.
    """
    node_q, elem_q = (_euler_parameters(beam_triads(axes, axis2)) for axes in (tangents, np.diff(points, axis=0)))
    return node_q, elem_q


def _euler_parameters(R: np.ndarray) -> np.ndarray:
    """``EulerParameters.from_matrix(R_k).q`` (K, 4) of K rotation matrices, bit for bit (Shepperd's method and
    the normalisation by the norm of each)."""
    q = shepperd(check_rotation_matrices(R))
    return q / vector_norms(q)[:, None]
