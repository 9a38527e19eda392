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

import numpy as np
import scipy.sparse as sp

from reference.state import Model


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
        raise NotImplementedError

    def external_forces(self, x, q, t):
        """``F`` (N,6) alone: gravity and the loads at time t (no actuators), as
        :func:`reference.evaluation.forces.external_forces`."""
        raise NotImplementedError

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
        raise NotImplementedError

    def constraint_hessian(self, x, q, t, lam):
        """``∂(Bᵀλ)/∂δ`` (6N, 6N, scipy.sparse csr) at fixed λ (m,), the joints' geometric stiffness
        (:func:`reference.joints.hessian.joint_rows_hessian`)."""
        raise NotImplementedError

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
        raise NotImplementedError

    def damping_matrix(self, x, q, v, w):
        """``C = ∂r/∂V`` (6N, 6N, scipy.sparse csr): the mass-proportional damping ``c M``, the
        gyroscopic tangent ``∂(ω × J ω)/∂ω`` at ``w``, and the force elements' dampers
        ``B_eᵀ diag(c) B_e`` at ``(x, q)``."""
        raise NotImplementedError

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
        raise NotImplementedError

    def residual(self, x, q, v, w, vd, lam, t, angle, dynamic=True):
        """The implicit residual as :func:`reference.algorithms.implicit.evaluate` computes it.

        ``r = S − F + Bᵀλ`` plus, if ``dynamic``, the inertia ``m (v̇ + c v)`` and
        ``J ω̇ + ω × J ω + c J ω`` (``vd`` (N,6) the accelerations ``[v̇ | ω̇]``); a static
        evaluation (``dynamic`` false) gives the force elements zero velocities.

        Returns
        -------
        r : ndarray (N,6)
        phi, B, phi_t
            :meth:`constraints` at ``(x, q, t)``.
        U, D : float
            As :meth:`forces`.
        """
        raise NotImplementedError

    def damper_dissipation(self, x, q, v, w, v_new, w_new):
        """``Σ c (B_e V⁻)·(B_e V̄)``, ``V̄ = ½(V⁻ + V⁺)`` [W]: the force elements' dampers' work rate
        over an explicit kick (:func:`reference.evaluation.force_elements.force_element_dissipation`)."""
        raise NotImplementedError

    def master_slave_project(self, q, v, w):
        """Replace each master/slave pair's velocities by ``T u`` with ``(TᵀMT) u = TᵀM V``, in place
        on ``v``, ``w`` (:func:`reference.joints.master_slave.master_slave_project`); nothing
        without master/slave joints."""
        raise NotImplementedError

    def master_slave_positions(self, x, q):
        """Set each slave's dependent coordinates from its master, in place on ``x``, ``q``
        (:func:`reference.joints.master_slave.master_slave_positions`); nothing without them."""
        raise NotImplementedError
