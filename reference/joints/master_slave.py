"""Master/slave joints: elimination of the slave's dependent coordinates.

The paper promises this formulation as a second ``Joint_Formulation`` (§4.2.3).
For a spherical or revolute joint between a **master** body m (a rigid body or
any node) and a **slave** beam node s sitting at the joint point:

* positions: the slave's dependent coordinates are not integrated but set
  from the master after every drift, ``x_s = x_m + A_m p'_m``; for a revolute
  joint the slave's triad is also turned (by the smallest rotation) so that
  its axis ``A_s a'_s`` equals the master's ``A_m a'_m``;
* velocities: the pair moves with the reduced velocities ``u`` — the master's
  ``(v_m, ω_m)`` and the slave's free rotation rates (all three for a
  spherical joint, the rate θ̇ about the axis for a revolute one) —
  ``V = T u`` with::

      v_s = v_m − A_m p̃'_m ω_m
      ω_s = ω_s                              (spherical)
      ω_s = A_sᵀ A_m ω_m + a'_s θ̇            (revolute)

  and ``u`` solves the reduced equations of the step,
  ``(Tᵀ M T) u = Tᵀ M V*``, i.e. the predicted momenta of the pair projected
  onto the motions the joint allows (no multipliers).

Where a master also carries Lagrange-multiplier joints, the two stages
alternate inside the staggered step's constrained sweeps (an alternating
M-orthogonal projection, which converges to the joint projection).
"""

from __future__ import annotations

import math

import numpy as np

from reference.connector import body_matrix
from reference.generated import rotation_maps as rm
from reference.jit import inlined

SPHERICAL, REVOLUTE = 0, 1


@inlined
def pair_parts(par):
    """The parts of a pair's packed ``par`` (9,) (:class:`reference.state.MasterSlaveJoints`): the master's
    body-fixed offset ``p`` to the slave's node [m], the master's body-fixed axis and the slave's body-fixed
    axis (unit; a revolute pair's)."""
    return par[0:3], par[3:6], par[6:9]


@inlined
def _pair_matrices(model, k, q, T, A_m, A_s):
    """Fill ``T`` (12 × d) for pair k at Euler parameters ``q``; return d."""
    m, s = model.master_slave.master[k], model.master_slave.slave[k]
    p, _, axis_s = pair_parts(model.master_slave.par[k])
    rm.rotation_matrix(q[m], A_m)
    rm.rotation_matrix(q[s], A_s)
    T[:, :] = 0.0
    for a in range(6):
        T[a, a] = 1.0
    for a in range(3):
        T[6 + a, a] = 1.0
    # −A_m p̃ ω_m: column b of −A_m p̃ is −A_m (p × e_b) = A_m (e_b × p)... written out:
    p0, p1, p2 = p[0], p[1], p[2]
    for r in range(3):
        # (A_m p̃)[r, :] = A_m[r, :] @ p̃ with p̃ = [[0,-p2,p1],[p2,0,-p0],[-p1,p0,0]]
        a0, a1, a2 = A_m[3 * r], A_m[3 * r + 1], A_m[3 * r + 2]
        T[6 + r, 3] = -(a1 * p2 - a2 * p1)
        T[6 + r, 4] = -(-a0 * p2 + a2 * p0)
        T[6 + r, 5] = -(a0 * p1 - a1 * p0)
    if model.master_slave.kind[k] == SPHERICAL:
        for a in range(3):
            T[9 + a, 6 + a] = 1.0
        return 9
    # revolute: ω_s = A_sᵀ A_m ω_m + a'_s θ̇
    for r in range(3):
        for c in range(3):
            acc = 0.0
            for l in range(3):
                acc += A_s[3 * l + r] * A_m[3 * l + c]
            T[9 + r, 3 + c] = acc
        T[9 + r, 6] = axis_s[r]
    return 7


