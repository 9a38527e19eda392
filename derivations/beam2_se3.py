"""The two-node helicoidal (SE(3)) beam, ``beam2_se3``, in sympy: forces, energy and tangent.

Interpolation (Sonneville, Cardona & Brüls 2014): the section frames ``H = (Λ, x)``
of the two ends are joined by the helicoid ``H(s) = H_1 exp(s ε̂)``, ``0 ≤ s ≤ L0``,
whose strains ``ε = (Γ, K)`` (section frame) are constant on the element.  With
``Λ_a = A(q_a)`` the section triads of the ends (docs/formulation.md §3.4)::

    R  = Λ1ᵀ Λ2,  ψ = log R  (shortest branch)      relative rotation
    d  = Λ1ᵀ (x2 − x1)                               chord in the frame of end 1
    U  = B(ψ) d,   B = J_r(ψ)⁻ᵀ = I − ψ̃/2 + c(|ψ|) ψ̃²   translational part of log(H1⁻¹H2)
    Γ  = U/L0 − Γ0,   K = (ψ − ψ0)/L0                 strains (section frame)
    N  = C_Γ Γ,       M = C_K K,       E = ½ L0 (Γᵀ C_Γ Γ + Kᵀ C_K K)

with ``c(a) = (1 − (a/2) cot(a/2))/a²`` (``c_jinv``).  ``d = L0 J_r(ψ)ᵀ Γ`` is the
chord of ``x(s) = x1 + Λ1 ∫₀ˢ exp(t K̃) Γ dt``, so every constant-strain state (straight,
circle, helix) is represented exactly by any number of elements; the strains depend on
the relative motion ``H1⁻¹H2`` only, so they are objective (invariant under a superposed
rigid motion) and path independent.  ``Γ0``, ``ψ0`` are those of the element at rest.

**Internal forces: the exact gradient of E** along ``x_a → x_a + δx_a``,
``Λ_a → Λ_a (I + δθ̃_a)`` (body-frame rotations, like every engine kernel)::

    δψ = J_r(ψ)⁻¹ (δθ2 − Rᵀ δθ1),   δd = Λ1ᵀ (δx2 − δx1) + d̃ δθ1,   δU = B δd + D δψ

with ``D = ∂(B d)/∂ψ``.  ``δE = Nᵀ δU + Mᵀ δψ`` gives, with ``v = Bᵀ N = J_r(ψ)⁻¹ N``
and ``g = M + Dᵀ N`` (``= M + ∇_ψ(Nᵀ B(ψ) d)``)::

    S_u1 = −Λ1 v,   S_u2 = Λ1 v,   S_θ2 = J_r(ψ)⁻ᵀ g,   S_θ1 = −d̃ v − R S_θ2

the structure of Beam2's (``derivations/beam2.py``) with the midpoint triad replaced
by the helicoid's log.

**Tangent** ``K = ∂S/∂[δx1, δθ1, δx2, δθ2]`` by the chain rule over the columns
``[δθ1, δu, δθ2]`` (``δu = δx2 − δx1``)::

    δN = C_Γ δU/L0,   δM = C_K δψ/L0,   δv = G δψ + J_r⁻¹ δN,   G = ∂(J_r(ψ)⁻¹ N)/∂ψ
    δg = δM + Dᵀ δN + H δψ + Gᵀ δd,   H = ∂²(Nᵀ B(ψ) d)/∂ψ²
    δS_θ2 = D_i δψ + J_r⁻ᵀ δg,        D_i = ∂(J_r(ψ)⁻ᵀ g)/∂ψ
    δS_θ1 = ṽ δd − d̃ δv + R S̃_θ2 (J_r δψ) − R δS_θ2,   J_r δψ = δθ2 − Rᵀ δθ1
    δS_u2 = −δS_u1 = Λ1 (δv − ṽ δθ1)

sympy takes the derivatives ``D``, ``G``, ``H``, ``D_i`` of the coefficient functions
through ``c'(a)/a`` and, for ``H``, ``(c'(a)/a)'/a`` (``c_jinv_dd`` below), so nothing
divides by ``|ψ|``.  ``tests/test_beam2_se3.py`` checks the forces against central
differences of E and the tangent against central differences of the forces.
:func:`generate` writes ``reference/generated/beam2_se3.py``; the kernels take the
arguments of ``beam2.internal_forces`` in the same order.
"""

from __future__ import annotations

import sympy as sp

