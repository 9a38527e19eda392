"""The joints in NumPy: constraint values Φ, Jacobian B, Φ_t, the λ-weighted Hessian, master/slave joints.

The twin of :func:`reference.joints.assembly.joint_rows`, :func:`reference.joints.hessian.joint_rows_hessian`
and :mod:`reference.joints.master_slave`.  Every joint evaluates the ten generated primitives
(``reference/generated/joints.py`` from ``derivations/joints.py``; their Hessians
``tangents.joint_primitive_hessian``) all joints at once (structure of arrays,
:func:`reference.plain.vectorise.plain`); a joint's rows are some of those primitives
(``model.joints.rows``) or, for a drive, one combination of them with its time function:

========  =====================================  ==================================
drive     row                                    Φ_t
========  =====================================  ==================================
0         the primitives ``rows[:neq]``          0
1, 2      ``Φ5 cos θ − Φ9 sin θ``, θ = f or ∫f    ``−(Φ5 sin θ + Φ9 cos θ) θ̇``
3, 4      ``Φ8 + s``, s = f or ∫f                 ``ṡ``
5         ``u · (Φ0, Φ1, Φ2) + f``, u inertial    ``ḟ``
========  =====================================  ==================================

Conventions (rows, columns, ε): :mod:`reference.plain.model`.  The ground (``j = −1``) sits at the
origin with the identity rotation; its columns are dropped.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from reference.connector import body_fixed_parts
from reference.generated import joints as generated_joints
from reference.generated import rotation_maps as rm
from reference.generated import tangents as generated_tangents
from reference.interactions import tf_derivative, tf_integral, tf_value
from reference.joints.master_slave import SPHERICAL, pair_parts
from reference.plain.loads import rotation_matrices, time_functions_at
from reference.plain.vectorise import plain

N_PRIMITIVES = generated_joints.N_PRIMITIVES


def _ends(joints, x, q):
    """The primitives' first eight arguments for every joint (structure of arrays; the ground where ``j = −1``)."""
    ground = (joints.j < 0)[:, None]
    xj = np.where(ground, 0.0, x[np.maximum(joints.j, 0)])
    qj = np.where(ground, np.array([1.0, 0.0, 0.0, 0.0]), q[np.maximum(joints.j, 0)])
    par = joints.par
    return (x[joints.i].T, q[joints.i].T, xj.T, qj.T, *plain(body_fixed_parts)(par.T))


def primitives(joints, x, q):
    """The ten primitives of every joint: Φ (J, 10) and their Jacobians (J, 10, 12) on
    ``[v_i, ω_i, v_j, ω_j]`` (generated ``joint_primitives``)."""
    J = joints.i.shape[0]
    phi, B = np.empty((N_PRIMITIVES, J)), np.empty((12 * N_PRIMITIVES, J))
    plain(generated_joints.joint_primitives)(*_ends(joints, x, q), phi, B)
    return phi.T, B.T.reshape(J, N_PRIMITIVES, 12)


def _drive_functions(time_functions, t):
    """``(value, rate)`` (T,) of each time function for each drive code: the prescribed quantity is
    f (drives 1, 3, 5) or ∫f (drives 2, 4)."""
    f = time_functions_at(time_functions, t, tf_value)
    df = time_functions_at(time_functions, t, tf_derivative)
    integral = time_functions_at(time_functions, t, tf_integral)
    return {1: (f, df), 2: (integral, f), 3: (f, df), 4: (integral, f), 5: (f, df)}


