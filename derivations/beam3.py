"""The three-node beam (``beam3``) in sympy: forces, energy and tangent.

Kinematics (Crisfield & Jelenić 1999, with the middle node's triad as the reference
triad): nodes 1, 2 at the ends (ξ = ∓1), node 3 in the middle (ξ = 0); quadratic shape
functions ``N1 = ξ(ξ − 1)/2``, ``N2 = ξ(ξ + 1)/2``, ``N3 = 1 − ξ²``, ``d/ds = (2/L0) d/dξ``.
With ``Λ_a`` the section triads (``p_a = q_a ⊗ o_a``) the *local* rotations are
``ψ_i = log(Λ3ᵀΛ_i)`` (ψ3 = 0) and, at the two Gauss points ``ξ_g = ∓1/√3``::

    ψ_g = N1 ψ1 + N2 ψ2,  ψ'_g = N1' ψ1 + N2' ψ2     interpolated local rotation
    Λ_g = Λ3 exp(ψ̃_g),    y_g = Λ3ᵀ x'_g,  x'_g = Σ N_a' x_a
    Γ_g = exp(ψ̃_g)ᵀ y_g − Γ0_g,   K_g = J_r(ψ_g) ψ'_g − K0_g
    U   = Σ_g (L0/2) · ½ (Γ_gᵀ C_Γ Γ_g + K_gᵀ C_K K_g)

The strains depend on relative rotations only: objective and path independent (Crisfield &
Jelenić's remedy of interpolating total rotations).  Two-point Gauss integration (reduced for
the quadratic element) is free of shear and membrane locking.

**Forces and tangent.**  U is a function of ``v = (y_1, y_2, ψ1, ψ2)`` (12 numbers), and each
Gauss term ``U_g(y, ψ, ψ')`` of nine: sympy takes its gradient ``g`` and Hessian ``H`` once
(coefficients of exp and J_r differentiated through ``c'(a)/a`` and ``(c'(a)/a)'/a``), and the
constant maps ``P_g`` (``u_g = P_g v``) give ``∂U/∂v = Σ P_gᵀ g_g``, ``∂²U/∂v² = Σ P_gᵀ H_g P_g``.
The perturbations ``x_a → x_a + δx_a``, ``Λ_a → Λ_a (I + δθ̃_a)`` enter through::

    δy_g = Λ3ᵀ δx'_g + ỹ_g δθ3,     δψ_i = J_r(ψ_i)⁻¹ (δθ_i − R_iᵀ δθ3),  R_i = exp(ψ̃_i)

(``δv = T δ``), so ``S = Tᵀ ∂U/∂v`` and ``K = Tᵀ (∂²U/∂v²) T + ∂(Tᵀ w)/∂δ |_w`` with
``w = ∂U/∂v`` held: the second term from ``Λ3`` in ``δy`` and ``ỹ_g``, and from ``J_r(ψ_i)⁻ᵀ``
and ``R_i`` (Beam2's ``D_i``, docs/tangents.md).  Order of the 18 forces and columns:
``[u1, θ1, u2, θ2, u3, θ3]`` (end, end, middle).
"""

from __future__ import annotations

import sympy as sp

from derivations.codegen import Coefficient, Kernel, Stager, render_coefficient, render_kernel, render_module, vector
from derivations.rotation_maps import (
    C,
    COEFFICIENTS,
    USER_FUNCTIONS,
    exp_matrix,
    log_quaternion,
    quat_conj,
    quat_mul,
    right_jacobian,
    right_jacobian_inverse,
    rotation_matrix,
    skew,
)
from derivations.tangents import DERIVATIVE_COEFFICIENTS, stage_sparse
from derivations.tangents import jacobian as jacobian1

a = sp.Symbol("a")
_ORIG = {c.name: c for c in COEFFICIENTS}
_FIRST = {c.name: c for c in DERIVATIVE_COEFFICIENTS}
NEW_COEFFICIENTS = [
    Coefficient("c_sinc_d", sp.simplify(sp.diff(_ORIG["c_sinc"].expr, a) / a),
                "c_sinc'(a)/a (smooth, even): ∂c_sinc(|ψ|)/∂ψ = c_sinc_d(|ψ|) ψ.", threshold=2.0, order=40),
]
NEW_COEFFICIENTS += [
    Coefficient(f"{name}_dd", sp.simplify(sp.diff(expr, a) / a),
                f"{name}_d'(a)/a (smooth, even): ∂{name}_d(|ψ|)/∂ψ = {name}_dd(|ψ|) ψ.", threshold=2.0, order=40)
    for name, expr in (("c_sinc", NEW_COEFFICIENTS[0].expr), ("c_cosc", _FIRST["c_cosc_d"].expr),
                       ("c_sinc3", _FIRST["c_sinc3_d"].expr))
]
"""Derivative coefficients the Hessian of a Gauss term needs beyond derivations/tangents.py's."""
NAMES = ("c_sinc", "c_cosc", "c_sinc3")
USER = USER_FUNCTIONS + [f"{n}_d" for n in NAMES] + [f"{n}_dd" for n in NAMES] + ["c_jinv_d"]
_F = {f"{n}{s}": sp.Function(f"{n}{s}") for n in NAMES for s in ("", "_d", "_dd")}


