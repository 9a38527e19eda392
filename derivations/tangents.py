"""Tangent matrices (the element matrices of Newton's method), in sympy.

Every tangent here is the exact derivative of a generated force or constraint
with respect to the **perturbation variables** ``[δx_a, δθ_a]`` of the nodes
(or bodies) it touches, under

    x_a → x_a + ε δx_a,        q_a → q_a ⊗ exp(ε δθ_a)

(δθ_a a *body-frame* rotation increment: exactly how the integrators update
rotations — the explicit scheme's Cayley factor, the implicit schemes'
``q ⊗ exp(Δθ)``).  ``K = ∂f/∂[δx_1, δθ_1, …]`` at ε = 0.  It is the
derivative of the force *vector* along this perturbation, which is what a
Newton iteration on the incremental rotations needs; because SO(3) is not a
vector space it is not symmetric: for a gradient ``f`` of a potential (the
beam's S, the joints' Bᵀλ) ``K − Kᵀ = blockdiag(0, f̃_θ1, 0, f̃_θ2)`` exactly
(docs/tangents.md).

Beam2 tangent stiffness (material + geometric)
----------------------------------------------
The internal forces of ``derivations/beam2.py`` are functions of ``x1, x2``,
``A1`` and the relative rotation ``ψ = log(A1ᵀA2)``.  Their variations
(derived in that module's docstring, with ``R = exp(ψ̃)``, ``E = exp(ψ̃/2)``,
``Am = A1 E``, ``J = J_r(ψ)``, ``Jh = J_r(ψ/2)``)::

    δψ  = J⁻¹ (δθ2 − Rᵀ δθ1)                       so that  J δψ = δθ2 − Rᵀ δθ1
    δθm = Eᵀ δθ1 + ½ Jh δψ                          (midpoint triad, δAm = Am δθ̃m)
    δE  = E (½ Jh δψ)~,   δR = R (J δψ)~

Differentiating each staged quantity of the force kernel along them (the
chain rule written out by hand; every factor is a 3 × 9 matrix over the columns
``[δθ1, δu, δθ2]``, ``δu = δx2 − δx1``, since S depends on ``x2 − x1`` only,
expanded to the twelve columns at the end)::

    δγ̂  = Amᵀ (δx2 − δx1)/L0 + γ̂~ δθm            δN = C_Γ δγ̂,   δM = C_K δψ/L0
    δf  = L0 (N~ δγ̂ − γ̂~ δN)
    δg  = δM + ½ D_h δψ + ½ Jhᵀ δf                  D_h = ∂(Jhᵀ f)/∂ψ |_f
    δS_θ2 = D_i δψ + J⁻ᵀ δg                          D_i = ∂(J⁻ᵀ g)/∂ψ |_g
    δS_θ1 = −½ E f~ Jh δψ + E δf + R S_θ2~ J δψ − R δS_θ2
    δS_u2 = −δS_u1 = −Am N~ δθm + Am δN

The only derivatives sympy takes are ``D_h`` and ``D_i`` (3×3 each): those of
the coefficient functions ``c(a)`` of the SO(3) Jacobians, through the derived
coefficients ``c_d(a) = c'(a)/a`` (smooth and even, emitted with the same
series/closed-form switch as the originals), so that
``∂c(|ψ|)/∂ψ = c_d(|ψ|) ψ`` has no division by |ψ|.  ``tests/test_tangents.py``
checks the result against central differences of the generated
``internal_forces`` under the perturbation above.

**Section frame vs node frame.** The kernel's ``q1, q2`` are the section
triads.  With constant element-end offsets ``o_a`` (node → section frame,
``p_a = q_a ⊗ o_a``, ``S_θ,node = A(o_a) S_θ,sec``), a node-frame increment is
``δθ_sec = A(o_a)ᵀ δθ_node``, hence ``K_node = T K_sec Tᵀ`` with
``T = blockdiag(I, A(o1), I, A(o2))``.

:func:`generate` writes ``reference/generated/tangents.py``.
"""

from __future__ import annotations

import sympy as sp

from derivations.beam2 import beam2_quantities, kernel_arguments
from derivations.joints import N_PRIMITIVES, primitives
from derivations.codegen import Coefficient, Kernel, Stager, render_coefficient, render_kernel, render_module, vector
from derivations.rotation_maps import (
    COEFFICIENTS,
    USER_FUNCTIONS,
    C,
    right_jacobian,
    right_jacobian_inverse,
    rotation_matrix,
    skew,
)

