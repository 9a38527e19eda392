"""A reduced flexible body: a floating reference frame and the modal coordinates of its beam (issue 39).

The kinematics and the kinetic energy are :mod:`reference.reduced.invariants`': nodes at
``x_i = r + A (x̄_i + Φt_i q)`` turning at ``ω + Φr_i q̇``.  The body's velocities are ``V = [ṙ, ω, q̇]``
(``ṙ`` inertial [m/s], ``ω`` the frame's angular velocity in its own components [rad/s], ``q̇`` (r,)), its
configuration the frame's origin ``r``, Euler parameters ``p`` (scalar first, ``ṗ = ½ p ⊗ (0, ω)``) and ``q``.

Equations of motion (Lagrange's equations in the frame's quasi-velocities, the Kirchhoff form
``ṗ + ω × p = F``, ``ḣ + ω × h + v × p = M`` of linear momentum ``p`` and angular momentum ``h`` about the
frame's origin, both in frame components, ``v = Aᵀ ṙ``; Shabana, *Dynamics of Multibody Systems*, 4th ed., §5.5):

    M(A, q) V̇ = Q − Q_v − [0, 0, K_ff q + D_ff q̇],

with :func:`reference.reduced.invariants.mass_matrix` and the quadratic-velocity (centrifugal, Coriolis and
gyroscopic) vector, worked out from the Kirchhoff form (the terms in ``v`` cancel)::

    Q_v,r = A [ω × (ω × S) + 2 ω × S₁ q̇],                S = S₀ + S₁ q,
    Q_v,θ = İ_θθ ω + İ_θf q̇ + ω × (I_θθ ω + I_θf q̇),     İ = Σ q̇ₖ ∂I/∂qₖ,
    Q_v,f,k = ωᵀ (Σₗ q̇ₗ C₁ₗ)[:, k] − ½ ωᵀ ∂ₖI_θθ ω − ωᵀ C₁ₖ q̇.

The equations conserve ``T + ½ qᵀ K_ff q`` and both momenta when ``Q = 0`` and ``D_ff = 0``
(tests/test_reduced_body.py checks this against the nodal sums).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from reference.reduced.craig_bampton import rotation_matrices
from reference.reduced.invariants import Invariants, mass_matrix, nodal_rows
from reference.rotation import skew


class ReducedBody:
    """A floating frame with the modes of a beam (module docstring): attributes ``modes``, ``inv``, ``interfaces``,
    ``rest`` (n, 3) the nodes' rest positions in the frame [m], ``Pt``, ``Pr`` (n, 3, r) the modes' rows, ``masses``
    ``(m (n,), J (n, 3, 3))``, ``K``, ``D`` (r, r) the modal stiffness and damping.

    Parameters
    ----------
    label : str
        The beam's label.
    beam : BeamMatrices
        :func:`reference.reduced.craig_bampton.beam_matrices`: the nodes' rest positions and lumped masses.
    modes : Basis
        The floating modes (:func:`reference.reduced.craig_bampton.floating_modes` or
        :func:`~reference.reduced.craig_bampton.free_free`), mass-normalised.
    inv : Invariants
        :func:`reference.reduced.invariants.invariants` of ``beam`` and ``modes``.
    damping_ratio : float
        Modal damping ratio ζ of every mode: ``D_ff = 2 ζ diag(ω_k)`` (mass-normalised modes) [-].
    interfaces : tuple of int
        Positions along the beam of the nodes where joints, springs and loads attach.
    """

    spin_stiffness = None
    """``𝕂`` (3, 3, r, r) of :func:`reference.reduced.stiffening.spin_stiffness` when the body takes geometric
    stiffening (``reduce.stiffening``), else None."""
    cubic = None
    """``K₃`` (r, r, r) of :func:`reference.reduced.stiffening.modal_third_derivatives` when the body takes the modes'
    second-order stiffness (``reduce.second_order``), else None."""
    quartic = None
    """``K₄`` (r, r, r, r) of :func:`reference.reduced.stiffening.modal_fourth_derivatives` when the body takes the
    modes' third-order stiffness (``reduce.third_order``), else None."""

    def __init__(self, label: str, beam, modes, inv: Invariants, damping_ratio: float = 0.0, interfaces=()):
        self.label, self.modes, self.inv, self.interfaces = label, modes, inv, tuple(interfaces)
        self.rest = beam.x - inv.origin
        m, J, self.Pt, self.Pr = nodal_rows(beam, modes)
        self.masses = (m, J)
        omega = 2.0 * np.pi * modes.frequencies
        self.K = inv.modal_stiffness
        self.D = 2.0 * damping_ratio * np.diag(omega)
        self.n_modes = int(self.K.shape[0])

    def _inertia(self, q, qd):
        """``I_θθ``, ``İ_θθ``, ``I_θf``, ``İ_θf`` and ``∂ₖI_θθ`` (r, 3, 3) at ``q``, ``q̇``."""
        inv = self.inv
        dI = inv.inertia_linear + np.einsum("l,klab->kab", q, inv.inertia_quadratic) \
            + np.einsum("l,lkab->kab", q, inv.inertia_quadratic)
        I_tt = inv.inertia + np.einsum("k,kab->ab", q, inv.inertia_linear) \
            + np.einsum("k,l,klab->ab", q, q, inv.inertia_quadratic)
        I_tf = inv.coupling + np.einsum("k,kal->al", q, inv.coupling_linear)
        return I_tt, np.einsum("k,kab->ab", qd, dI), I_tf, np.einsum("k,kal->al", qd, inv.coupling_linear), dI

    def mass_matrix(self, p, q) -> np.ndarray:
        """M (6 + r, 6 + r) on ``[ṙ, ω, q̇]`` at the frame's Euler parameters ``p`` (4,) and ``q``."""
        return mass_matrix(self.inv, rotation_matrices(p[None])[0], q)

    def quadratic_velocity(self, p, q, w, qd) -> np.ndarray:
        """``Q_v`` (6 + r,) of the module docstring at ``(p, q)`` and velocities ``ω`` (3,), ``q̇`` (r,)."""
        inv, A = self.inv, rotation_matrices(p[None])[0]
        S = inv.first_moment + inv.modal_first_moment @ q
        I_tt, I_tt_dot, I_tf, I_tf_dot, dI = self._inertia(q, qd)
        Q = np.empty(6 + self.n_modes)
        W = skew(w)
        Q[:3] = A @ (W @ (W @ S) + 2.0 * W @ (inv.modal_first_moment @ qd))
        Q[3:6] = I_tt_dot @ w + I_tf_dot @ qd + W @ (I_tt @ w + I_tf @ qd)
        Q[6:] = I_tf_dot.T @ w - 0.5 * np.einsum("a,kab,b->k", w, dI, w) \
            - np.einsum("a,kal,l->k", w, inv.coupling_linear, qd)
        return Q

    def elastic_forces(self, q, qd) -> np.ndarray:
        """``K_ff q + D_ff q̇`` (r,) [the modal coordinates' units: N m^½ / kg^½ for mass-normalised modes]."""
        return self.K @ q + self.D @ qd

    def accelerations(self, p, q, w, qd, Q=None) -> np.ndarray:
        """``V̇ = M⁻¹ (Q − Q_v − [0, 0, K q + D q̇])`` (6 + r,), ``Q`` the applied generalised forces
        (:meth:`point_force`; none by default)."""
        rhs = -self.quadratic_velocity(p, q, w, qd)
        rhs[6:] -= self.elastic_forces(q, qd)
        if Q is not None:
            rhs += Q
        return np.linalg.solve(self.mass_matrix(p, q), rhs)

    def point_force(self, node: int, p, q, force, moment=np.zeros(3)) -> np.ndarray:
        """The generalised force (6 + r,) of an inertial ``force`` [N] and ``moment`` [N m] at the beam's node of
        position ``node``: ``Gᵀ [f; Aᵀ m]`` with ``G`` the node's velocity map (module docstring)."""
        A = rotation_matrices(p[None])[0]
        u = self.rest[node] + self.Pt[node] @ q
        fb, mb = A.T @ np.asarray(force, dtype=float), A.T @ np.asarray(moment, dtype=float)
        return np.concatenate([A @ fb, skew(u) @ fb + mb, self.Pt[node].T @ fb + self.Pr[node].T @ mb])

    def energy(self, p, q, v, w, qd) -> tuple[float, float]:
        """Kinetic ``½ Vᵀ M V`` and strain ``½ qᵀ K_ff q`` energy [J]."""
        V = np.concatenate([v, w, qd])
        return 0.5 * V @ self.mass_matrix(p, q) @ V, 0.5 * q @ self.K @ q

    def critical_time_step(self) -> float:
        """``2 / ω_max`` [s], ``ω²`` the largest eigenvalue of ``(K_ff, M_ff)``: the central difference's limit for
        the stiffest mode kept; infinite without modes."""
        if self.n_modes == 0:
            return np.inf
        return 2.0 / float(np.sqrt(sla.eigvalsh(self.K, self.inv.modal_mass).max()))

    def mesh(self, r, p, q) -> tuple[np.ndarray, np.ndarray]:
        """The deformed mesh: node positions ``r + A (x̄ + Φt q)`` (n, 3) [m] and the nodes' small rotations
        relative to the frame ``Φr q`` (n, 3) [rad, frame components], for output and VTK."""
        A = rotation_matrices(p[None])[0]
        return r + (self.rest + self.Pt @ q) @ A.T, self.Pr @ q


