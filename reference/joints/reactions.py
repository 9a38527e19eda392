"""Joint reactions from the Lagrange multipliers (an output, computed per output record).

With the equations of motion ``M a + Bᵀ λ = Q`` (``reference/joints/assembly.py``)
the constraint forces on the nodes are ``−Bᵀ λ``.  B's columns are
``[v (inertial) | ω (body frame)]`` per node, so for joint k with rows
``r0 … r0+m−1`` and body i the generalised force on body i is

    F_i = −B_{k,v_i}ᵀ λ_k      (inertial force at the node x_i)  [N]
    M_i = −B_{k,ω_i}ᵀ λ_k      (moment about x_i, body-frame components)  [N m]

The reaction of the joint on body i, reduced to the joint point
``P_i = x_i + A_i s_i`` (s_i the body-fixed offset), in inertial components:

    force  = F_i
    moment = A_i M_i − (A_i s_i) × F_i

A drive is a joint of one row: its reaction moment (rotation drive) lies along
the drive axis and is the driving torque; a displacement drive's force lies
along the axis and is the driving force.  The reaction on body j is the
opposite force and, about the same point, the opposite moment (Newton's third
law; ``B_j`` is the negative of ``B_i`` up to the lever arm).

The computation depends only on the configuration, the multipliers and the
time — ``(model, x, q, λ, t)`` — not on the algorithm that produced λ, as long
as λ follows the convention above.  Joints eliminated by master/slave have no
multipliers; their reactions are not computed (NaN in the results file).
"""

from __future__ import annotations

import numpy as np

from reference.connector import body_fixed_parts
from reference.generated import rotation_maps as rm
from reference.jit import kernel
from reference.joints.assembly import joint_rows


@kernel
def joint_reactions(model, x, q, lam, t, slot, force, moment, work):
    """Reactions of the multiplier joints on their body i, about the joint point, inertial.

    Parameters
    ----------
    model : Model
    x : array (N, 3), q : array (N, 4)
        Configuration.
    lam : array (m,)
        Lagrange multipliers (``M a + Bᵀλ = Q``).
    t : float
        Time (drives' rows depend on it).
    slot : int array (J,)
        Row of ``force``/``moment`` that receives multiplier joint k (``model.joints`` order).
    force, moment : arrays (≥ J, 3), written at the rows ``slot`` [N], [N m].
    work : tuple
        The scratch of :func:`scratch`: ``jphi, jB, jphit, prim_phi, prim_B, A`` (6,), (6, 12), (6,), (10,),
        (120,), (9,).
    """
    jphi, jB, jphit, prim_phi, prim_B, A = work
    for k in range(model.joints.i.shape[0]):
        m = model.joints.neq[k]
        r0 = model.joints.row0[k]
        i, j = model.joints.i[k], model.joints.j[k]
        tf = model.joints.tf[k]
        par = model.joints.par[k]
        joint_rows(x, q, i, j, par, model.joints.rows[k], model.joints.drive[k], model.time_functions.kind[tf], model.time_functions.par[tf], t,
                   jphi[:m], jB[:m], jphit[:m], prim_phi, prim_B)
        F0 = F1 = F2 = 0.0
        M0 = M1 = M2 = 0.0
        for r in range(m):
            lr = lam[r0 + r]
            F0 -= jB[r, 0] * lr
            F1 -= jB[r, 1] * lr
            F2 -= jB[r, 2] * lr
            M0 -= jB[r, 3] * lr
            M1 -= jB[r, 4] * lr
            M2 -= jB[r, 5] * lr
        rm.rotation_matrix(q[i], A)
        s_i = body_fixed_parts(par)[0]
        d0 = A[0] * s_i[0] + A[1] * s_i[1] + A[2] * s_i[2]
        d1 = A[3] * s_i[0] + A[4] * s_i[1] + A[5] * s_i[2]
        d2 = A[6] * s_i[0] + A[7] * s_i[1] + A[8] * s_i[2]
        o = slot[k]
        force[o, 0], force[o, 1], force[o, 2] = F0, F1, F2
        moment[o, 0] = A[0] * M0 + A[1] * M1 + A[2] * M2 - (d1 * F2 - d2 * F1)
        moment[o, 1] = A[3] * M0 + A[4] * M1 + A[5] * M2 - (d2 * F0 - d0 * F2)
        moment[o, 2] = A[6] * M0 + A[7] * M1 + A[8] * M2 - (d0 * F1 - d1 * F0)


def scratch() -> tuple:
    """Work arrays of :func:`joint_reactions` (allocate once, reuse for every output)."""
    return np.zeros(6), np.zeros((6, 12)), np.zeros(6), np.zeros(10), np.zeros(120), np.zeros(9)


def reactions(model, x, q, lam, t: float):
    """Plain-Python face of :func:`joint_reactions`: ``(force, moment)`` arrays (J, 3)."""
    J = model.joints.i.shape[0]
    force, moment = np.zeros((J, 3)), np.zeros((J, 3))
    joint_reactions(model, np.asarray(x, dtype=float), np.asarray(q, dtype=float), np.asarray(lam, dtype=float),
                    float(t), np.arange(J), force, moment, scratch())
    return force, moment