a = sp.Symbol("a")

_ORIGINAL = {c.name: c for c in COEFFICIENTS}
DIFFERENTIATED = ("c_cosc", "c_sinc3", "c_jinv")
"""Coefficient functions whose derivative the tangents need."""

DERIVATIVE_COEFFICIENTS = [
    Coefficient(
        f"{name}_d",
        sp.simplify(sp.diff(_ORIGINAL[name].expr, a) / a),
        f"{name}'(a)/a (smooth, even): ∂{name}(|ψ|)/∂ψ = {name}_d(|ψ|) ψ.",
        threshold=2.0,
        order=40,
    )
    for name in DIFFERENTIATED
]
"""``c'(a)/a`` of the coefficients above.  The closed forms cancel (c_jinv_d loses 2e-13 just
above a = 1), so the series is used up to a = 2 (the series of c_jinv_d converges for a < 2π,
ratio (a/2π)² ≈ 0.1 per term at a = 2).  Against 40-digit references: ≤ 2.3e-16 relative on the
series side, ≤ 5.5e-15 on the closed-form side up to a = π."""
D = {name: sp.Function(f"{name}_d") for name in DIFFERENTIATED}
TANGENT_USER_FUNCTIONS = USER_FUNCTIONS + [c.name for c in DERIVATIVE_COEFFICIENTS]


def _differentiable(name):
    """A sympy function printed as ``name`` whose derivative is ``a · name_d(a)``."""

    def fdiff(self, argindex=1):
        arg = self.args[0]
        return arg * D[name](arg)

    return type(name, (sp.Function,), {"fdiff": fdiff})


_DIFFERENTIABLE = {C[name]: _differentiable(name) for name in DIFFERENTIATED}


def jacobian(vec: sp.Matrix, wrt) -> sp.Matrix:
    """``∂vec/∂wrt`` with the coefficient functions differentiated through ``c_d``."""
    for undefined, differentiable in _DIFFERENTIABLE.items():
        vec = vec.replace(undefined, differentiable)
    J = vec.jacobian(sp.Matrix(wrt))
    for undefined, differentiable in _DIFFERENTIABLE.items():
        J = J.replace(differentiable, undefined)
    return J