from derivations.beam2 import kernel_arguments, two_node_start
from derivations.codegen import Coefficient, Kernel, Stager, render_coefficient, render_kernel, render_module
from derivations.rotation_maps import C, USER_FUNCTIONS, exp_matrix, right_jacobian_inverse, skew
from derivations.tangents import DERIVATIVE_COEFFICIENTS, stage_sparse

a = sp.Symbol("a")
_JINV_D = next(c for c in DERIVATIVE_COEFFICIENTS if c.name == "c_jinv_d")
JINV_DD = Coefficient(
    "c_jinv_dd",
    sp.simplify(sp.diff(_JINV_D.expr, a) / a),
    "c_jinv_d'(a)/a (smooth, even): ∂c_jinv_d(|ψ|)/∂ψ = c_jinv_dd(|ψ|) ψ.",
    threshold=2.0,
    order=40,
)
"""The second derivative coefficient of ``c_jinv`` the Hessian ``H`` needs; series up to a = 2 like
``c_jinv_d`` (the closed form cancels badly at small a; the series converges for a < 2π)."""
USER = USER_FUNCTIONS + ["c_jinv_d", "c_jinv_dd"]
_D, _DD = sp.Function("c_jinv_d"), sp.Function("c_jinv_dd")


def _differentiable(name, derivative):
    def fdiff(self, argindex=1):
        return self.args[0] * derivative(self.args[0])

    return type(name, (sp.Function,), {"fdiff": fdiff})


_DD_DIFF = _differentiable("c_jinv_d", _DD)
_D_DIFF = _differentiable("c_jinv", _DD_DIFF)


def _jacobian(vec: sp.Matrix, wrt) -> sp.Matrix:
    """``∂vec/∂wrt`` with ``c_jinv`` and ``c_jinv_d`` differentiated through their derived coefficients."""
    vec = vec.replace(C["c_jinv"], lambda x: _D_DIFF(x)).replace(_D, lambda x: _DD_DIFF(x))
    J = vec.jacobian(sp.Matrix(wrt))
    J = J.replace(_DD_DIFF, lambda x: _D(x))
    return J.replace(_D_DIFF, lambda x: C["c_jinv"](x))


def se3_quantities():
    """Inputs, element quantities (forces, strains, resultants, energy) and stages of the force kernel."""
    x1, x2, q1, q2, L0, psi0, gamma0, c, CG, CK, st, A1, psi = two_node_start()
    R = st.define("R", exp_matrix(psi))
    d = st.define("d", A1.T * (x2 - x1))
    Ji_expr = right_jacobian_inverse(psi)
    Ji = st.define("Ji", Ji_expr)
    Uv = st.define("U", Ji.T * d)
    Gamma = st.define("Gamma", Uv / L0 - gamma0)
    Kappa = st.define("Kappa", (psi - psi0) / L0)
    N = st.define("N", CG * Gamma)
    M = st.define("M", CK * Kappa)
    v = st.define("v", Ji * N)
    D = st.define("D", _jacobian(Ji_expr.T * d, psi))
    g = st.define("g", M + D.T * N)
    s_theta2 = st.define("st2", Ji.T * g)
    s_theta1 = -skew(d) * v - R * s_theta2
    n = A1 * v
    S = list(-n) + list(s_theta1) + list(n) + list(s_theta2)
    E = L0 / 2 * ((Gamma.T * CG * Gamma)[0] + (Kappa.T * CK * Kappa)[0])
    inputs = dict(x1=x1, x2=x2, q1=q1, q2=q2, L0=L0, psi0=psi0, gamma0=gamma0, c=c)
    named = dict(A1=A1, R=R, psi=psi, d=d, Ji=Ji, Ji_expr=Ji_expr, N=N, v=v, D=D, g=g, st2=s_theta2, CG=CG, CK=CK)
    quantities = dict(S=S, U=E, Gamma=Gamma, Kappa=Kappa, N=N, M=M, named=named)
    return inputs, quantities, st.stages