def joint_rows(model, x, q, t):
    """Every joint's rows, as :func:`reference.joints.assembly.assemble_constraints`.

    Returns
    -------
    phi : ndarray (m,)
    B_local : ndarray (m, 12)
        Each row's Jacobian on ``[v_i, ω_i, v_j, ω_j]`` of its joint (the ground's columns zero).
    phi_t : ndarray (m,)
    """
    joints = model.joints
    m = model.n_constraints
    phi, B, phi_t = np.zeros(m), np.zeros((m, 12)), np.zeros(m)
    if m == 0:
        return phi, B, phi_t
    P, PB = primitives(joints, x, q)
    drives = _drive_functions(model.time_functions, t) if np.any(joints.drive > 0) else {}
    for k in range(joints.i.shape[0]):
        r0, neq, drive, tf = joints.row0[k], joints.neq[k], joints.drive[k], joints.tf[k]
        rows = slice(r0, r0 + neq)
        if drive == 0:
            prim = joints.rows[k, :neq]
            phi[rows], B[rows] = P[k, prim], PB[k, prim]
            continue
        s, ds = drives[int(drive)][0][tf], drives[int(drive)][1][tf]
        if drive <= 2:  # rotation drive: θ = s(t) about u3
            c, sn = np.cos(s), np.sin(s)
            phi[r0] = P[k, 5] * c - P[k, 9] * sn
            phi_t[r0] = -(P[k, 5] * sn + P[k, 9] * c) * ds
            B[r0] = PB[k, 5] * c - PB[k, 9] * sn
        elif drive <= 4:  # displacement drive: body i slides by s along u3 relative to j
            phi[r0], phi_t[r0], B[r0] = P[k, 8] + s, ds, PB[k, 8]
        else:  # prescribed displacement along the ground-fixed u3 (par[15:24], inertial)
            u = joints.par[k, [17, 20, 23]]
            phi[r0], phi_t[r0], B[r0] = u @ P[k, :3] + s, ds, u @ PB[k, :3]
    ground = np.repeat(joints.j < 0, joints.neq)
    B[ground, 6:] = 0.0
    return phi, B, phi_t


def row_nodes(joints):
    """``(i, j)`` (m,) of each row's joint."""
    return np.repeat(joints.i, joints.neq), np.repeat(joints.j, joints.neq)


def jacobian_layout(model):
    """Where each row's 12 local entries go in the global B (m, 6N): ``(keep, indices, indptr, shape)``, the
    CSR layout of :func:`global_jacobian` (fixed by the model; ``keep`` (m, 12) drops the ground's columns)."""
    m, N = model.n_constraints, model.nodes.mass.shape[0]
    i, j = row_nodes(model.joints)
    cols = np.concatenate([6 * i[:, None] + np.arange(6), 6 * j[:, None] + np.arange(6)], axis=1)
    keep = np.concatenate([np.ones((m, 6), bool), np.repeat((j >= 0)[:, None], 6, axis=1)], axis=1)
    indptr = np.concatenate([[0], np.cumsum(keep.sum(axis=1))])
    return keep, cols[keep], indptr, (m, 6 * N)


def global_jacobian(layout, B_local):
    """B (m, 6N) scipy.sparse.csr from the rows' local Jacobians (m, 12) in the :func:`jacobian_layout`."""
    keep, indices, indptr, shape = layout
    return sp.csr_matrix((B_local[keep], indices, indptr), shape=shape)


def primitive_weights(model, t, lam):
    """Weights (J, 10) of the primitives in ``Σ_rows λ_r B_r``
    (:func:`reference.joints.hessian.primitive_weights`)."""
    joints = model.joints
    w = np.zeros((joints.i.shape[0], N_PRIMITIVES))
    drives = _drive_functions(model.time_functions, t)
    for k in range(joints.i.shape[0]):
        r0, neq, drive = joints.row0[k], joints.neq[k], joints.drive[k]
        if drive == 0:
            np.add.at(w[k], joints.rows[k, :neq], lam[r0:r0 + neq])
        elif drive <= 2:
            s = drives[int(drive)][0][joints.tf[k]]
            w[k, 5], w[k, 9] = lam[r0] * np.cos(s), -lam[r0] * np.sin(s)
        elif drive <= 4:
            w[k, 8] = lam[r0]
        else:
            w[k, :3] = lam[r0] * joints.par[k, [17, 20, 23]]
    return w