def stage_sparse(st: Stager, name: str, M: sp.Matrix) -> sp.Matrix:
    """Stage the distinct non-trivial entries of ``M`` (each once, up to sign).

    Exact zeros stay zeros, entries that are ``±`` a symbol are used as they are, and
    repeated entries (a symmetric Hessian, a negated block) share one staged symbol.
    """
    M = sp.Matrix(M)
    out = sp.zeros(*M.shape)
    unique, where = [], {}
    for k, e in enumerate(M):
        if e == 0 or e.is_Symbol or (-e).is_Symbol:
            out[k // M.shape[1], k % M.shape[1]] = e
            continue
        if e in where:
            where[e][1].append((k, 1))
        elif -e in where:
            where[-e][1].append((k, -1))
        else:
            where[e] = (len(unique), [(k, 1)])
            unique.append(e)
    if unique:
        syms = st.define(name, unique)
        for e, (u, uses) in where.items():
            for k, sign in uses:
                out[k // M.shape[1], k % M.shape[1]] = sign * syms[u]
    return out


def _stage_symbols(stages, prefix, shape):
    """The symbols ``prefix_0 …`` defined by an earlier stage, as a matrix."""
    for syms, _ in stages:
        if syms and syms[0].name == f"{prefix}_0":
            return sp.Matrix(shape[0], shape[1], list(syms))
    raise KeyError(prefix)


def beam2_tangent():
    """Inputs of the Beam2 kernel, its forces S (12) and tangent K (12 × 12), and the stages."""
    inp, out, stages = beam2_quantities()
    st = Stager()
    st.stages = list(stages)
    psi = _stage_symbols(stages, "psi", (3, 1))
    E = _stage_symbols(stages, "E", (3, 3))
    R = _stage_symbols(stages, "R", (3, 3))
    Am = _stage_symbols(stages, "Am", (3, 3))
    gh = _stage_symbols(stages, "gh", (3, 1))
    N = _stage_symbols(stages, "N", (3, 1))
    f = _stage_symbols(stages, "f", (3, 1))
    g = _stage_symbols(stages, "g", (3, 1))
    st2 = _stage_symbols(stages, "st2", (3, 1))
    L0 = inp["L0"]
    c = inp["c"]
    CG, CK = sp.diag(*c[:3]), sp.diag(*c[3:])
    Z, I = sp.zeros(3, 3), sp.eye(3)

    Jinv_expr = right_jacobian_inverse(psi)
    Jh_expr = right_jacobian(psi / 2)
    Jinv = st.define("Ji", Jinv_expr)
    Jh = st.define("Jh", Jh_expr)
    dpsi1 = st.define("dps1", -Jinv * R.T)
    dpsi = sp.Matrix.hstack(dpsi1, Z, Jinv)
    Jdpsi = sp.Matrix.hstack(-R.T, Z, I)
    dthm = stage_sparse(st, "dthm", sp.Matrix.hstack(E.T + Jh * dpsi1 / 2, Z, Jh * Jinv / 2))
    dgh = stage_sparse(st, "dgh", sp.Matrix.hstack(Z, Am.T / L0, Z) + skew(gh) * dthm)
    dN = CG * dgh
    dM = CK * dpsi / L0
    df = stage_sparse(st, "df", L0 * (skew(N) * dgh - skew(gh) * dN))
    Dh = st.define("Dh", jacobian(Jh_expr.T * f, psi))
    dg = stage_sparse(st, "dg", dM + (Dh * dpsi + Jh.T * df) / 2)
    Di = st.define("Di", jacobian(Jinv_expr.T * g, psi))
    dst2 = stage_sparse(st, "dst2", Di * dpsi + Jinv.T * dg)
    dst1 = stage_sparse(st, "dst1", -E * skew(f) * Jh * dpsi / 2 + E * df + R * skew(st2) * Jdpsi - R * dst2)
    dn = stage_sparse(st, "dn", Am * (dN - skew(N) * dthm))
    K9 = sp.Matrix.vstack(-dn, dst1, dn, dst2)
    K = sp.Matrix.hstack(-K9[:, 3:6], K9[:, 0:3], K9[:, 3:6], K9[:, 6:9])
    return inp, out["S"], K, st.stages


def beam2_kernel() -> Kernel:
    inp, S, K, stages = beam2_tangent()
    args = kernel_arguments(inp)
    return Kernel(
        "beam2_tangent",
        "Beam2 internal forces S and tangent stiffness K = ∂S/∂[δx1, δθ1, δx2, δθ2] (derivations/tangents.py).\n\n"
        "    Same inputs and the same ``s`` as ``beam2.internal_forces``.  ``K`` (12 × 12, row-major) is\n"
        "    material + geometric stiffness, the exact derivative of ``s`` under ``x_a → x_a + ε δx_a``,\n"
        "    ``q_a → q_a ⊗ exp(ε δθ_a)`` (body-frame increments of the section triads).  Rows and\n"
        "    columns are ordered [u1 (inertial), θ1 (body 1), u2, θ2].  Node-frame tangent with\n"
        "    element-end offsets o_a (section = node ⊗ o_a): ``T K Tᵀ``, T = blockdiag(I, A(o1), I, A(o2)).\n"
        "    Units: N/m, N, N m (force/length, force/angle or moment/length, moment/angle blocks).",
        args,
        [("s", list(S), "internal forces [S_u1, S_θ1, S_u2, S_θ2] (12,)"),
         ("K", list(K), "tangent stiffness ∂s/∂[δx1, δθ1, δx2, δθ2], row-major (12 × 12)")],
        None,
        stages,
    )


def joint_hessian():
    """Inputs of the joint primitives, weights w (10) and ``H = ∂(Σ_p w_p B_pᵀ)/∂η`` (12 × 12).

    ``B_p`` at a configuration already perturbed by ``η`` is the first-order term in
    ``δ`` of ``Φ_p(x + η_x + δ_x, A exp(η̃) (I + δ̃))``; so ``H_ab`` is the mixed second
    derivative ``∂²Φ/∂δ_a ∂η_b`` of ``Φ(x + εη_x + τδ_x, A (I + εη̃)(I + τδ̃))`` at zero.
    The primitives depend on the positions only through ``Δ = x_j − x_i``, so the
    derivatives are taken in the nine variables ``v = [δθ_i, δΔ, δθ_j]`` and expanded to
    the twelve at the end (``H = Pᵀ H_v P``, P the 9 × 12 map with ``δΔ = δx_j − δx_i``).
    With the raw coordinates ``z = (A_i, Δ, A_j)`` (21: the rotation matrices' entries)
    and ``T = ∂z/∂v`` (columns ``vec(A ẽ_c)`` for δθ, ``e_c`` for δΔ), the chain rule
    gives::

        H_v = Tᵀ (∂²Φ_w/∂z²) T + [∂Φ_w/∂z · vec(A ẽ_b ẽ_a)]_ab      (a, b rotations of one body)

    with ``Φ_w = Σ_p w_p Φ_p``: the only derivatives sympy takes are those of the
    polynomials ``Φ_p`` with respect to plain symbols, which keeps the derivation fast.
    """
    xi, xj = sp.Matrix(vector("xi", 3)), sp.Matrix(vector("xj", 3))
    qi, qj = vector("qi", 4), vector("qj", 4)
    si, sj = sp.Matrix(vector("si", 3)), sp.Matrix(vector("sj", 3))
    fi, fj = vector("fi", 9), vector("fj", 9)
    Ui, Uj = sp.Matrix(3, 3, fi), sp.Matrix(3, 3, fj)
    w = vector("w", N_PRIMITIVES)

    st = Stager()
    Ai = st.define("Ai", rotation_matrix(qi))
    Aj = st.define("Aj", rotation_matrix(qj))
    delta = st.define("dx", xj - xi)
    phi = primitives(sp.zeros(3, 1), Ai, delta, Aj, si, sj, Ui, Uj)
    z = list(Ai) + list(delta) + list(Aj)
    n = len(z)
    grads = [[sp.diff(p, v) for v in z] for p in phi]
    grad = stage_sparse(st, "gz", sp.Matrix([sum(wp * gp[k] for wp, gp in zip(w, grads)) for k in range(n)]))
    hess = stage_sparse(st, "hz", sp.Matrix(n, n, lambda r, c: sum(
        wp * sp.diff(gp[r], z[c]) for wp, gp in zip(w, grads) if gp[r] != 0)))

    units = [sp.Matrix([1 if k == c else 0 for k in range(3)]) for c in range(3)]
    rotations = ((Ai, 0, 0), (Aj, 12, 6))  # (matrix, first row in z, first column in v)
    T = sp.zeros(n, 9)
    for A, row0, col0 in rotations:
        for c in range(3):
            T[row0:row0 + 9, col0 + c] = (A * skew(units[c])).reshape(9, 1)
    T[9:12, 3:6] = sp.eye(3)
    Hv = T.T * stage_sparse(st, "hT", hess * T)
    for A, row0, col0 in rotations:
        g = grad[row0:row0 + 9, 0]
        for a in range(3):
            for b in range(3):
                second = (A * skew(units[b]) * skew(units[a])).reshape(9, 1)
                Hv[col0 + a, col0 + b] += (g.T * second)[0]
    Hv = stage_sparse(st, "Hv", Hv)
    P = sp.zeros(9, 12)
    P[0:3, 3:6] = sp.eye(3)
    P[3:6, 0:3] = -sp.eye(3)
    P[3:6, 6:9] = sp.eye(3)
    P[6:9, 9:12] = sp.eye(3)
    H = P.T * Hv * P
    inputs = dict(xi=xi, qi=qi, xj=xj, qj=qj, si=si, sj=sj, fi=fi, fj=fj, w=w)
    return inputs, list(H), st.stages


def joint_kernel() -> Kernel:
    inp, H, stages = joint_hessian()
    return Kernel(
        "joint_primitive_hessian",
        "λ-weighted Hessian of the ten joint primitives (derivations/tangents.py).\n\n"
        "    ``H = ∂(Σ_p w_p B_pᵀ)/∂[δx_i, δθ_i, δx_j, δθ_j]`` (12 × 12, row-major) under\n"
        "    ``x → x + ε δx``, ``q → q ⊗ exp(ε δθ)``; B_p are the rows of ``joints.joint_primitives``\n"
        "    (columns [v_i | ω_i | v_j | ω_j]).  Row a of H is B's column a, column b the perturbation.\n"
        "    With ``w`` the multipliers of the rows a joint uses (``reference.joints.hessian``), H is\n"
        "    the geometric stiffness of the joint, ``∂(Bᵀλ)/∂q``.",
        [("xi", list(inp["xi"]), "position of body i (inertial) [m]"),
         ("qi", inp["qi"], "Euler parameters of body i"),
         ("xj", list(inp["xj"]), "position of body j [m]"),
         ("qj", inp["qj"], "Euler parameters of body j"),
         ("si", list(inp["si"]), "joint point, body-fixed on i [m]"),
         ("sj", list(inp["sj"]), "joint point, body-fixed on j [m]"),
         ("fi", inp["fi"], "joint frame on i: row-major 3×3 whose columns are u1', u2', u3' (body-fixed)"),
         ("fj", inp["fj"], "joint frame on j, likewise"),
         ("w", inp["w"], "weight of each primitive (10,): the multiplier of the row that uses it")],
        [("H", H, "Σ_p w_p ∂B_pᵀ/∂[δx_i, δθ_i, δx_j, δθ_j], row-major (12 × 12)")],
        None,
        stages,
    )


def _flat(M: sp.Matrix) -> list:
    return [M[i, j] for i in range(M.shape[0]) for j in range(M.shape[1])]


def nodal_kernels() -> list[Kernel]:
    """Tangents of the nodal loads and of the gyroscopic term, by differentiation.

    The rotation is perturbed as ``A → A (I + δθ̃)`` (the first order of
    ``q ⊗ exp(δθ)``), so the results are ``−A b̃`` (follower force ``A b``) and
    ``(Aᵀm)~`` (dead moment ``Aᵀ m`` in the body frame); the gyroscopic term
    ``ω × Jω`` has ``∂/∂ω = ω̃ J − (Jω)~``.
    """
    q, b, w = vector("q", 4), sp.Matrix(vector("b", 3)), sp.Matrix(vector("w", 3))
    J = sp.Matrix(3, 3, vector("J", 9))
    dt = sp.Matrix(vector("dt", 3))
    zero = {s: 0 for s in dt}
    A = rotation_matrix(q)
    Ap = A * (sp.eye(3) + skew(dt))
    follower = (Ap * b).jacobian(dt).xreplace(zero)
    dead = (Ap.T * b).jacobian(dt).xreplace(zero)
    gyro = w.cross(J * w).jacobian(w)
    rot = ("q", q, "Euler parameters of the node")
    return [
        Kernel("follower_force_tangent",
               "``∂(A b)/∂δθ`` (3 × 3, row-major): a follower force, body-frame components b, in the\n"
               "    inertial frame, differentiated along ``q → q ⊗ exp(δθ)``; equals ``−A b̃``.",
               [rot, ("b", list(b), "force in body-frame components [N]")],
               [("K", _flat(follower), "∂(A b)/∂δθ, row-major (3 × 3) [N/rad]")]),
        Kernel("dead_moment_tangent",
               "``∂(Aᵀ m)/∂δθ`` (3 × 3, row-major): a dead (inertially fixed) moment in body-frame\n"
               "    components, differentiated along ``q → q ⊗ exp(δθ)``; equals ``(Aᵀm)~``.",
               [rot, ("b", list(b), "moment in inertial components [N m]")],
               [("K", _flat(dead), "∂(Aᵀ b)/∂δθ, row-major (3 × 3) [N m/rad]")]),
        Kernel("gyroscopic_tangent",
               "``∂(ω × J ω)/∂ω`` (3 × 3, row-major), ω body frame; equals ``ω̃ J − (Jω)~``.",
               [("J", list(J), "inertia tensor in the body frame, row-major 3×3 [kg m²]"),
                ("w", list(w), "angular velocity, body frame [rad/s]")],
               [("K", _flat(gyro), "∂(ω × Jω)/∂ω, row-major (3 × 3) [kg m²/s]")]),
    ]


def kernels() -> list[Kernel]:
    return [beam2_kernel(), joint_kernel()] + nodal_kernels()


def generate() -> str:
    """Source of ``reference/generated/tangents.py``."""
    parts = [render_coefficient(c) for c in DERIVATIVE_COEFFICIENTS]
    parts += [render_kernel(k, TANGENT_USER_FUNCTIONS) for k in kernels()]
    return render_module(
        "derivations/tangents.py",
        "Tangent matrices: Beam2 tangent stiffness, joint constraint Hessians, load and gyroscopic tangents.\n\n"
        "Derivatives under x → x + ε δx, q → q ⊗ exp(ε δθ) (body-frame increments);\n"
        "see derivations/tangents.py and docs/tangents.md.",
        parts,
        imports=(
            "import math",
            "",
            "from reference.generated.rotation_maps import branch_sign, c_asinc, c_cosc, c_jinv, c_sinc, c_sinc3",
            "from reference.jit import kernel",
        ),
    )