def nearest_velocities(body: ReducedBody, V) -> np.ndarray:
    """The body's velocities ``[ṙ, ω, q̇]`` (6 + r,) nearest, in kinetic energy, to nodal velocities ``V``
    (n, 6) ``[ẋ_i, ω_i]`` (inertial and frame components) with the frame at rest orientation and ``q = 0``:
    ``(Gᵀ M G) X = Gᵀ M V``, ``Gᵀ M G`` the body's mass matrix (the Galerkin projection of the initial
    velocities onto the reduced motion)."""
    m, J = body.masses
    V = np.asarray(V, dtype=float)
    p0, q0 = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(body.n_modes)
    rhs = np.zeros(6 + body.n_modes)
    for i in range(len(m)):
        f, h = m[i] * V[i, :3], J[i] @ V[i, 3:]
        rhs += np.concatenate([f, skew(body.rest[i]) @ f + h, body.Pt[i].T @ f + body.Pr[i].T @ h])
    return np.linalg.solve(body.mass_matrix(p0, q0), rhs)


def steady_spin(body: ReducedBody, omega) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The modal equations linearised about ``q = 0`` with the frame turning at the constant ``ω`` (3,) [rad/s,
    frame components] about its fixed origin (a hub): ``M q̈ + G q̇ + K q = f`` with ``M = M_ff``, the
    gyroscopic ``G_kl = ωᵀ (C₁ₗ[:, k] − C₁ₖ[:, l])`` (skew) and ``K = K_ff − ωᵀ I₂ₖₗ ω`` (centrifugal
    softening), from the modal rows of ``Q_v`` (module docstring); the constant centrifugal load
    ``f_k = −½ ωᵀ I₁ₖ ω`` moves the equilibrium, not the frequencies.  Without geometric stiffening, which
    the linear modes lack: the frequencies of this pencil are what the reduced body predicts for a spinning
    part."""
    w = np.asarray(omega, dtype=float)
    C = np.einsum("a,lak->kl", w, body.inv.coupling_linear)
    quadratic = np.einsum("a,klab,b->kl", w, body.inv.inertia_quadratic, w)
    return body.inv.modal_mass, C - C.T, body.K - 0.5 * (quadratic + quadratic.T)
