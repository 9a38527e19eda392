"""Parameter derivatives of the element forces (issue 40; docs/formulation.md §14), in sympy.

For each element family the derivative of the internal force vector S with respect to every section
stiffness entry ``c = (EA, GA2, GA3, GJ, EI2, EI3)`` at once, ``∂S/∂c`` (a dofs × 6 block per element), at a
fixed configuration.  It is taken by the chain rule through the force kernel's own stages (forward mode,
:func:`forward_derivative`): each staged quantity ``y_i = f_i(inputs, y_<i)`` that depends on c gets the
staged derivatives ::

    ∂y_i/∂c_j = ∂f_i/∂c_j + Σ_k ∂f_i/∂y_k · ∂y_k/∂c_j

and the forces' derivatives are the same sums over the stages they read.  The stiffness enters the forces only
through the section resultants ``N = C_Γ Γ``, ``M = C_K K`` (Beam2, beam2_se3: derivations/beam2.py,
derivations/beam2_se3.py) or each Gauss term's gradient (beam3: derivations/beam3.py), so S is linear in c:
``∂S/∂c`` does not depend on c and the kernels do not take it.  The rotation maps' coefficient functions
(``c_sinc(|ψ|)`` …) have arguments that do not depend on c, so no coefficient is differentiated.

:func:`generate` writes ``reference/generated/sensitivities.py``; the reference path runs it on all elements at
once (:mod:`reference.plain.vectorise`, :func:`reference.plain.elements.element_stiffness_derivatives`).
"""

from __future__ import annotations

import re

import sympy as sp

from derivations.codegen import Kernel, render_kernel, render_module

STIFFNESS = ("EA", "GA2", "GA3", "GJ", "EI2", "EI3")
"""The section entries the kernels differentiate by, in the order of the kernels' columns (the ``c`` input of
the force kernels)."""


def _total(expr, wrt, known) -> list:
    """``d expr / d wrt_j`` for every j: the partial derivatives and the chain through the staged symbols
    ``known`` (symbol → its derivatives, one per j)."""
    deps = [s for s in expr.free_symbols if s in known]
    out = []
    for j, w in enumerate(wrt):
        d = sp.diff(expr, w) + sum((sp.diff(expr, s) * known[s][j] for s in deps), sp.S.Zero)
        if d.has(sp.Derivative, sp.Subs):
            raise ValueError(f"the derivative by {w} reaches a function's argument: {expr}")
        out.append(d)
    return out


def forward_derivative(stages, outputs, wrt, prefix: str = "d"):
    """The stages extended with the staged derivatives by ``wrt`` and the outputs' derivatives.

    Parameters
    ----------
    stages : list of (list of Symbol, list of Expr)
        A force kernel's stages (:class:`derivations.codegen.Stager`).
    outputs : list of Expr
        The expressions to differentiate (in the stages' symbols).
    wrt : list of Symbol
        The parameters.
    prefix : str
        The derivative symbols are named ``{prefix}{j}_{symbol}``.

    Returns
    -------
    stages : list
        The stages the derivatives need (the originals they read and the new derivative stages), in order.
    derivatives : list of Expr
        ``d outputs[i] / d wrt[j]`` at position ``i * len(wrt) + j``.
    """
    known, extended = {}, []
    for syms, exprs in stages:
        extended.append((syms, exprs))
        new_syms, new_exprs = [], []
        for sym, expr in zip(syms, exprs):
            ds = _total(expr, wrt, known)
            if all(d == 0 for d in ds):
                continue
            known[sym] = []
            for j, d in enumerate(ds):
                if d == 0:
                    known[sym].append(sp.S.Zero)
                    continue
                s = sp.Symbol(f"{prefix}{j}_{sym.name}", real=True)
                known[sym].append(s)
                new_syms.append(s)
                new_exprs.append(d)
        if new_syms:
            extended.append((new_syms, new_exprs))
    derivatives = [d for expr in outputs for d in _total(sp.sympify(expr), wrt, known)]
    return needed_stages(extended, derivatives), derivatives