def constraint_hessians(model, x, q, t, lam):
    """Each joint's geometric stiffness ``∂(Bᵀλ)/∂[δx_i, δθ_i, δx_j, δθ_j]`` at fixed λ (m,): ``nodes``
    (J, 2) ``[i, j]`` and blocks (J, 12, 12) (the ground's rows and columns zero), the weighted sum of the
    generated primitive Hessians (:func:`reference.joints.hessian.joint_rows_hessian`)."""
    joints = model.joints
    J = joints.i.shape[0]
    H = np.empty((144, J))
    plain(generated_tangents.joint_primitive_hessian)(*_ends(joints, x, q), primitive_weights(model, t, lam).T, H)
    H = H.T.reshape(J, 12, 12).copy()
    ground = joints.j < 0
    H[ground, 6:, :] = 0.0
    H[ground, :, 6:] = 0.0
    return np.stack([joints.i, joints.j], axis=1), H


def _pair_matrix(model, k, q):
    """``T`` (12, d) of master/slave pair k: ``[v_m, ω_m, v_s, ω_s] = T u``
    (:func:`reference.joints.master_slave._pair_matrices`), d = 9 spherical, 7 revolute."""
    ms = model.master_slave
    p, a_s = ms.par[k, 0:3], ms.par[k, 6:9]
    A_m, A_s = rotation_matrices(q[[ms.master[k], ms.slave[k]]])
    p_skew = np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])
    spherical = ms.kind[k] == SPHERICAL
    T = np.zeros((12, 9 if spherical else 7))
    T[:6, :6] = np.eye(6)
    T[6:9, :3] = np.eye(3)
    T[6:9, 3:6] = -A_m @ p_skew  # v_s = v_m − A_m p̃'_m ω_m
    if spherical:
        T[9:12, 6:9] = np.eye(3)  # ω_s free
    else:
        T[9:12, 3:6] = A_s.T @ A_m  # ω_s = A_sᵀ A_m ω_m + a'_s θ̇
        T[9:12, 6] = a_s
    return T


def master_slave_project(model, q, v, w):
    """Replace each master/slave pair's velocities by ``T u``, ``(TᵀMT) u = TᵀM V``, in place
    (:func:`reference.joints.master_slave.master_slave_project`)."""
    ms, mass, inertia = model.master_slave, model.nodes.mass, model.nodes.inertia
    for k in range(ms.master.shape[0]):
        m, s = ms.master[k], ms.slave[k]
        T = _pair_matrix(model, k, q)
        M = np.zeros((12, 12))
        M[:3, :3], M[3:6, 3:6] = mass[m] * np.eye(3), inertia[m]
        M[6:9, 6:9], M[9:, 9:] = mass[s] * np.eye(3), inertia[s]
        V = np.concatenate([v[m], w[m], v[s], w[s]])
        u = np.linalg.solve(T.T @ M @ T, T.T @ (M @ V))
        V = T @ u
        v[m], w[m], v[s], w[s] = V[:3], V[3:6], V[6:9], V[9:]


def master_slave_positions(model, x, q):
    """Set each slave's dependent coordinates from its master, in place: ``x_s = x_m + A_m p'_m`` and, for a
    revolute pair, the slave turned by the smallest rotation taking its axis ``A_s a'_s`` onto the master's
    ``A_m a'_m`` (:func:`reference.joints.master_slave.master_slave_positions`)."""
    ms = model.master_slave
    product = plain(rm.quat_product)
    for k in range(ms.master.shape[0]):
        m, s = ms.master[k], ms.slave[k]
        par = ms.par[k]
        A_m, A_s = rotation_matrices(q[[m, s]])
        offset, axis_m, axis_s = plain(pair_parts)(par)
        x[s] = x[m] + A_m @ offset
        if ms.kind[k] == SPHERICAL:
            continue
        c, d = A_s @ axis_s, A_m @ axis_m
        r = np.concatenate([[1.0 + c @ d], np.cross(c, d)])
        out = np.empty(4)
        product(r / np.sqrt(r @ r), q[s].copy(), out)
        q[s] = out
