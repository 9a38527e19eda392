"""The two-node geometrically exact beam (Beam2), one-point integration, in sympy.

Kinematics (Simo & Vu-Quoc 1986; docs/formulation.md §3), strains at the midpoint::

    x' = (x2 − x1)/L0
    r  = q1* ⊗ q2 (shortest branch),  ψ = log r       relative rotation
    Am = A1 exp(ψ̃/2)                                   midpoint triad
    Γ  = Amᵀ x' − Γ0,   K = (ψ − ψ0)/L0                 strains (section frame)
    N  = C_Γ Γ,         M = C_K K                       section forces, moments
    U  = (L0/2)(Γᵀ C_Γ Γ + Kᵀ C_K K)                    strain energy

**Internal forces are the exact gradient of U** with respect to the nodal
displacements and the body-frame rotation perturbations ``δR_i = R_i δθ̃_i``
(the virtual work of the engine's body-frame moments).  The variations used:

* ``δψ = J_r(ψ)⁻¹ (δθ2 − Rᵀ δθ1)`` with ``R = A1ᵀA2 = exp(ψ̃)``, from
  ``δ(A1ᵀA2) = exp(ψ̃)(δθ2 − Rᵀδθ1)~`` and the right Jacobian of the
  exponential map;
* ``δθm = Eᵀ δθ1 + ½ J_r(ψ/2) δψ`` for the midpoint triad, ``E = exp(ψ̃/2)``;
* ``δΓ = Amᵀ (δx2 − δx1)/L0 + (Amᵀ x')~ δθm``,  ``δK = δψ/L0``.

Hence, with ``f = L0 N × (Amᵀ x')`` and ``g = M + ½ J_r(ψ/2)ᵀ f``::

    S_u1 = −Am N,   S_u2 = Am N
    S_θ2 = J_r(ψ)⁻ᵀ g,   S_θ1 = E f − R J_r(ψ)⁻ᵀ g

(``M ü + S = F`` sign convention; the rotational parts are body-frame
moments at each end).  The tests check them against central finite
differences of U.  :func:`generate` writes ``reference/generated/beam2.py``.

**The kernel works in section frames.**  Its ``q1``, ``q2`` are the Euler
parameters of the element's own section triads at its two ends, not
necessarily the node frames.  ``K = (ψ − ψ0)/L0`` is the right curvature only
for a straight reference: with ``ψ0 ≠ 0`` a small extra rotation δ gives
``ψ − ψ0 ≈ J_r(ψ0)⁻¹ δ``, too stiff by ``|J_r(ψ0)⁻¹ δ|²/|δ|²`` normal to ψ0
(23 % for the 90° kink two perpendicular beams sharing a node would give).
So every element is straight in its own section frame (ψ0 = 0, Γ0 = E1 at
rest) and each end a refers to it through a constant offset ``o_a`` from the
node frame: ``Λ_a = A(q_a) A(o_a)``, section quaternion ``p_a = q_a ⊗ o_a``,
``o_a = q_a⁰* ⊗ p_a⁰`` fixed at t = 0 (identity where the node frame is the
section frame).  Kinks at shared nodes and the chords of a curved beam are
then exact for any angle and the measure stays objective.  The assembly
(``reference.elements.beam2.beam2_assemble``) composes ``p_a``
(``section_quaternion``), calls this kernel and maps the rotational forces back
to the node frames, ``S_θ,node = A(o_a) S_θ,section`` (``to_node_frame``),
because ``δθ_section = A(o_a)ᵀ δθ_node``; a tangent of this kernel transforms
as ``K_node = T K_sec Tᵀ``, ``T = blockdiag(I, A(o_1), I, A(o_2))``.  ``psi0``
and ``gamma0`` stay inputs (computed from the section frames at rest, 0 and E1
to round-off for a Beam2 of the Domain).
"""

from __future__ import annotations

import sympy as sp

from derivations.codegen import Kernel, Stager, render_kernel, render_module, vector
from derivations.soa import render_short_series, render_soa_kernel
from derivations.rotation_maps import (
    USER_FUNCTIONS,
    atan2_quadrant,
    exp_matrix,
    log_quaternion,
    quat_conj,
    quat_mul,
    right_jacobian,
    right_jacobian_inverse,
    rotation_matrix,
)