def needed_stages(stages, outputs) -> list:
    """The stages ``outputs`` read, directly or through other stages (each stage cut to the symbols needed)."""
    defined = {sym: expr for syms, exprs in stages for sym, expr in zip(syms, exprs)}
    need, todo = set(), [s for e in outputs for s in sp.sympify(e).free_symbols if s in defined]
    while todo:
        sym = todo.pop()
        if sym not in need:
            need.add(sym)
            todo += [s for s in defined[sym].free_symbols if s in defined and s not in need]
    out = []
    for syms, exprs in stages:
        kept = [(s, e) for s, e in zip(syms, exprs) if s in need]
        if kept:
            out.append(([s for s, _ in kept], [e for _, e in kept]))
    return out


def _kernel(name, family, inputs, forces, stages, c, n_dofs) -> Kernel:
    """The kernel ``name`` writing ``∂S/∂c`` (``n_dofs`` × 6, row-major) of the force expressions ``forces``."""
    used, derivatives = forward_derivative(stages, forces, list(c))
    inputs = [arg for arg in inputs if arg[0] != "c"]
    return Kernel(
        name,
        f"∂S/∂c of the {family} internal forces S by the six section stiffnesses c at a fixed configuration.\n\n"
        "    ``c = (EA, GA2, GA3, GJ, EI2, EI3)``; S is linear in c (derivations/sensitivities.py), so this\n"
        f"    does not depend on c.  Row i (the order of ``internal_forces``' ``s``), column j: ``∂S_i/∂c_j``\n"
        "    [m (forces by EA…), 1/m (moments by EI…) and the mixed units of the same forms].",
        inputs,
        [("ds", derivatives, f"∂S/∂c ({n_dofs} × 6, row-major)")],
        None,
        used,
    )


def kernels() -> list[Kernel]:
    """``beam2_section_derivative``, ``beam2_se3_section_derivative``, ``beam3_section_derivative``."""
    from derivations import beam2, beam2_se3, beam3

    inp, out, stages = beam2.beam2_quantities()
    vect = beam2._vectorisable
    stages = [(syms, [vect(e) for e in exprs]) for syms, exprs in stages]
    args = beam2.kernel_arguments(inp)
    found = [_kernel("beam2_section_derivative", "Beam2", args, [vect(e) for e in out["S"]], stages, inp["c"], 12)]
    inp, out, stages = beam2_se3.se3_quantities()
    found.append(_kernel("beam2_se3_section_derivative", "beam2_se3", beam2.kernel_arguments(inp), out["S"], stages,
                         inp["c"], 12))
    forces = beam3.beam3_kernels()[0]
    (_, s_exprs, _), c = forces.outputs[0], dict((n, v) for n, v, _ in forces.inputs)["c"]
    found.append(_kernel("beam3_section_derivative", "beam3", forces.inputs, s_exprs, forces.stages, c, 18))
    return found


HELPERS = {
    "reference.generated.rotation_maps": ("atan2_quadrant", "branch_sign", "c_asinc", "c_cosc", "c_jinv", "c_sinc",
                                          "c_sinc3"),
    "reference.generated.tangents": ("c_cosc_d", "c_jinv_d", "c_sinc3_d"),
    "reference.generated.beam2_se3": ("c_jinv_dd",),
    "reference.generated.beam3": ("c_cosc_dd", "c_sinc_d", "c_sinc_dd", "c_sinc3_dd"),
}
"""Where the coefficient functions the kernels may call are generated (imported only if called)."""


def generate() -> str:
    """Source of ``reference/generated/sensitivities.py``."""
    from derivations import beam2_se3, beam3

    user = sorted(set(beam2_se3.USER) | set(beam3.USER))
    parts = [render_kernel(k, user) for k in kernels()]
    body = "\n".join(parts)
    imports = ["import math", ""]
    for module, names in HELPERS.items():
        called = [n for n in names if re.search(rf"\b{n}\(", body)]
        if called:
            imports.append(f"from {module} import {', '.join(called)}")
    imports.append("from reference.jit import kernel")
    return render_module(
        "derivations/sensitivities.py",
        "∂S/∂c: the element families' internal forces differentiated by the section stiffnesses.\n\n"
        "See derivations/sensitivities.py for the derivation.",
        parts,
        imports=tuple(imports),
    )
