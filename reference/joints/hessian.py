"""Geometric stiffness of the joints: the λ-weighted constraint Hessian, per joint.

For Newton's method on ``M a + S + Bᵀλ = F, Φ = 0`` the joint forces ``Bᵀλ``
depend on the configuration through ``B``; their derivative at fixed λ,

    K_c = ∂(Bᵀλ)/∂[δx_i, δθ_i, δx_j, δθ_j]   (12 × 12, x → x + ε δx, q → q ⊗ exp(ε δθ)),

is the joint's geometric stiffness (docs/tangents.md).  A joint's row r uses
primitive ``rows[r]`` (``reference/generated/joints.py``), so
``K_c = Σ_p w_p H_p`` with the weight ``w_p`` the multiplier of the row that uses
primitive p; a rotation drive's row is ``row5 cos θ(t) − row9 sin θ(t)``
(weights ``λ cos θ``, ``−λ sin θ``), a displacement drive's row is ``row8 + s(t)``, a prescribed
displacement's ``u · rows 0–2 + s(t)`` (weights ``λ u``, u the inertial direction).
The weighted sum of the primitive Hessians is the generated
``tangents.joint_primitive_hessian``.  With the ground (``j = −1``) the rows and
columns of body j are zero.
"""

from __future__ import annotations

import math

from reference.connector import body_fixed_parts
from reference.generated import tangents as generated
from reference.interactions import tf_integral, tf_value
from reference.jit import kernel
from reference.joints.assembly import GROUND_Q, GROUND_X, joint_rows


@kernel
def primitive_weights(par, rows, drive, tf_kind, tf_par, t, lam, w):
    """Weights ``w`` (10,) of the primitives for the joint multipliers ``lam`` (m,).

    ``par``, ``rows``, ``drive``, ``tf_kind``, ``tf_par``, ``t`` as in
    :func:`reference.joints.assembly.joint_rows`.
    """
    w[:] = 0.0
    if drive == 0:
        for r in range(lam.shape[0]):
            w[rows[r]] += lam[r]
    elif drive <= 2:
        th = tf_value(tf_kind, tf_par, t) if drive == 1 else tf_integral(tf_kind, tf_par, t)
        w[5] = lam[0] * math.cos(th)
        w[9] = -lam[0] * math.sin(th)
    elif drive <= 4:
        w[8] = lam[0]
    else:
        f_j = body_fixed_parts(par)[3]  # u3, its last column: the ground's frame, inertial
        w[0], w[1], w[2] = lam[0] * f_j[2], lam[0] * f_j[5], lam[0] * f_j[8]


@kernel
def joint_rows_hessian(x, q, i, j, par, rows, drive, tf_kind, tf_par, t, lam, phi, B, phit, H,
                       prim_phi, prim_B, w):
    """Rows of one joint and its λ-weighted Hessian (geometric stiffness).

    Parameters
    ----------
    x, q : arrays (N, 3), (N, 4)
        Node positions [m] and Euler parameters.
    i, j : int
        Body indices (``j = -1``: the ground).
    par : array (24,)
        ``[s_i, s_j, f_i (9), f_j (9)]`` body-fixed point and frames (``Joint.body_fixed``).
    rows : int array (6,)
        Primitive rows of the joint kind (``-1`` padded).
    drive : int
        0 none, 1/2 rotation drive (θ = f(t) / ∫f), 3/4 displacement drive, 5 prescribed displacement.
    tf_kind, tf_par, t
        The drive's time function and the time [s].
    lam : array (m,)
        The joint's multipliers (reaction forces [N] / moments [N m] per row).
    phi, B, phit : arrays (m,), (m, 12), (m,), written
        As :func:`reference.joints.assembly.joint_rows`.
    H : array (12, 12), C-contiguous, written
        ``∂(Bᵀλ)/∂[δx_i, δθ_i, δx_j, δθ_j]`` at fixed λ (units of λ times those of B per
        length or angle).
    prim_phi, prim_B, w : arrays (10,), (120,), (10,)
        Scratch.

    Takes 18 parameters: those of :func:`reference.joints.assembly.joint_rows` with λ, the Hessian H and its scratch
    w.
    """
    joint_rows(x, q, i, j, par, rows, drive, tf_kind, tf_par, t, phi, B, phit, prim_phi, prim_B)
    primitive_weights(par, rows, drive, tf_kind, tf_par, t, lam, w)
    Hf = H.reshape(144)
    xj, qj = GROUND_X, GROUND_Q  # one type for both branches: the generated kernel compiles once
    if j >= 0:
        xj, qj = x[j], q[j]
    s_i, s_j, f_i, f_j = body_fixed_parts(par)
    generated.joint_primitive_hessian(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, w, Hf)
    if j < 0:
        for a in range(12):
            for b in range(6, 12):
                H[a, b] = 0.0
                H[b, a] = 0.0