@inlined
def master_slave_project(model, q, v, w, T, A_m, A_s, MT, TMT, rhs):
    """Replace each pair's velocities by ``T u``, ``(TᵀMT) u = TᵀM V`` (in place)."""
    for k in range(model.master_slave.master.shape[0]):
        m, s = model.master_slave.master[k], model.master_slave.slave[k]
        d = _pair_matrices(model, k, q, T, A_m, A_s)
        # MT = M T (12 × d); M = diag(m_m I, J_m, m_s I, J_s)
        for c in range(d):
            for a in range(3):
                MT[a, c] = model.nodes.mass[m] * T[a, c]
                MT[6 + a, c] = model.nodes.mass[s] * T[6 + a, c]
            for a in range(3):
                acc_m = 0.0
                acc_s = 0.0
                for b in range(3):
                    acc_m += model.nodes.inertia[m, a, b] * T[3 + b, c]
                    acc_s += model.nodes.inertia[s, a, b] * T[9 + b, c]
                MT[3 + a, c] = acc_m
                MT[9 + a, c] = acc_s
        for r in range(d):
            acc = 0.0
            for a in range(3):
                acc += MT[a, r] * v[m, a] + MT[3 + a, r] * w[m, a] + MT[6 + a, r] * v[s, a] + MT[9 + a, r] * w[s, a]
            rhs[r] = acc
            for c in range(d):
                acc = 0.0
                for a in range(12):
                    acc += T[a, r] * MT[a, c]
                TMT[r, c] = acc
        # solve the small SPD system by Gaussian elimination (d ≤ 9)
        for col in range(d):
            piv = TMT[col, col]
            for r in range(col + 1, d):
                f = TMT[r, col] / piv
                for c in range(col, d):
                    TMT[r, c] -= f * TMT[col, c]
                rhs[r] -= f * rhs[col]
        for r in range(d - 1, -1, -1):
            acc = rhs[r]
            for c in range(r + 1, d):
                acc -= TMT[r, c] * rhs[c]
            rhs[r] = acc / TMT[r, r]
        for a in range(3):
            v[m, a] = rhs[a]
            w[m, a] = rhs[3 + a]
        for a in range(3):
            vs = 0.0
            ws = 0.0
            for c in range(d):
                vs += T[6 + a, c] * rhs[c]
                ws += T[9 + a, c] * rhs[c]
            v[s, a] = vs
            w[s, a] = ws


@inlined
def master_slave_positions(model, x, q, A_m, A_s, q_tmp, r):
    """Set each slave's dependent coordinates from its master (after the drift)."""
    for k in range(model.master_slave.master.shape[0]):
        m, s = model.master_slave.master[k], model.master_slave.slave[k]
        p, axis_m, axis_s = pair_parts(model.master_slave.par[k])
        rm.rotation_matrix(q[m], A_m)
        for a in range(3):
            x[s, a] = x[m, a] + A_m[3 * a] * p[0] + A_m[3 * a + 1] * p[1] + A_m[3 * a + 2] * p[2]
        if model.master_slave.kind[k] != REVOLUTE:
            continue
        rm.rotation_matrix(q[s], A_s)
        c0 = A_s[0] * axis_s[0] + A_s[1] * axis_s[1] + A_s[2] * axis_s[2]
        c1 = A_s[3] * axis_s[0] + A_s[4] * axis_s[1] + A_s[5] * axis_s[2]
        c2 = A_s[6] * axis_s[0] + A_s[7] * axis_s[1] + A_s[8] * axis_s[2]
        d0 = A_m[0] * axis_m[0] + A_m[1] * axis_m[1] + A_m[2] * axis_m[2]
        d1 = A_m[3] * axis_m[0] + A_m[4] * axis_m[1] + A_m[5] * axis_m[2]
        d2 = A_m[6] * axis_m[0] + A_m[7] * axis_m[1] + A_m[8] * axis_m[2]
        # the smallest rotation taking c to d: Euler parameters ∝ (1 + c·d, c × d)
        r[0] = 1.0 + c0 * d0 + c1 * d1 + c2 * d2
        r[1] = c1 * d2 - c2 * d1
        r[2] = c2 * d0 - c0 * d2
        r[3] = c0 * d1 - c1 * d0
        nrm = math.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2 + r[3] ** 2)
        for a in range(4):
            r[a] /= nrm
        rm.quat_product(r, q[s], q_tmp)
        for a in range(4):
            q[s, a] = q_tmp[a]


def master_slave_parameters(joint) -> np.ndarray:
    """``[p'_m (3), a'_m (3), a'_s (3)]`` of a master/slave joint (master = body_j)."""
    master, slave = joint.body_j, joint.body_i
    Am, As = body_matrix(master), body_matrix(slave)
    axis = joint.frame[:, 2]
    return np.concatenate([Am.T @ (joint.point - master.position), Am.T @ axis, As.T @ axis])