def _twice(name):
    def fdiff2(self, argindex=1):
        return self.args[0] * _F[f"{name}_dd"](self.args[0])

    first = type(f"{name}_d", (sp.Function,), {"fdiff": fdiff2})

    def fdiff1(self, argindex=1):
        return self.args[0] * first(self.args[0])

    return type(name, (sp.Function,), {"fdiff": fdiff1}), first


_DIFF = {n: _twice(n) for n in NAMES}


def _jacobian(vec: sp.Matrix, wrt) -> sp.Matrix:
    """``∂vec/∂wrt`` with the coefficient functions (and their first derivatives) differentiable."""
    for n in NAMES:
        vec = vec.replace(C[n], lambda x, n=n: _DIFF[n][0](x)).replace(_F[f"{n}_d"], lambda x, n=n: _DIFF[n][1](x))
    J = vec.jacobian(sp.Matrix(wrt))
    for n in NAMES:
        J = J.replace(_DIFF[n][1], lambda x, n=n: _F[f"{n}_d"](x)).replace(_DIFF[n][0], lambda x, n=n: C[n](x))
    return J


XI = (-1 / sp.sqrt(3), 1 / sp.sqrt(3))


def shape(xi):
    """Values and ξ-derivatives of N1, N2, N3 (ends at ξ = ∓1, middle at 0)."""
    N = [xi * (xi - 1) / 2, xi * (xi + 1) / 2, 1 - xi**2]
    dN = [xi - sp.Rational(1, 2), xi + sp.Rational(1, 2), -2 * xi]
    return N, dN


def gauss_term():
    """A Gauss term ``U_g(y, p, dp)`` (weight 1, times L0/2), its gradient (9) and Hessian (9 × 9)."""
    y, p, dp = sp.Matrix(vector("gy", 3)), sp.Matrix(vector("gp", 3)), sp.Matrix(vector("gd", 3))
    g0, k0 = sp.Matrix(vector("gg0", 3)), sp.Matrix(vector("gk0", 3))
    c = vector("c", 6)
    L0 = sp.Symbol("L0", positive=True)
    Gamma = exp_matrix(p).T * y - g0
    Kappa = right_jacobian(p) * dp - k0
    U = L0 / 4 * ((Gamma.T * sp.diag(*c[:3]) * Gamma)[0] + (Kappa.T * sp.diag(*c[3:]) * Kappa)[0])
    u = list(y) + list(p) + list(dp)
    grad = _jacobian(sp.Matrix([U]), u)
    hess = _jacobian(grad.T, u)
    return (y, p, dp, g0, k0), Gamma, Kappa, U, grad, hess


