"""Geometric stiffening of a reduced body: the stress stiffness of its modes under a steady spin (issue 39).

Linear modes lose the stiffening that a spinning part's centrifugal tension gives its bending (Kane, Ryan &
Banerjee, J. Guid. Control Dyn. 10 (1987) 139): a blade's flapwise frequency rises with the spin, a model on
linear modes keeps it at rest.  The linear term that restores it is the geometric stiffness of the stress state
of the centrifugal load (Shabana, *Dynamics of Multibody Systems*, 4th ed., §5.9 on stress stiffening).

:func:`centrifugal_stiffening` takes it from the project's own tangent: the static displacement ``u`` of the
centrifugal load at unit spin, frame held (``K_ii u = f``, ``f_i = m_i (I − e eᵀ) x̄_i`` about the axis ``e``
through the frame's origin), and the derivative of the element tangent along it,
``K_σ = (K_T(+ε u) − K_T(−ε u)) / 2ε`` (central difference, error O(ε²)); on the modes
``K_G = Φᵀ K_σ Φ``, and the stiffness at spin Ω is ``K_ff + Ω² K_G``.  The derivative is taken in the node
frames at rest (``δθ`` turned by the rest rotations, as the modes are): exact for the axial stretch of a straight
radial blade, a linearisation of the initial-displacement terms otherwise.
"""

from __future__ import annotations

import itertools

import numpy as np

from reference.plain.elements import element_tangent
from reference.plain.newton import compose
from reference.reduced.craig_bampton import frame_map, node_coordinates, rotation_matrices

STEP = 1e-3
"""ε × the largest centrifugal displacement [m] (× the beam's length scale 1): small enough that the O(ε²) error of
the central difference is ~1e-6 relative, large enough that the round-off of K_T (~1e-16 of EA/L) stays ~1e-10."""


def centrifugal_displacement(beam, held, axis, origin) -> np.ndarray:
    """The static displacement (6n,) of the centrifugal load at unit spin about ``axis`` through ``origin``
    [m per (rad/s)², body-frame coordinates], the nodes at positions ``held`` along the beam fixed."""
    e = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    m = np.diag(beam.M)[::6]
    radial = (beam.x - origin) - np.outer((beam.x - origin) @ e, e)
    f = np.zeros(beam.K.shape[0])
    f.reshape(-1, 6)[:, :3] = m[:, None] * radial
    free = np.setdiff1d(np.arange(f.size), node_coordinates(held))
    u = np.zeros_like(f)
    u[free] = np.linalg.solve(beam.K[np.ix_(free, free)], f[free])
    return u


def _tangent_at(domain, beam, u, scale: float = 1.0) -> np.ndarray:
    """The beam's tangent (6n, 6n) at its rest state displaced by ``scale · u`` (``u`` (6n,) in the body-frame
    coordinates of the module docstring: ``x + s u_x``, ``q ⊗ exp(s A u_θ)``), in the node frames
    (:func:`_to_body_frame` turns it)."""
    x = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3)
    q = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4)
    A = rotation_matrices(q[beam.nodes])
    U = u.reshape(-1, 6)
    idx = node_coordinates(beam.nodes)
    x[beam.nodes] += scale * U[:, :3]
    q[beam.nodes] = compose(q[beam.nodes], scale * np.einsum("nba,nb->na", A, U[:, 3:]))
    return element_tangent(domain.model, x, q)[idx][:, idx].toarray()


def _to_body_frame(domain, beam, K) -> np.ndarray:
    """``T K Tᵀ``: a (6n, 6n) matrix of the beam's node frames at rest (rotation rows body frame) in the body-frame
    coordinates of the module docstring."""
    q = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4)
    T = frame_map(rotation_matrices(q[beam.nodes]))
    return T @ K @ T.T


def tangent_derivative(domain, beam, u) -> np.ndarray:
    """``K_σ = (K_T(+ε u) − K_T(−ε u)) / 2ε`` (6n, 6n): the derivative of the beam's tangent at rest along the
    displacement ``u`` (6n,) (body-frame coordinates of the module docstring), per unit of ``u``; ε = :data:`STEP`
    over the largest entry of ``u`` (zero for ``u = 0``: a spin about a straight blade's own axis loads nothing)."""
    if not np.abs(u).max() > 0.0:
        return np.zeros((u.size, u.size))
    scale = STEP / np.abs(u).max()
    difference = _tangent_at(domain, beam, u, scale) - _tangent_at(domain, beam, u, -scale)
    return _to_body_frame(domain, beam, difference) / (2.0 * scale)


def _symmetric(tensor) -> np.ndarray:
    """The mean of ``tensor`` over every permutation of its indices (a derivative of the strain energy is
    symmetric in them; the difference quotients are so to their truncation error)."""
    perms = list(itertools.permutations(range(tensor.ndim)))
    return sum(tensor.transpose(p) for p in perms) / len(perms)


def modal_third_derivatives(domain, beam, modes) -> np.ndarray:
    """``K₃`` (r, r, r): the derivative of the modal stiffness along each mode,
    ``K₃[:, :, k] = Φᵀ K_σ(Φ_k) Φ`` (:func:`tangent_derivative`), made symmetric in its three indices (it is the
    third derivative of the strain energy in the modal coordinates).  The modes' second-order stiffness: the
    elastic force ``K η + ½ K₃ : η η``, the tangent ``K + K₃ · η``, the energy ``½ ηᵀ K η + ⅙ K₃ ⋮ η η η``; it
    carries the stress stiffness of the body's own deformation (a coupler's axial force stiffening its bending,
    the P-δ effect that linear modes lack)."""
    phi = modes.T
    r = phi.shape[1]
    K3 = np.zeros((r, r, r))
    for k in range(r):
        K3[:, :, k] = phi.T @ tangent_derivative(domain, beam, phi[:, k]) @ phi
    return _symmetric(K3)


