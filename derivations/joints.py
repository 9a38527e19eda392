"""Joint constraint equations and their velocity-level Jacobians, in sympy.

Every joint kind is assembled from a few **primitives** between body i and
body j (Nikravesh 1988, ch. 11; docs/formulation.md §5).  Each joint carries a joint
frame ``(u1, u2, u3)`` (u3 the joint axis) and a joint point P, given in the
inertial frame at t = 0 and stored body-fixed on both bodies: ``s'_k``,
``u'_{m,k}``.  With ``d = x_j + A_j s'_j − x_i − A_i s'_i`` and
``u_{m,k} = A_k u'_{m,k}`` the primitives are::

    row 0–2   spherical          d                      = 0
    row 3     dot-1              u1_i · u3_j             = 0
    row 4     dot-1              u2_i · u3_j             = 0
    row 5     dot-1              u1_i · u2_j             = 0   (locks rotation about u3)
    row 6     dot-2              u1_i · d                = 0
    row 7     dot-2              u2_i · d                = 0
    row 8     dot-2              u3_i · d                (sliding along u3)
    row 9     dot-1              u1_i · u1_j             (cosine of the rotation about u3)

Rows 5 and 9 are the sine and cosine of the rotation θ of body i relative to
body j about u3 (when the axes are aligned), ``θ = atan2(row 5, row 9)``.
Joint kinds select rows (``JOINT_ROWS``); the driving constraints combine rows
5, 8 and 9 with a time function at run time (``reference/joints``):
``Φ = row5 cos θ(t) − row9 sin θ(t) = sin(θ − θ(t))`` for a rotation drive,
``Φ = row8 + s(t)`` for a displacement drive: body i turns by +θ and slides by +s relative to
body j (one sign rule for both drives).  A prescribed displacement (body j the ground, whose frame is
inertial) weights the spherical rows by the ground-fixed u3: ``Φ = u3 · (rows 0–2) + s(t)``, the point
P_i moved by +s along a fixed inertial direction.

The velocity-level Jacobian ``B`` (columns ``[v_i | ω_i | v_j | ω_j]``, ω in
the body frames) is obtained **by differentiation**, not by hand: the
configuration is perturbed as ``x_k → x_k + δx_k``, ``A_k → A_k (I + δθ̃_k)``
(a body-frame rotation) and ``B = ∂Φ/∂(δx_i, δθ_i, δx_j, δθ_j)`` at zero, so
that ``Φ̇ = B [v_i, ω_i, v_j, ω_j]``.  :func:`generate` writes
``reference/generated/joints.py``.
"""

from __future__ import annotations

import sympy as sp

from derivations.codegen import Kernel, Stager, render_kernel, render_module, vector
from derivations.rotation_maps import USER_FUNCTIONS, rotation_matrix, skew

N_PRIMITIVES = 10
JOINT_ROWS = {
    "spherical": (0, 1, 2),
    "revolute": (0, 1, 2, 3, 4),
    "universal": (0, 1, 2, 5),
    "cylindrical": (3, 4, 6, 7),
    "translational": (3, 4, 5, 6, 7),
    "fixed": (0, 1, 2, 3, 4, 5),
}
"""Primitive rows of each joint kind (number of equations = len)."""


def primitives(xi, Ai, xj, Aj, si, sj, Ui, Uj):
    """The ten primitive constraint functions (see the module docstring)."""
    d = xj + Aj * sj - xi - Ai * si
    ui = [Ai * Ui[:, m] for m in range(3)]
    uj = [Aj * Uj[:, m] for m in range(3)]
    return [d[0], d[1], d[2],
            ui[0].dot(uj[2]), ui[1].dot(uj[2]), ui[0].dot(uj[1]),
            ui[0].dot(d), ui[1].dot(d), ui[2].dot(d),
            ui[0].dot(uj[0])]


def kernels() -> list[Kernel]:
    xi, xj = sp.Matrix(vector("xi", 3)), sp.Matrix(vector("xj", 3))
    qi, qj = vector("qi", 4), vector("qj", 4)
    si, sj = sp.Matrix(vector("si", 3)), sp.Matrix(vector("sj", 3))
    fi, fj = vector("fi", 9), vector("fj", 9)
    Ui, Uj = sp.Matrix(3, 3, fi), sp.Matrix(3, 3, fj)

    st = Stager()
    Ai = st.define("Ai", rotation_matrix(qi))
    Aj = st.define("Aj", rotation_matrix(qj))
    phi = primitives(xi, Ai, xj, Aj, si, sj, Ui, Uj)

    dxi, dti, dxj, dtj = (sp.Matrix(vector(n, 3)) for n in ("dxi", "dti", "dxj", "dtj"))
    perturbed = primitives(xi + dxi, Ai * (sp.eye(3) + skew(dti)), xj + dxj, Aj * (sp.eye(3) + skew(dtj)),
                           si, sj, Ui, Uj)
    zero = {s: 0 for s in list(dxi) + list(dti) + list(dxj) + list(dtj)}
    columns = list(dxi) + list(dti) + list(dxj) + list(dtj)
    B = [sp.diff(p, c).xreplace(zero) for p in perturbed for c in columns]
    return [
        Kernel(
            "joint_primitives",
            "The ten joint primitives Φ and their velocity Jacobian B (derivations/joints.py).\n\n"
            "    ``Φ̇ = B [v_i, ω_i, v_j, ω_j]`` with ω in the body frames; B is row-major (10 × 12).",
            [("xi", list(xi), "position of body i (inertial) [m]"),
             ("qi", qi, "Euler parameters of body i"),
             ("xj", list(xj), "position of body j [m]"),
             ("qj", qj, "Euler parameters of body j"),
             ("si", list(si), "joint point, body-fixed on i [m]"),
             ("sj", list(sj), "joint point, body-fixed on j [m]"),
             ("fi", fi, "joint frame on i: row-major 3×3 whose columns are u1', u2', u3' (body-fixed)"),
             ("fj", fj, "joint frame on j, likewise")],
            [("phi", phi, "the primitives (10,)"),
             ("B", B, "their Jacobian, row-major (10 × 12)")],
            None,
            st.stages,
        )
    ]


def generate() -> str:
    """Source of ``reference/generated/joints.py``."""
    rows = "\n".join(f"    {k!r}: {v!r}," for k, v in JOINT_ROWS.items())
    table = (f"N_PRIMITIVES = {N_PRIMITIVES}\n\n"
             f"JOINT_ROWS = {{\n{rows}\n}}\n"
             '"""Primitive rows that make each joint kind (see derivations/joints.py)."""\n')
    parts = [table] + [render_kernel(k, USER_FUNCTIONS) for k in kernels()]
    return render_module(
        "derivations/joints.py",
        "Joint constraint primitives and their velocity-level Jacobians.\n\n"
        "See derivations/joints.py for the equations; columns of B are [v_i | ω_i | v_j | ω_j].",
        parts,
    )