def two_node_start():
    """What every two-node beam derivation starts from: the kernel inputs (positions, section
    quaternions, ``L0``, ``ψ0``, ``Γ0``, stiffness ``c``), ``C_Γ``, ``C_K``, and a :class:`Stager` with
    the stages ``A1 = A(q1)``, ``r = q1* ⊗ q2`` and ``ψ = log r`` (shortest branch) defined."""
    x1, x2 = sp.Matrix(vector("x1", 3)), sp.Matrix(vector("x2", 3))
    q1, q2 = vector("q1", 4), vector("q2", 4)
    L0 = sp.Symbol("L0", positive=True)
    psi0, gamma0 = sp.Matrix(vector("psi0", 3)), sp.Matrix(vector("gamma0", 3))
    c = vector("c", 6)
    st = Stager()
    A1 = st.define("A1", rotation_matrix(q1))
    r = st.define("r", quat_mul(quat_conj(q1), q2))
    psi = st.define("psi", sp.Matrix(log_quaternion(r)))
    return x1, x2, q1, q2, L0, psi0, gamma0, c, sp.diag(*c[:3]), sp.diag(*c[3:]), st, A1, psi


def beam2_quantities():
    """Symbolic inputs, element quantities (strains, forces, energy) and the stages.

    Intermediate quantities (``A1``, ``r``, ``psi``, ``E`` …) are named symbols
    defined in stages, so the expressions stay small and the emitted code reads
    like the derivation above.
    """
    x1, x2, q1, q2, L0, psi0, gamma0, c, CG, CK, st, A1, psi = two_node_start()
    E = st.define("E", exp_matrix(psi / 2))
    R = st.define("R", E * E)
    Am = st.define("Am", A1 * E)
    gamma_hat = st.define("gh", Am.T * (x2 - x1) / L0)
    Gamma = st.define("Gamma", gamma_hat - gamma0)
    Kappa = st.define("Kappa", (psi - psi0) / L0)
    N = st.define("N", CG * Gamma)
    M = st.define("M", CK * Kappa)

    f = st.define("f", L0 * N.cross(gamma_hat))
    g = st.define("g", M + right_jacobian(psi / 2).T * f / 2)
    s_theta2 = st.define("st2", right_jacobian_inverse(psi).T * g)
    s_theta1 = E * f - R * s_theta2
    n = Am * N
    S = list(-n) + list(s_theta1) + list(n) + list(s_theta2)
    U = L0 / 2 * ((Gamma.T * CG * Gamma)[0] + (Kappa.T * CK * Kappa)[0])
    inputs = dict(x1=x1, x2=x2, q1=q1, q2=q2, L0=L0, psi0=psi0, gamma0=gamma0, c=c)
    quantities = dict(S=S, U=U, Gamma=Gamma, Kappa=Kappa, N=N, M=M, psi=psi, gamma_hat=gamma_hat)
    return inputs, quantities, st.stages


def kernel_arguments(inp) -> list:
    """The Beam2 kernels' inputs, in order, with their descriptions (shared by the tangent kernel)."""
    return [
        ("x1", list(inp["x1"]), "position of node 1 (inertial) [m]"),
        ("x2", list(inp["x2"]), "position of node 2 (inertial) [m]"),
        ("q1", inp["q1"], "Euler parameters of the section triad at end 1, p1 = q_node1 ⊗ o1"),
        ("q2", inp["q2"], "Euler parameters of the section triad at end 2, p2 = q_node2 ⊗ o2"),
        ("L0", inp["L0"], "reference length [m]"),
        ("psi0", list(inp["psi0"]), "reference relative rotation ψ0 = log(A1ᵀA2) of the section triads at rest (0: straight) [rad]"),
        ("gamma0", list(inp["gamma0"]), "reference Γ0 = Amᵀx' at rest (E1 for a straight beam)"),
        ("c", inp["c"], "section stiffness EA, GA2, GA3 [N], GJ, EI2, EI3 [N m²]"),
    ]


def _vectorisable(expr):
    """``expr`` with libm's ``atan2`` replaced by ``atan2_quadrant`` (arithmetic only, derivations/atan2.py):
    the force kernel's half angle, ``atan2(|e|, σ e0)``, has both arguments ≥ 0, and the
    structure-of-arrays kernel (:func:`generate_soa`) then needs no scalar loop for it."""
    return expr.replace(sp.atan2, lambda y, x: atan2_quadrant(y, x))


def kernels() -> list[Kernel]:
    """The force kernel ``internal_forces`` (its half angle by ``atan2_quadrant``; the tangent kernels,
    derivations/tangents.py, differentiate :func:`beam2_quantities` and keep libm's ``atan2``)."""
    inp, out, stages = beam2_quantities()
    out = {name: [_vectorisable(e) for e in value] if isinstance(value, list) else _vectorisable(value)
           for name, value in out.items()}
    stages = [(syms, [_vectorisable(e) for e in exprs]) for syms, exprs in stages]
    args = kernel_arguments(inp)
    return [
        Kernel(
            "internal_forces",
            "Beam2 internal nodal forces (the exact gradient of the strain energy), strains, resultants.\n\n"
            "    Paper eq. (3): the vector S of ``M a + S = F``.  Order of ``s``:\n"
            "    S_u1 (inertial, N), S_θ1 (section frame of end 1, N m), S_u2, S_θ2 (section frame of end 2).",
            args,
            [("s", out["S"], "internal forces [S_u1, S_θ1, S_u2, S_θ2] (12,)"),
             ("strain", list(out["Gamma"]) + list(out["Kappa"]), "Γ (3) then K (3) at the midpoint [-, 1/m]"),
             ("stress", list(out["N"]) + list(out["M"]), "N (3) [N] then M (3) [N m], section frame")],
            (out["U"], "strain energy U [J]"),
            stages,
        ),
    ]