def modal_fourth_derivatives(domain, beam, modes) -> np.ndarray:
    """``K₄`` (r, r, r, r): the second derivative of the modal stiffness along each pair of modes,
    ``K₄[:, :, k, l] = Φᵀ ∂²K_T/∂u_k ∂u_l Φ`` (mixed central differences of the tangent, steps ε = :data:`STEP` over
    each mode's largest entry), made symmetric in its four indices (the fourth derivative of the strain energy in
    the modal coordinates).  The modes' third-order stiffness: the elastic force ``… + ⅙ K₄ ⋮ η η η``, the tangent
    ``… + ½ K₄ : η η``, the energy ``… + ¹⁄₂₄ K₄ ⋮ η η η η``.  With :func:`modal_third_derivatives` it gives the strain
    energy to fourth order in η, the order of a beam's axial stretch from its own bending (von Kármán's
    ``EA/8L (∫ w′² dx)²``): the bent coupler's shortening stiffens its bending, which the third order alone lacks
    (Barbič & James 2005 keep the same orders for St. Venant–Kirchhoff solids, whose energy is exactly quartic)."""
    phi = modes.T
    r = phi.shape[1]
    steps = STEP / np.abs(phi).max(axis=0)
    K4 = np.zeros((r, r, r, r))
    for k in range(r):
        for l in range(k, r):
            uk, ul = steps[k] * phi[:, k], steps[l] * phi[:, l]
            second = (_tangent_at(domain, beam, uk + ul) - _tangent_at(domain, beam, uk - ul)
                      - _tangent_at(domain, beam, ul - uk) + _tangent_at(domain, beam, -uk - ul))
            second = _to_body_frame(domain, beam, second)
            K4[:, :, k, l] = K4[:, :, l, k] = phi.T @ second @ phi / (4.0 * steps[k] * steps[l])
    return _symmetric(K4)


def derivative_modes(domain, beam, basis) -> np.ndarray:
    """Static modal derivatives (Idelsohn & Cardona, Comput. Methods Appl. Mech. Eng. 49 (1985) 253) of the
    fixed-interface modes of a Craig–Bampton ``basis`` (:func:`reference.reduced.craig_bampton.craig_bampton`):
    for each pair ``k ≤ l`` of its modes ``φ``, the displacement (6n,) that the tangent's change along one mode
    makes of the other, interface nodes held,

        ``θ_kl = −K_ii⁻¹ ½ (K_σ(φ_l) φ_k + K_σ(φ_k) φ_l)``,

    ``K_σ(u)`` the tangent's derivative along ``u`` (:func:`tangent_derivative`).  They are the second-order
    displacement field of the modes: a beam bent in its mode shape ``φ`` moves axially by ``½ θ`` per unit of
    modal amplitude squared (the membrane strain ``½ w′²`` relaxed), which fixed-interface modes place late in
    frequency order or not at all.  Columns in the order ``(1, 1), (1, 2), …, (1, m), (2, 2), …`` [m per unit of
    modal coordinate squared, body-frame coordinates of the module docstring of
    :mod:`reference.reduced.craig_bampton`]."""
    held = node_coordinates(basis.interfaces)
    phi = basis.T[:, held.size:]
    size, m = phi.shape
    interior = np.setdiff1d(np.arange(size), held)
    K_ii = beam.K[np.ix_(interior, interior)]
    changes = [tangent_derivative(domain, beam, phi[:, k]) for k in range(m)]
    out = np.zeros((size, m * (m + 1) // 2))
    for column, (k, l) in enumerate(itertools.combinations_with_replacement(range(m), 2)):
        load = 0.5 * (changes[l] @ phi[:, k] + changes[k] @ phi[:, l])
        out[interior, column] = -np.linalg.solve(K_ii, load[interior])
    return out


def centrifugal_stiffening(domain, beam, modes, held, axis, origin) -> np.ndarray:
    """``K_G`` (r, r): the modes' geometric stiffness per (rad/s)² of spin about ``axis`` through ``origin``
    (module docstring), the nodes at positions ``held`` along the beam fixed to the frame (the hub)."""
    u = centrifugal_displacement(beam, held, axis, origin)
    K_sigma = tangent_derivative(domain, beam, u)
    K_G = modes.T.T @ K_sigma @ modes.T
    return 0.5 * (K_G + K_G.T)


def spin_stiffness(domain, beam, modes, interfaces) -> np.ndarray:
    """``𝕂`` (3, 3, r, r): the modes' centrifugal stress stiffness at any spin ``ω`` (frame components),
    ``K_G(ω) = Σ_ab ω_a ω_b 𝕂_ab``, the body turning about its first interface node (a blade about its hub; that
    node held).  The centrifugal load is quadratic in ω and the stress stiffness linear in the load, so six
    :func:`centrifugal_stiffening` calls fix it: ``𝕂_aa = K_G(e_a)`` and
    ``𝕂_ab = K_G((e_a + e_b)/√2) − ½ (𝕂_aa + 𝕂_bb)``."""
    held = (interfaces[0],)
    origin = beam.x[interfaces[0]]
    r = modes.T.shape[1]
    out = np.zeros((3, 3, r, r))
    axes = np.eye(3)
    for a in range(3):
        out[a, a] = centrifugal_stiffening(domain, beam, modes, held, axes[a], origin)
    for a in range(3):
        for b in range(a + 1, 3):
            both = centrifugal_stiffening(domain, beam, modes, held, axes[a] + axes[b], origin)
            out[a, b] = out[b, a] = both - 0.5 * (out[a, a] + out[b, b])
    return out
