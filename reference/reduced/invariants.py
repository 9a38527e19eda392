"""The floating frame of reference's inertia shape integrals (Shabana's invariants) of a beam's modes.

A reduced body moves its nodes as ``x_i = r + A u_i(q)``, ``u_i = x̄_i + Φt_i q`` (Shabana, *Dynamics of
Multibody Systems*, 4th ed., eqs. 5.2–5.10): ``r`` the frame's origin [m], ``A`` its rotation, ``x̄_i`` the
node's rest position in the frame, ``Φt_i`` (3, r) the translational rows of the modes
(:func:`reference.reduced.craig_bampton.floating_modes`), ``q`` (r,) the modal coordinates.  Each node also turns
with the frame and its modes' rotational rows ``Φr_i`` (3, r): its angular velocity is ``ω + Φr_i q̇`` (body-frame
components, linear in the small relative rotation, as the linear modes are).  With the lumped masses ``m_i`` and
rotary inertias ``J_i`` (body frame) the kinetic energy is

    T = ½ Σ m_i |ṙ − A ũ_i ω + A Φt_i q̇|² + ½ Σ (ω + Φr_i q̇)ᵀ J_i (ω + Φr_i q̇),

so the mass matrix on ``[ṙ (inertial), ω (body), q̇]`` is ``Σ G_iᵀ diag(m_i I, J_i) G_i`` with
``G_i = [[I, −A ũ_i, A Φt_i], [0, I, Φr_i]]``.  Its entries are polynomials of degree two in ``q`` whose
coefficients, sums over the nodes, do not change with the motion: :class:`Invariants` holds them once, and
:func:`mass_matrix` puts them together (``ã`` is the skew matrix of ``a``, ``ã b = a × b``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference.rotation import skew


class Invariants(NamedTuple):
    """The inertia shape integrals of a reduced body (module docstring; r modes, frame origin ``origin``).

    Attributes
    ----------
    mass : float
        ``m = Σ m_i`` [kg].
    origin : ndarray (3,)
        The frame's origin in the rest configuration [m] (``x̄_i = x_i − origin``).
    first_moment : ndarray (3,)
        ``S₀ = Σ m_i x̄_i`` [kg m].
    modal_first_moment : ndarray (3, r)
        ``S₁ = Σ m_i Φt_i``: ``S(q) = S₀ + S₁ q``.
    inertia : ndarray (3, 3)
        ``I₀ = Σ m_i x̃_iᵀ x̃_i + Σ J_i`` [kg m²], the rest inertia about the origin.
    inertia_linear : ndarray (r, 3, 3)
        ``I₁ₖ = Σ m_i (x̃_iᵀ φ̃_ik + φ̃_ikᵀ x̃_i)``, ``φ_ik`` column k of ``Φt_i``.
    inertia_quadratic : ndarray (r, r, 3, 3)
        ``I₂ₖₗ = Σ m_i φ̃_ikᵀ φ̃_il``: ``I_θθ(q) = I₀ + Σ qₖ I₁ₖ + Σ qₖ qₗ I₂ₖₗ``.
    coupling : ndarray (3, r)
        ``C₀ = Σ m_i x̃_i Φt_i + Σ J_i Φr_i``, rotation–mode coupling at rest.
    coupling_linear : ndarray (r, 3, r)
        ``C₁ₖ = Σ m_i φ̃_ik Φt_i``: ``I_θf(q) = C₀ + Σ qₖ C₁ₖ``.
    modal_mass, modal_stiffness : ndarray (r, r)
        ``M_ff = Σ Φt_iᵀ m_i Φt_i + Φr_iᵀ J_i Φr_i`` and ``K_ff = Φᵀ K Φ`` (the beam's K, not a nodal sum).
    """

    mass: float
    origin: np.ndarray
    first_moment: np.ndarray
    modal_first_moment: np.ndarray
    inertia: np.ndarray
    inertia_linear: np.ndarray
    inertia_quadratic: np.ndarray
    coupling: np.ndarray
    coupling_linear: np.ndarray
    modal_mass: np.ndarray
    modal_stiffness: np.ndarray


def _skews(vectors) -> np.ndarray:
    """Skew matrices (..., 3, 3) of vectors (..., 3)."""
    v = np.asarray(vectors, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def nodal_rows(beam, modes) -> tuple:
    """The lumped masses ``m`` (n,), rotary inertias ``J`` (n, 3, 3) and the modes' translational and rotational
    rows ``Φt``, ``Φr`` (n, 3, r) of a :class:`~reference.reduced.craig_bampton.BeamMatrices` and a basis."""
    n = len(beam.nodes)
    blocks = beam.M.reshape(n, 6, n, 6)[np.arange(n), :, np.arange(n), :]
    phi = modes.T.reshape(n, 6, -1)
    return blocks[:, 0, 0], blocks[:, 3:, 3:], phi[:, :3, :], phi[:, 3:, :]


def invariants(beam, modes, origin=None) -> Invariants:
    """The :class:`Invariants` of ``beam`` (:class:`~reference.reduced.craig_bampton.BeamMatrices`) with the
    floating-frame ``modes`` (a :class:`~reference.reduced.craig_bampton.Basis` without rigid motion), about
    ``origin`` [m] (default: the beam's centre of mass)."""
    m, J, Pt, Pr = nodal_rows(beam, modes)
    mass = float(m.sum())
    origin = beam.x.T @ m / mass if origin is None else np.asarray(origin, dtype=float)
    xb = beam.x - origin
    X, P = _skews(xb), _skews(np.moveaxis(Pt, 2, 1))  # (n,3,3), (n,r,3,3)
    XtP = np.einsum("n,nba,nkbc->kac", m, X, P)
    return Invariants(
        mass=mass, origin=origin, first_moment=m @ xb, modal_first_moment=np.einsum("n,nak->ak", m, Pt),
        inertia=np.einsum("n,nba,nbc->ac", m, X, X) + J.sum(axis=0),
        inertia_linear=XtP + XtP.transpose(0, 2, 1),
        inertia_quadratic=np.einsum("n,nkba,nlbc->klac", m, P, P),
        coupling=np.einsum("n,nab,nbk->ak", m, X, Pt) + np.einsum("nab,nbk->ak", J, Pr),
        coupling_linear=np.einsum("n,nkab,nbl->kal", m, P, Pt),
        modal_mass=modes.M.copy(), modal_stiffness=modes.K.copy())


def mass_matrix(inv: Invariants, A, q) -> np.ndarray:
    """The reduced body's mass matrix (6 + r, 6 + r) on ``[ṙ (inertial), ω (body), q̇]`` at the frame's rotation
    ``A`` (3, 3) and modal coordinates ``q`` (r,) (module docstring), from the invariants alone."""
    r = q.shape[0]
    S = skew(inv.first_moment + inv.modal_first_moment @ q)
    I_tt = inv.inertia + np.einsum("k,kab->ab", q, inv.inertia_linear) \
        + np.einsum("k,l,klab->ab", q, q, inv.inertia_quadratic)
    I_tf = inv.coupling + np.einsum("k,kal->al", q, inv.coupling_linear)
    M = np.zeros((6 + r, 6 + r))
    M[:3, :3] = inv.mass * np.eye(3)
    M[:3, 3:6] = -A @ S
    M[:3, 6:] = A @ inv.modal_first_moment
    M[3:6, 3:6] = I_tt
    M[3:6, 6:] = I_tf
    M[6:, 6:] = inv.modal_mass
    M[3:, :3] = M[:3, 3:].T
    M[6:, 3:6] = I_tf.T
    return M
