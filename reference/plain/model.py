"""The model's equations in plain NumPy: what every algorithm of the reference path asks of a Model.

:class:`Evaluation` is the reference twin of the compiled evaluation layer
(:mod:`reference.evaluation`, :mod:`reference.joints.assembly`): the same generated physics
(``reference/generated/*.py``, from ``derivations/*.py``) evaluated with NumPy, no numba.
Its pieces live in three modules, each short enough to read on one screen per function:

- the element families' forces and tangents: :mod:`reference.plain.elements`;
- loads, gravity and the force elements: :mod:`reference.plain.loads`;
- the joints (Φ, B, Φ_t, the constraint Hessian) and master/slave joints:
  :mod:`reference.plain.constraints`.

Conventions (the engine's, stated once in :mod:`reference.state`, :mod:`reference.evaluation.forces`
and :mod:`reference.algorithms.implicit`):

- N nodes; ``x`` (N,3) inertial positions [m], ``q`` (N,4) Euler parameters, scalar first;
  ``v`` (N,3) inertial velocities [m/s], ``w`` (N,3) body-frame angular velocities [rad/s].
- Per node six coordinates ``[inertial δx (3), body-frame δθ (3)]`` in that order; a global
  vector or matrix column of length 6N is node-major: coordinate ``6 n + a``.
  Increments are applied as ``x ← x + δx``, ``q ← q ⊗ exp(δθ)``.
- Generalised forces per node (N,6) ``[inertial force (3) N, body-frame moment (3) N m]``:
  ``S`` internal (elements, minus the force elements' springs and dampers), ``F`` external
  (gravity, loads × time functions, actuators).  Eq. (5) of the paper reads
  ``M V̇ + Bᵀλ = F − S`` (plus damping ``−c M V`` and the gyroscopic ``−ω × J ω``).
- Joints: m rows in the engine's order (joint k's rows start at ``model.joints.row0[k]``);
  B (m, 6N) has columns per node as above, all 6N of them (fixed coordinates included:
  an algorithm restricts to :attr:`Evaluation.free`); ``Φ_t = ∂Φ/∂t`` (drives);
  ``ε`` (m,) the regularisation, ``ε λ = Φ`` (:mod:`reference.joints.assembly`).
- Rotational force elements carry a continuous angle ``angle`` (F,) (``State.angle``):
  every evaluation continues it from the value passed and writes it back in place, as the
  compiled evaluation does.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from reference.generated import rotation_maps as rm
from reference.plain import constraints, loads
from reference.plain.elements import element_forces, element_tangent
from reference.plain.vectorise import plain
from reference.state import Model


def assemble_blocks(n_nodes, nodes, blocks):
    """The (6N, 6N) scipy.sparse.csr sum of square blocks (K, 6n, 6n) on the node lists ``nodes`` (K, n)
    (node-major coordinates; a node −1, the ground, drops its rows and columns)."""
    K, n = nodes.shape
    idx = (6 * nodes[:, :, None] + np.arange(6)).reshape(K, 6 * n)
    keep = np.repeat(nodes >= 0, 6, axis=1)
    mask = keep[:, :, None] & keep[:, None, :]
    rows = np.broadcast_to(idx[:, :, None], blocks.shape)
    cols = np.broadcast_to(idx[:, None, :], blocks.shape)
    return sp.csr_matrix((blocks[mask], (rows[mask], cols[mask])), shape=(6 * n_nodes, 6 * n_nodes))


class Residual(NamedTuple):
    """One evaluation of the implicit residual (:meth:`Evaluation.residual`): ``r`` (N,6), the forces ``S``,
    ``F`` (N,6) it was made of, :meth:`Evaluation.constraints`' ``phi`` (m,), ``B`` (m, 6N) csr and
    ``phi_t`` (m,), the strain energy ``U`` [J] and the dampers' power ``D`` [W]."""

    r: np.ndarray
    S: np.ndarray
    F: np.ndarray
    phi: np.ndarray
    B: sp.csr_matrix
    phi_t: np.ndarray
    U: float
    D: float


