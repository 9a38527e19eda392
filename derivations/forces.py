"""Force-element measures, their velocity Jacobians and their tangents, in sympy.

A force element (``reference/forces.py``) between body i and body j (or the
ground) is described by one or six **measures** ``e(x_i, A_i, x_j, A_j)``;
points ``s'`` and frames ``U' = [u1' u2' u3']`` are stored body-fixed on both
bodies as for a joint (``derivations/joints.py``), ``d = x_j + A_j s'_j − x_i − A_i s'_i``,
``u_{m,k} = A_k u'_{m,k}`` and ``R_ab = u_a,i · u_b,j`` (the rotation of j
relative to i in i's frame)::

    point_to_point   d (three components, inertial): the engine takes ℓ = |d| and its
                     derivatives by the chain rule (no square root to differentiate here)
    rotational       (u1_i · u2_j, u1_i · u1_j) = r (sin φ, cos φ): the engine takes
                     φ = atan2 of the two (the rotation drive's angle) and its
                     derivatives by the chain rule (cheaper than deriving atan2 here)
    bushing          (u1_i·d, u2_i·d, u3_i·d, ½(R32 − R23), ½(R13 − R31), ½(R21 − R12))

The bushing's rotation measure is the axial vector of the skew part of R,
``sin|θ| θ/|θ|`` for a rotation vector θ: equal to θ up to third order, and
symmetric in the three axes.

As for the joints, derivatives are taken along the body-frame perturbation
``x_k → x_k + δx_k``, ``A_k → A_k (I + δθ̃_k)``:

* ``B = ∂e/∂(δx_i, δθ_i, δx_j, δθ_j)`` at zero (``ė = B V``, V = [v_i, ω_i, v_j, ω_j]);
* the **tangent** ``G_r[a, c] = ∂B_r[a]/∂δ_c``: the change of row r of B when the
  configuration is perturbed along column c.  The generalised force of the
  element is ``f = −Bᵀ s`` with ``s = k (e − e0) + c B V``, so its stiffness
  (∂(−f)/∂δ, body-frame increments) is ``Bᵀ K B + Σ_r s_r G_r`` and its
  damping matrix ``Bᵀ C B``; an implicit algorithm assembles these blocks.
"""

from __future__ import annotations

import sympy as sp

from derivations.codegen import Kernel, Stager, render_kernel, render_module, vector
from derivations.rotation_maps import USER_FUNCTIONS, rotation_matrix, skew

INPUTS = [("xi", "position of body i (inertial) [m]"),
          ("qi", "Euler parameters of body i"),
          ("xj", "position of body j [m]"),
          ("qj", "Euler parameters of body j"),
          ("si", "attachment point, body-fixed on i [m]"),
          ("sj", "attachment point, body-fixed on j [m]"),
          ("fi", "element frame on i: row-major 3×3 whose columns are u1', u2', u3' (body-fixed)"),
          ("fj", "element frame on j, likewise")]


def measures(kind, xi, Ai, xj, Aj, si, sj, Ui, Uj):
    """The measures of one kind (see the module docstring)."""
    d = xj + Aj * sj - xi - Ai * si
    ui = [Ai * Ui[:, m] for m in range(3)]
    uj = [Aj * Uj[:, m] for m in range(3)]
    if kind == "point_to_point":
        return [d[0], d[1], d[2]]
    if kind == "rotational":
        return [ui[0].dot(uj[1]), ui[0].dot(uj[0])]
    R = [[ui[a].dot(uj[b]) for b in range(3)] for a in range(3)]
    return [ui[0].dot(d), ui[1].dot(d), ui[2].dot(d),
            (R[2][1] - R[1][2]) / 2, (R[0][2] - R[2][0]) / 2, (R[1][0] - R[0][1]) / 2]


def kernels() -> list[Kernel]:
    xi, xj = sp.Matrix(vector("xi", 3)), sp.Matrix(vector("xj", 3))
    qi, qj = vector("qi", 4), vector("qj", 4)
    si, sj = sp.Matrix(vector("si", 3)), sp.Matrix(vector("sj", 3))
    fi, fj = vector("fi", 9), vector("fj", 9)
    Ui, Uj = sp.Matrix(3, 3, fi), sp.Matrix(3, 3, fj)
    inputs = [(n, v, doc) for (n, doc), v in zip(INPUTS, (list(xi), qi, list(xj), qj, list(si), list(sj), fi, fj))]
    d1 = [sp.Matrix(vector(n, 3)) for n in ("dxi", "dti", "dxj", "dtj")]
    cols = [s for v in d1 for s in v]
    zero = {s: 0 for s in cols}
    out = []
    for kind in ("point_to_point", "rotational", "bushing"):
        st = Stager()
        Ai = st.define("Ai", rotation_matrix(qi))
        Aj = st.define("Aj", rotation_matrix(qj))
        e = measures(kind, xi, Ai, xj, Aj, si, sj, Ui, Uj)
        m = len(e)
        once = measures(kind, xi + d1[0], Ai * (sp.eye(3) + skew(d1[1])), xj + d1[2], Aj * (sp.eye(3) + skew(d1[3])),
                        si, sj, Ui, Uj)
        B = [sp.diff(p, c).xreplace(zero) for p in once for c in cols]
        out.append(Kernel(
            f"{kind}_measures",
            f"Measures e of a {kind.replace('_', '-')} force element and their velocity Jacobian B "
            "(derivations/forces.py).\n\n"
            f"    ``ė = B [v_i, ω_i, v_j, ω_j]`` with ω in the body frames; B is row-major ({m} × 12).",
            inputs, [("e", e, f"the measures ({m},)"), ("B", B, f"their Jacobian, row-major ({m} × 12)")],
            None, st.stages))
        # G: the directional derivatives of B's entries (functions of x_k and of the symbols A_k)
        # along δx_k and along A_k → A_k (I + δθ̃_k), i.e. ∂/∂δθ_c = Σ ∂/∂A_k[p,q] (A_k ẽ_c)[p,q]
        directions = []
        for x_k, A_k in ((xi, Ai), (xj, Aj)):
            directions += [{x_k[c]: 1} for c in range(3)]
            directions += [{A_k[p, q]: (A_k * skew(sp.eye(3)[:, c]))[p, q] for p in range(3) for q in range(3)}
                           for c in range(3)]
        G = []
        for entry in B:
            for direction in directions:
                G.append(sum((sp.diff(entry, sym) * rate for sym, rate in direction.items()), sp.Integer(0)))
        st2 = Stager()
        st2.stages = list(st.stages)
        out.append(Kernel(
            f"{kind}_tangent",
            f"Tangent G of the {kind.replace('_', '-')} measures' Jacobian (derivations/forces.py).\n\n"
            f"    ``G[r, a, c] = ∂B[r, a]/∂δ_c`` along body-frame increments δ = [δx_i, δθ_i, δx_j, δθ_j];\n"
            f"    row-major ({m} × 12 × 12).",
            inputs, [("G", G, f"({m} × 12 × 12), row-major")], None, st2.stages))
    return out


def generate() -> str:
    """Source of ``reference/generated/forces.py``."""
    return render_module(
        "derivations/forces.py",
        "Force-element measures, their velocity Jacobians and tangents.\n\n"
        "See derivations/forces.py for the equations; columns are [v_i | ω_i | v_j | ω_j].",
        [render_kernel(k, USER_FUNCTIONS) for k in kernels()],
    )