def beam3_kernels():
    x = [sp.Matrix(vector(f"x{k}", 3)) for k in (1, 2, 3)]
    q = [vector(f"q{k}", 4) for k in (1, 2, 3)]
    L0 = sp.Symbol("L0", positive=True)
    gamma0, kappa0 = vector("gamma0", 6), vector("kappa0", 6)
    c = vector("c", 6)
    (ys, ps, dps, g0s, k0s), Gamma_e, Kappa_e, U_e, grad_e, hess_e = gauss_term()

    st = Stager()
    A3 = st.define("A3", rotation_matrix(q[2]))
    psi = [st.define(f"psi{i}", sp.Matrix(log_quaternion(st.define(f"r{i}", quat_mul(quat_conj(q[2]), q[i])))))
           for i in (0, 1)]
    Ji_expr = [right_jacobian_inverse(p) for p in psi]
    Ji = [st.define(f"Ji{i}", Ji_expr[i]) for i in (0, 1)]
    R = [st.define(f"R{i}", exp_matrix(psi[i])) for i in (0, 1)]
    I = sp.eye(3)
    U_total, strain, stress, gv, Hv = 0, [], [], sp.zeros(12, 1), sp.zeros(12, 12)
    T_y, subs, gauss_inputs = [], [], []
    for g, xi in enumerate(XI):
        N, dN = shape(xi)
        xp = sum((dN[k] * 2 / L0 * x[k] for k in range(3)), sp.zeros(3, 1))
        y = st.define(f"y{g}", A3.T * xp)
        pg = st.define(f"pg{g}", N[0] * psi[0] + N[1] * psi[1])
        dpg = st.define(f"dp{g}", (dN[0] * psi[0] + dN[1] * psi[1]) * 2 / L0)
        sub = dict(zip(list(ys) + list(ps) + list(dps) + list(g0s) + list(k0s),
                       list(y) + list(pg) + list(dpg) + gamma0[3 * g:3 * g + 3] + kappa0[3 * g:3 * g + 3]))
        Gam = st.define(f"Gam{g}", Gamma_e.xreplace(sub))
        Kap = st.define(f"Kap{g}", Kappa_e.xreplace(sub))
        strain += list(Gam) + list(Kap)
        gauss_inputs += list(y) + list(pg) + list(dpg)
        stress += list(sp.diag(*c[:3]) * Gam) + list(sp.diag(*c[3:]) * Kap)
        U_total += L0 / 4 * ((Gam.T * sp.diag(*c[:3]) * Gam)[0] + (Kap.T * sp.diag(*c[3:]) * Kap)[0])
        grad = st.define(f"gr{g}", grad_e.T.xreplace(sub))
        # u_g = P_g v, v = (y_0, y_1, psi1, psi2)
        P = sp.zeros(9, 12)
        P[0:3, 3 * g:3 * g + 3] = I
        P[3:6, 6:9], P[3:6, 9:12] = N[0] * I, N[1] * I
        P[6:9, 6:9], P[6:9, 9:12] = dN[0] * 2 / L0 * I, dN[1] * 2 / L0 * I
        gv += P.T * grad
        subs.append((sub, P))
        # δy_g over the 18 columns [x1, θ1, x2, θ2, x3, θ3]
        Ty = sp.zeros(3, 18)
        for k in range(3):
            Ty[:, 6 * k:6 * k + 3] = dN[k] * 2 / L0 * A3.T
        Ty[:, 15:18] = skew(y)
        T_y.append((Ty, y, [dN[k] * 2 / L0 for k in range(3)]))
    w = st.define("w", gv)
    T = sp.zeros(12, 18)
    for g in range(2):
        T[3 * g:3 * g + 3, :] = T_y[g][0]
    dpsi = []
    for i in range(2):
        m = sp.zeros(3, 18)
        m[:, 6 * i + 3:6 * i + 6] = Ji[i]
        m[:, 15:18] = -Ji[i] * R[i].T
        dpsi.append(m)
        T[6 + 3 * i:9 + 3 * i, :] = m
    Ts = stage_sparse(st, "T", T)
    S = st.define("S", Ts.T * w)
    n_force = len(st.stages)
    hess_in = vector("hg", 162)
    for g, (sub, P) in enumerate(subs):
        Hv += P.T * sp.Matrix(9, 9, hess_in[81 * g:81 * g + 81]) * P
    Hvs = stage_sparse(st, "Hv", Hv)
    K = Ts.T * Hvs * Ts
    # ∂(Tᵀ w)/∂δ with w held: the y rows
    G = sp.zeros(18, 18)
    for g in range(2):
        _, y, dNs = T_y[g]
        wy = sp.Matrix(w[3 * g:3 * g + 3])
        for k in range(3):
            # rows x_k: dN_k A3 w_y; A3 → A3 (I + δθ3~): −dN_k A3 w̃_y δθ3
            G[6 * k:6 * k + 3, 15:18] += -dNs[k] * A3 * skew(wy)
        # rows θ3: (ỹ)ᵀ w_y = w_y × y; δ: w̃_y δy
        G[15:18, :] += skew(wy) * T_y[g][0]
    # the ψ rows: rows θ_i get J_r⁻ᵀ(ψ_i) w_ψi, rows θ3 get −R_i J_r⁻ᵀ(ψ_i) w_ψi
    for i in range(2):
        wp = sp.Matrix(w[6 + 3 * i:9 + 3 * i])
        Di = st.define(f"Di{i}", jacobian1(Ji_expr[i].T * wp, psi[i]))
        sv = st.define(f"sv{i}", Ji[i].T * wp)
        Jd = sp.zeros(3, 18)  # J_r δψ_i = δθ_i − R_iᵀ δθ3
        Jd[:, 6 * i + 3:6 * i + 6] = I
        Jd[:, 15:18] = -R[i].T
        G[6 * i + 3:6 * i + 6, :] += Di * dpsi[i]
        G[15:18, :] += R[i] * skew(sv) * Jd - R[i] * Di * dpsi[i]
    K = stage_sparse(st, "K", K + G)
    inputs = [
        ("x1", list(x[0]), "position of end node 1 (inertial) [m]"),
        ("x2", list(x[1]), "position of end node 2 [m]"),
        ("x3", list(x[2]), "position of the middle node [m]"),
        ("q1", q[0], "Euler parameters of the section triad at node 1, p1 = q_node1 ⊗ o1"),
        ("q2", q[1], "section triad at node 2"),
        ("q3", q[2], "section triad at the middle node (the reference triad)"),
        ("L0", L0, "reference length (ξ from −1 to 1 maps to s from 0 to L0) [m]"),
        ("gamma0", gamma0, "Γ0 at the two Gauss points (2 × 3) at rest"),
        ("kappa0", kappa0, "K0 at the two Gauss points (2 × 3) at rest [1/m]"),
        ("c", c, "section stiffness EA, GA2, GA3 [N], GJ, EI2, EI3 [N m²]"),
    ]
    forces = Kernel(
        "internal_forces",
        "beam3 internal nodal forces (the exact gradient of the strain energy), strains, resultants.\n\n"
        "    Order of ``s``: S_u1, S_θ1, S_u2, S_θ2, S_u3, S_θ3 (u inertial [N], θ section frames [N m]);\n"
        "    strains and resultants at the Gauss points ξ = −1/√3 then +1/√3.",
        inputs,
        [("s", list(S), "internal forces (18,)"),
         ("u", gauss_inputs, "y (3), ψ (3), ψ' (3) at Gauss point 1, then at Gauss point 2: the inputs of "
                             "``gauss_hessian``"),
         ("strain", strain, "Γ (3), K (3) at Gauss point 1, then at Gauss point 2 [-, 1/m]"),
         ("stress", stress, "N (3) [N], M (3) [N m] at Gauss point 1, then at Gauss point 2, section frame")],
        (U_total, "strain energy [J]"),
        st.stages[:n_force],
    )
    tangent_inputs = inputs + [("hg", hess_in, "the Hessians of the two Gauss terms (2 × 81, row-major), "
                                                "``gauss_hessian`` at the two points of ``internal_forces``'s u")]
    tangent = Kernel(
        "tangent",
        "beam3 internal forces S and tangent stiffness K = ∂S/∂[δx1, δθ1, δx2, δθ2, δx3, δθ3].\n\n"
        "    Same inputs and ``s`` as ``internal_forces``; ``K`` (18 × 18, row-major) the exact derivative\n"
        "    under ``x_a → x_a + ε δx_a``, ``q_a → q_a ⊗ exp(ε δθ_a)`` (body-frame increments of the section\n"
        "    triads).  Units: N/m, N, N m.",
        tangent_inputs,
        [("s", list(S), "internal forces (18,)"),
         ("K", list(K), "tangent stiffness, row-major (18 × 18)")],
        None,
        st.stages,
    )
    gauss = Kernel(
        "gauss_hessian",
        "The Hessian (9 × 9, row-major) of one Gauss term ``(L0/4)(Γᵀ C_Γ Γ + Kᵀ C_K K)`` of beam3 in\n"
        "    ``u = (y, ψ, ψ')`` (derivations/beam3.py); the tangent kernel takes it for both points.",
        [("u", list(ys) + list(ps) + list(dps), "y = Λ3ᵀx' (3), ψ (3), ψ' (3) at the Gauss point"),
         ("g0", list(g0s), "Γ0 at the Gauss point"),
         ("k0", list(k0s), "K0 at the Gauss point [1/m]"),
         ("c", c, "section stiffness EA, GA2, GA3 [N], GJ, EI2, EI3 [N m²]"),
         ("L0", L0, "reference length [m]")],
        [("H", list(hess_e), "∂²U_g/∂u², row-major (9 × 9)")],
    )
    return [forces, gauss, tangent]


def generate() -> str:
    """Source of ``reference/generated/beam3.py``."""
    parts = [render_coefficient(c) for c in NEW_COEFFICIENTS] + [render_kernel(k, USER) for k in beam3_kernels()]
    return render_module(
        "derivations/beam3.py",
        "beam3 element arrays: quadratic three-node beam, two Gauss points; forces, energy, resultants, tangent.\n\n"
        "See derivations/beam3.py for the derivation.",
        parts,
        imports=(
            "import math",
            "",
            "from reference.generated.rotation_maps import branch_sign, c_asinc, c_cosc, c_jinv, c_sinc, c_sinc3",
            "from reference.generated.tangents import c_cosc_d, c_jinv_d, c_sinc3_d",
            "from reference.jit import kernel",
        ),
    )