class Evaluation:
    """The equations of one Model in NumPy: forces, constraints, tangent, mass.

    Stateless apart from what is fixed by the model (its arrays, the sparsity of B): every
    method takes the configuration it is evaluated at, and nothing is remembered between
    calls except where a method says so (the continuous angle, updated in place).

    Parameters
    ----------
    model : Model
        The assembled model (:class:`reference.state.Model`).

    Attributes
    ----------
    model : Model
    n_nodes, n_constraints : int
        N and m.
    masses : tuple (m (N,), J (N,3,3))
        The nodes' lumped masses [kg] and body-frame inertia tensors [kg m²]
        (``model.nodes.mass``, ``model.nodes.inertia``).
    free : ndarray of bool (N,6)
        True where a coordinate is free (``model.nodes.free > 0.5``).
    eps : ndarray (m,)
        The joints' ε per row (``model.joints.eps``).
    damping : float
        The mass-proportional damping c [1/s] (``model.damping``): force ``−c m v``, moment ``−c J ω``.
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self.n_nodes = int(model.nodes.mass.shape[0])
        self.n_constraints = model.n_constraints
        self.masses = (model.nodes.mass, model.nodes.inertia)
        self.free = model.nodes.free > 0.5
        self.eps = model.joints.eps
        self.damping = float(model.damping)
        self._jacobian_layout = constraints.jacobian_layout(model)

    def forces(self, x, q, v, w, t, angle):
        """The generalised forces at ``(x, q, v, w)`` and time ``t`` [s].

        As :func:`reference.evaluation.forces.generalized_forces`: the element families'
        internal forces, the force elements' springs and dampers (subtracted from S, their
        dampers at the velocities ``v``, ``w``), gravity, the loads and the actuators.

        Parameters
        ----------
        x, q, v, w : ndarray (N,3), (N,4), (N,3), (N,3)
        t : float
        angle : ndarray (F,)
            The rotational force elements' continuous angles: continued and written back in place.

        Returns
        -------
        S, F : ndarray (N,6)
            Internal and external generalised forces (new arrays).
        U : float
            Strain energy of the elements and the springs [J].
        D : float
            Power of the force elements' dampers ``Σ c (B_e V)²`` [W].
        """
        S, U = element_forces(self.model, x, q)
        F = loads.external_forces(self.model, q, t)
        D = 0.0
        if self.model.force_elements.kind.shape[0] > 0:
            G, actuators, U_springs, D = loads.force_element_forces(self.model, x, q, v, w, t, angle)
            S, F, U = S - G, F + actuators, U + U_springs
        return S, F, float(U), D

    def external_forces(self, x, q, t):
        """``F`` (N,6) alone: gravity and the loads at time t (no actuators), as
        :func:`reference.evaluation.forces.external_forces`."""
        return loads.external_forces(self.model, q, t)

    def constraints(self, x, q, t):
        """The joints' rows at ``(x, q)`` and time t (:func:`reference.joints.assembly.joint_rows`).

        Returns
        -------
        phi : ndarray (m,)
            Φ, the constraint values (drives included: ``Φ = … − s(t)`` style rows).
        B : scipy.sparse.csr_matrix (m, 6N)
            ∂Φ/∂δ with the columns of the module docstring (``B V`` is the rows' rate with ``V``
            the (N,6) velocities ``[v | ω]`` flattened node-major).
        phi_t : ndarray (m,)
            ∂Φ/∂t; the constraint rate is ``B V + Φ_t``.
        """
        phi, B_local, phi_t = constraints.joint_rows(self.model, x, q, t)
        return phi, constraints.global_jacobian(self._jacobian_layout, B_local), phi_t

    def constraint_hessian(self, x, q, t, lam):
        """``∂(Bᵀλ)/∂δ`` (6N, 6N, scipy.sparse csr) at fixed λ (m,), the joints' geometric stiffness
        (:func:`reference.joints.hessian.joint_rows_hessian`)."""
        return assemble_blocks(self.n_nodes, *constraints.constraint_hessians(self.model, x, q, t, lam))

    def tangent(self, x, q, v, w, t, lam=None, angle=None):
        """The tangent stiffness ``K = ∂r/∂δ`` (6N, 6N, scipy.sparse csr) at fixed velocities.

        ``r`` is the implicit residual (:mod:`reference.algorithms.implicit`,
        ``r = M V̇ + c M V + gyro + S − F + Bᵀλ``), δ the increments of the module docstring
        under the update ``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (static, ``ψ = 0``).  K is the sum of
        the element families' tangents, ``−∂F/∂δ`` of the follower forces and dead moments, the
        force elements' stiffness ``−∂f/∂δ`` at the velocities ``v``, ``w`` (with the actuators'
        term) and, when ``lam`` is given, :meth:`constraint_hessian`.  Fixed coordinates are
        included (the algorithm restricts).

        The compiled Newton matrix (:func:`reference.evaluation.tangent.tangent_values`) is
        ``[c_m M + c_c C + c_k K T(ψ), Bᵀ; B T(ψ), −c_e diag(ε)]`` with :meth:`mass_matrix`,
        :meth:`damping_matrix` and :meth:`rotation_tangent`.

        ``angle`` (F,): the rotational springs' continuous angles (read, not updated); None
        continues them from zero (the principal angle).
        """
        model, N = self.model, self.n_nodes
        K = element_tangent(model, x, q) + assemble_blocks(N, np.arange(N)[:, None], loads.load_tangent(model, q, t))
        if model.force_elements.kind.shape[0] > 0:
            angle = np.zeros(model.force_elements.kind.shape[0]) if angle is None else angle
            nodes, K_fe, _ = loads.force_element_tangents(model, x, q, v, w, t, angle)
            K = K + assemble_blocks(N, nodes, K_fe)
        if lam is not None and self.n_constraints > 0:
            K = K + self.constraint_hessian(x, q, t, lam)
        return K.tocsr()

    def damping_matrix(self, x, q, v, w):
        """``C = ∂r/∂V`` (6N, 6N, scipy.sparse csr): the mass-proportional damping ``c M``, the
        gyroscopic tangent ``∂(ω × J ω)/∂ω`` at ``w``, and the force elements' dampers
        ``B_eᵀ diag(c) B_e`` at ``(x, q)``."""
        model, N = self.model, self.n_nodes
        gyro = np.zeros((N, 6, 6))
        gyro[:, 3:, 3:] = loads.gyroscopic_tangents(model.nodes.inertia, w)
        C = self.damping * self.mass_matrix() + assemble_blocks(N, np.arange(N)[:, None], gyro)
        if model.force_elements.kind.shape[0] > 0:
            angle = np.zeros(model.force_elements.kind.shape[0])  # C = B_eᵀ diag(c) B_e depends on neither t nor φ
            nodes, _, C_fe = loads.force_element_tangents(model, x, q, v, w, 0.0, angle)
            C = C + assemble_blocks(N, nodes, C_fe)
        return C.tocsr()

    def mass_matrix(self):
        """M (6N, 6N, scipy.sparse csr): per node ``m I₃`` and the body-frame inertia J."""
        m, J = self.masses
        N = self.n_nodes
        blocks = np.zeros((N, 6, 6))
        blocks[:, 0, 0] = blocks[:, 1, 1] = blocks[:, 2, 2] = m
        blocks[:, 3:, 3:] = J
        return sp.block_diag(list(blocks), format="csr") if N else sp.csr_matrix((0, 0))

    def rotation_tangent(self, psi):
        """``T(ψ)`` (6N, 6N, scipy.sparse csr): per node ``I₃`` and the right tangent operator
        ``J_r(ψ_n)`` of ``exp(ψ + δ) = exp(ψ) exp(J_r(ψ) δ) + O(δ²)`` (generalized-α's update
        ``q = q_n ⊗ exp(ψ + δ)``), ψ (N,3)."""
        N = self.n_nodes
        Jr = np.empty((9, N))
        plain(rm.right_jacobian)(np.asarray(psi, dtype=float).T, Jr)
        blocks = np.zeros((N, 6, 6))
        blocks[:, :3, :3] = np.eye(3)
        blocks[:, 3:, 3:] = Jr.T.reshape(N, 3, 3)
        return assemble_blocks(N, np.arange(N)[:, None], blocks)

    def residual(self, x, q, v, w, vd, lam, t, angle, dynamic=True):
        """The implicit residual as :func:`reference.algorithms.implicit.evaluate` computes it.

        ``r = S − F + Bᵀλ`` plus, if ``dynamic``, the inertia ``m (v̇ + c v)`` and
        ``J ω̇ + ω × J ω + c J ω`` (``vd`` (N,6) the accelerations ``[v̇ | ω̇]``); a static
        evaluation (``dynamic`` false) gives the force elements zero velocities.

        ``angle`` as in :meth:`forces` (continued in place).  Returns a :class:`Residual`.
        """
        if not dynamic:
            v, w = np.zeros_like(v), np.zeros_like(w)
        S, F, U, D = self.forces(x, q, v, w, t, angle)
        r = S - F
        if dynamic:
            m, J = self.masses
            Jw = np.einsum("nab,nb->na", J, w)
            r[:, :3] += m[:, None] * (vd[:, :3] + self.damping * v)
            r[:, 3:] += np.cross(w, Jw) + self.damping * Jw + np.einsum("nab,nb->na", J, vd[:, 3:])
        phi, B, phi_t = self.constraints(x, q, t)
        if self.n_constraints > 0:
            r += (B.T @ lam).reshape(-1, 6)
        return Residual(r, S, F, phi, B, phi_t, U, D)

    def damper_dissipation(self, x, q, v, w, v_new, w_new):
        """``Σ c (B_e V⁻)·(B_e V̄)``, ``V̄ = ½(V⁻ + V⁺)`` [W]: the force elements' dampers' work rate
        over an explicit kick (:func:`reference.evaluation.force_elements.force_element_dissipation`)."""
        if self.model.force_elements.kind.shape[0] == 0:
            return 0.0
        return loads.force_element_dissipation(self.model, x, q, v, w, v_new, w_new)

    def master_slave_project(self, q, v, w):
        """Replace each master/slave pair's velocities by ``T u`` with ``(TᵀMT) u = TᵀM V``, in place
        on ``v``, ``w`` (:func:`reference.joints.master_slave.master_slave_project`); nothing
        without master/slave joints."""
        constraints.master_slave_project(self.model, q, v, w)

    def master_slave_positions(self, x, q):
        """Set each slave's dependent coordinates from its master, in place on ``x``, ``q``
        (:func:`reference.joints.master_slave.master_slave_positions`); nothing without them."""
        constraints.master_slave_positions(self.model, x, q)