def se3_tangent():
    """Inputs, forces S (12), tangent K (12 × 12) and the stages (the chain rule of the module docstring)."""
    inp, out, stages = se3_quantities()
    q = out["named"]
    st = Stager()
    st.stages = list(stages)
    A1, R, psi, d, Ji, N, v, D, g, st2 = (q[k] for k in ("A1", "R", "psi", "d", "Ji", "N", "v", "D", "g", "st2"))
    Ji_expr, CG, CK, L0 = q["Ji_expr"], q["CG"], q["CK"], inp["L0"]
    Z, I = sp.zeros(3, 3), sp.eye(3)

    dpsi1 = st.define("dps1", -Ji * R.T)
    dpsi = sp.Matrix.hstack(dpsi1, Z, Ji)
    Jdpsi = sp.Matrix.hstack(-R.T, Z, I)
    dd = sp.Matrix.hstack(skew(d), A1.T, Z)
    dU = stage_sparse(st, "dU", Ji.T * dd + D * dpsi)
    dN = CG * dU / L0
    dM = CK * dpsi / L0
    G = st.define("G", _jacobian(Ji_expr * N, psi))
    H = st.define("H", _jacobian(_jacobian(Ji_expr.T * d, psi).T * N, psi))
    dv = stage_sparse(st, "dv", G * dpsi + Ji * dN)
    dg = stage_sparse(st, "dg", dM + D.T * dN + H * dpsi + G.T * dd)
    Di = st.define("Di", _jacobian(Ji_expr.T * g, psi))
    dst2 = stage_sparse(st, "dst2", Di * dpsi + Ji.T * dg)
    dst1 = stage_sparse(st, "dst1", skew(v) * dd - skew(d) * dv + R * skew(st2) * Jdpsi - R * dst2)
    dn = stage_sparse(st, "dn", A1 * (dv - skew(v) * sp.Matrix.hstack(I, Z, Z)))
    K9 = sp.Matrix.vstack(-dn, dst1, dn, dst2)
    K = sp.Matrix.hstack(-K9[:, 3:6], K9[:, 0:3], K9[:, 3:6], K9[:, 6:9])
    return inp, out["S"], K, st.stages


def kernels() -> list[Kernel]:
    inp, out, stages = se3_quantities()
    args = kernel_arguments(inp)
    args[5] = ("psi0", args[5][1], "relative rotation ψ0 = log(Λ1ᵀΛ2) of the section triads at rest [rad]")
    args[6] = ("gamma0", args[6][1], "Γ0 = B(ψ0) d0 / L0 at rest (E1 for a straight or circular element)")
    args[4] = ("L0", args[4][1], "reference arc length of the helicoid [m]")
    tinp, S, K, tstages = se3_tangent()
    return [
        Kernel(
            "internal_forces",
            "beam2_se3 internal nodal forces (the exact gradient of the strain energy), strains, resultants.\n\n"
            "    Paper eq. (3): the vector S of ``M a + S = F``.  Order of ``s``:\n"
            "    S_u1 (inertial, N), S_θ1 (section frame of end 1, N m), S_u2, S_θ2 (section frame of end 2).\n"
            "    Strains and resultants are constant on the element (the helicoid's).",
            args,
            [("s", out["S"], "internal forces [S_u1, S_θ1, S_u2, S_θ2] (12,)"),
             ("strain", list(out["Gamma"]) + list(out["Kappa"]), "Γ (3) then K (3) [-, 1/m], section frame"),
             ("stress", list(out["N"]) + list(out["M"]), "N (3) [N] then M (3) [N m], section frame")],
            (out["U"], "strain energy [J]"),
            stages,
        ),
        Kernel(
            "tangent",
            "beam2_se3 internal forces S and tangent stiffness K = ∂S/∂[δx1, δθ1, δx2, δθ2].\n\n"
            "    Same inputs and the same ``s`` as ``internal_forces``.  ``K`` (12 × 12, row-major) is the\n"
            "    exact derivative of ``s`` under ``x_a → x_a + ε δx_a``, ``q_a → q_a ⊗ exp(ε δθ_a)``\n"
            "    (body-frame increments of the section triads); node frames: ``T K Tᵀ`` as for Beam2.\n"
            "    Units: N/m, N, N m (force/length, force/angle or moment/length, moment/angle blocks).",
            args,
            [("s", list(S), "internal forces [S_u1, S_θ1, S_u2, S_θ2] (12,)"),
             ("K", list(K), "tangent stiffness ∂s/∂[δx1, δθ1, δx2, δθ2], row-major (12 × 12)")],
            None,
            tstages,
        ),
    ]


def generate() -> str:
    """Source of ``reference/generated/beam2_se3.py``."""
    parts = [render_coefficient(JINV_DD)] + [render_kernel(k, USER) for k in kernels()]
    return render_module(
        "derivations/beam2_se3.py",
        "beam2_se3 element arrays: helicoidal (SE(3)) interpolation, forces, energy, resultants, tangent.\n\n"
        "See derivations/beam2_se3.py for the derivation.",
        parts,
        imports=(
            "import math",
            "",
            "from reference.generated.rotation_maps import branch_sign, c_asinc, c_cosc, c_jinv, c_sinc, c_sinc3",
            "from reference.generated.tangents import c_jinv_d",
            "from reference.jit import kernel",
        ),
    )