def generate() -> str:
    """Source of ``reference/generated/beam2.py``."""
    parts = [render_kernel(k, USER_FUNCTIONS) for k in kernels()]
    return render_module(
        "derivations/beam2.py",
        "Beam2 element arrays: internal forces (exact energy gradient), strain energy, resultants.\n\n"
        "See derivations/beam2.py for the derivation.",
        parts,
        imports=(
            "import math",
            "",
            "from reference.generated.rotation_maps import (",
            "    atan2_quadrant, branch_sign, c_asinc, c_cosc, c_jinv, c_sinc, c_sinc3,",
            ")",
            "from reference.jit import kernel",
        ),
    )


SOA_BLOCK = 64
"""Elements per call of the structure-of-arrays kernel (:func:`generate_soa`): its rows of 64 values
(45 rows, 23 kB) stay in the first-level cache (32 kB and more)."""
SOA_FIXED = ("L0", "psi0", "gamma0", "c")
"""The inputs the structure-of-arrays kernel reads from rows filled once, at the model's assembly
(``Beam2Data.blocked``), instead of gathering them at every step."""


def generate_soa() -> str:
    """Source of ``reference/generated/beam2_soa.py``: :func:`kernels`' ``internal_forces`` as a
    structure-of-arrays kernel over blocks of :data:`SOA_BLOCK` elements (derivations/soa.py).

    Its outputs are the forces ``s`` and the energy only: the explicit step reads nothing else (the
    strains and resultants of an output come from the per-element kernel, ``Beam2Formulation.resultants``).
    """
    from derivations.rotation_maps import COEFFICIENTS

    (k,) = kernels()
    k = Kernel(k.name, k.doc, k.inputs, [o for o in k.outputs if o[0] == "s"], k.returns, k.stages)
    coefficients = {c.name: c for c in COEFFICIENTS if c.name in USER_FUNCTIONS}
    source, layout = render_soa_kernel(k, coefficients, SOA_BLOCK, USER_FUNCTIONS, SOA_FIXED,
                                       {"atan2_quadrant": "atan2_quadrant_vector"})
    constants = [f"BLOCK = {SOA_BLOCK}", '"""Elements per call of :func:`internal_forces_soa` at most."""',
                 f"ROWS = {layout['rows']}", '"""Rows of its array ``v`` (each ``BLOCK`` long)."""',
                 f"FIXED_ROWS = {layout['fixed_rows']}",
                 '"""Rows of a block of its array ``u`` (the inputs that never change, each ``BLOCK`` long)."""']
    for name, first, _ in layout["inputs"] + layout["outputs"]:
        constants += [f"ROW_{name.upper()} = {first}", f'"""First row of ``{name}``."""']
    for name, first, _ in layout["fixed"]:
        constants += [f"FIXED_{name.upper()} = {first}", f'"""First row of ``{name}`` in a block of ``u``."""']
    series = [render_short_series(c) for c in COEFFICIENTS if c.name in source]
    select = ('@inlined\ndef branch_sign_select(x):\n    """``branch_sign`` inlined: a select in a vector loop."""\n'
              "    if x >= 0.0:\n        return 1.0\n    return -1.0\n\n\n"
              "atan2_quadrant_vector = inlined(atan2_quadrant)\n"
              '"""``atan2_quadrant`` inlined into the vector loops (the same arithmetic: the same bits)."""\n')
    return render_module(
        "derivations/beam2.py",
        "Beam2 internal forces as a structure-of-arrays kernel: the arithmetic of ``beam2.internal_forces``\n"
        "over a block of elements in loops the compiler vectorises across the elements.\n\n"
        "See derivations/beam2.py for the derivation and derivations/soa.py for the loops.",
        ["\n".join(constants) + "\n"] + series + [select, source],
        imports=(
            "import math",
            "",
            "from reference.generated.rotation_maps import (",
            "    atan2_quadrant, branch_sign, c_asinc, c_cosc, c_jinv, c_sinc, c_sinc3,",
            ")",
            "from reference.jit import inlined, vector_kernel",
        ),
    )
