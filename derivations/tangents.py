"""Tangent matrices (the element matrices of Newton's method), in sympy.

Every tangent here is the exact derivative of a generated force or constraint
with respect to the **perturbation variables** ``[δx_a, δθ_a]`` of the nodes
(or bodies) it touches, under

    x_a → x_a + ε δx_a,        q_a → q_a ⊗ exp(ε δθ_a)

(δθ_a a *body-frame* rotation increment: exactly how the integrators update
rotations — the explicit scheme's Cayley factor, the implicit schemes'
``q ⊗ exp(Δθ)``).  ``K = ∂f/∂[δx_1, δθ_1, …]`` at ε = 0.  Because SO(3) is not
a vector space, ``K`` is not symmetric away from equilibrium: it is the
derivative of the force *vector* along this perturbation, which is what a
Newton iteration on the incremental rotations needs.

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
chain rule written out by hand, every factor a 3×12 matrix)::

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

from derivations.beam2 import beam2_quantities
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
        threshold=1.0,
        order=26,
    )
    for name in DIFFERENTIATED
]
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
    v = vec
    for old, new in _DIFFERENTIABLE.items():
        v = v.replace(old, new)
    J = v.jacobian(sp.Matrix(wrt))
    back = {new: old for old, new in _DIFFERENTIABLE.items()}
    for new, old in back.items():
        J = J.replace(new, old)
    return J


def stage_sparse(st: Stager, name: str, M: sp.Matrix) -> sp.Matrix:
    """Stage the structurally non-zero entries of ``M``; exact zeros stay zeros."""
    M = sp.Matrix(M)
    idx = [k for k, e in enumerate(M) if e != 0]
    if not idx:
        return sp.zeros(*M.shape)
    syms = st.define(name, [M[k] for k in idx])
    out = sp.zeros(*M.shape)
    for k, s in zip(idx, syms):
        out[k // M.shape[1], k % M.shape[1]] = s
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
    dpsi = sp.Matrix.hstack(Z, dpsi1, Z, Jinv)
    Jdpsi = sp.Matrix.hstack(Z, -R.T, Z, I)
    dthm = stage_sparse(st, "dthm", sp.Matrix.hstack(Z, E.T + Jh * dpsi1 / 2, Z, Jh * Jinv / 2))
    dgh = stage_sparse(st, "dgh", sp.Matrix.hstack(-Am.T / L0, Z, Am.T / L0, Z) + skew(gh) * dthm)
    dN = CG * dgh
    dM = CK * dpsi / L0
    df = stage_sparse(st, "df", L0 * (skew(N) * dgh - skew(gh) * dN))
    Dh = st.define("Dh", jacobian(Jh_expr.T * f, psi))
    dg = stage_sparse(st, "dg", dM + (Dh * dpsi + Jh.T * df) / 2)
    Di = st.define("Di", jacobian(Jinv_expr.T * g, psi))
    dst2 = stage_sparse(st, "dst2", Di * dpsi + Jinv.T * dg)
    dst1 = -E * skew(f) * Jh * dpsi / 2 + E * df + R * skew(st2) * Jdpsi - R * dst2
    dn = stage_sparse(st, "dn", Am * (dN - skew(N) * dthm))
    K = sp.Matrix.vstack(-dn, dst1, dn, dst2)
    return inp, out["S"], K, st.stages


def beam2_kernel() -> Kernel:
    inp, S, K, stages = beam2_tangent()
    args = [
        ("x1", list(inp["x1"]), "position of node 1 (inertial) [m]"),
        ("x2", list(inp["x2"]), "position of node 2 (inertial) [m]"),
        ("q1", inp["q1"], "Euler parameters of node 1 (section triad)"),
        ("q2", inp["q2"], "Euler parameters of node 2 (section triad)"),
        ("L0", inp["L0"], "reference length [m]"),
        ("psi0", list(inp["psi0"]), "reference relative rotation ψ0 = log(A1ᵀA2) at rest [rad]"),
        ("gamma0", list(inp["gamma0"]), "reference Γ0 = Amᵀx' at rest (E1 for a straight beam)"),
        ("c", inp["c"], "section stiffness EA, GA2, GA3 [N], GJ, EI2, EI3 [N m²]"),
    ]
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
    derivative ``∂²Φ/∂δ_a ∂η_b`` of ``Φ(x + εη_x + τδ_x, A (I + εη̃)(I + τδ̃))`` at zero
    (only the first order of each exponential contributes to the mixed term; the order of
    the two factors does).
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
    d = [sp.Matrix(vector(n, 3)) for n in ("dxi", "dti", "dxj", "dtj")]
    e = [sp.Matrix(vector(n, 3)) for n in ("exi", "eti", "exj", "etj")]
    I = sp.eye(3)
    phi = primitives(xi + e[0] + d[0], Ai * (I + skew(e[1])) * (I + skew(d[1])),
                     xj + e[2] + d[2], Aj * (I + skew(e[3])) * (I + skew(d[3])), si, sj, Ui, Uj)
    weighted = sum(wp * p for wp, p in zip(w, phi))
    dvars = [s for v in d for s in v]
    evars = [s for v in e for s in v]
    zero = {s: 0 for s in dvars + evars}
    first = [sp.diff(weighted, s) for s in dvars]
    H = [sp.diff(fa, s).xreplace(zero) for fa in first for s in evars]
    inputs = dict(xi=xi, qi=qi, xj=xj, qj=qj, si=si, sj=sj, fi=fi, fj=fj, w=w)
    return inputs, H, st.stages


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


def kernels() -> list[Kernel]:
    return [beam2_kernel(), joint_kernel()]


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
