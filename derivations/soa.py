"""Structure-of-arrays (SoA) kernels: one element kernel's arithmetic, run over a block of elements in
loops the compiler vectorises across the elements.

:func:`render_soa_kernel` takes a :class:`~derivations.codegen.Kernel` (the per-element kernel's own
stages and outputs, the same one common-subexpression pass of
:func:`derivations.codegen._shared_subexpressions`) and emits one function ``name(n, v)`` working on
``n ≤ block`` elements whose inputs, intermediate values and outputs are rows of one flat array
``v``: component ``k`` of element ``e`` at ``v[k*block + e]``.  Every statement is the per-element
kernel's statement, printed the same way, so both give the same numbers bit for bit.

A loop the compiler can vectorise may hold arithmetic, ``sqrt``, ``abs`` and selects, but no call of
the C maths library (``atan2``, ``sin``, ``cos``: LLVM has no vector form of them here).  So the
statements are split into rounds; round r is a vector loop then a scalar loop:

* ``atan2`` (libm's) is computed in the scalar loop of the first round its arguments are ready in (the
  call alone: its arguments and what uses the angle are other statements); a kernel that calls a
  function of arithmetic only instead (the Beam2 kernels' ``atan2_quadrant``, derivations/atan2.py)
  keeps it in the vector loops, under the inlined name ``vector_names`` gives;
* a statement with a coefficient function ``c_*(a)`` (a removable singularity at 0: a short Taylor
  series, then a long one, below a threshold, the closed form with ``sin``/``cos`` above) is computed
  in the vector loop with the short series only (``c_*_short``), and the scalar loop then recomputes
  it with the full function for the elements whose argument is at or beyond the short series' range
  (none for the small relative rotations of a fine mesh: a compare per element).  The long series is
  not in the vector loop: a vector loop computes both sides of a select, so every element would pay
  for the long series that a fine mesh never takes (measured: 48 → 37 ns per Beam2 element);
* every other statement goes into the vector loop of the latest round that still precedes its
  first use (so that few values cross loops); a value used in another loop than its own is
  stored in a row of ``v``, the others stay in registers.
"""

from __future__ import annotations

import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.printing.pycode import PythonCodePrinter

from derivations.codegen import Coefficient, Kernel, _printer, _shared_subexpressions, coefficient_series


def render_short_series(coef: Coefficient) -> str:
    """An inlined ``<name>_short(a)``: ``coef``'s short Taylor series, the same text as the full function's
    first branch (exact for |a| below the short series' threshold only: the kernel's scalar loop takes
    the full function beyond it)."""
    small, first, _ = coefficient_series(coef)
    return (
        "@inlined\n"
        f"def {coef.name}_short(a):\n"
        f'    """``{coef.name}(a)`` for |a| < {small!r}: its series of order {coef.short_order} alone (arithmetic, no select,\n'
        f'    no libm call), so that the loop calling it vectorises and computes nothing more."""\n'
        f"    return {first}\n"
    )


def _calls(expr, names) -> list:
    return [f for f in expr.atoms(AppliedUndef) if f.func.__name__ in names]


def _isolate_atan2(stmts):
    """Each ``atan2(y, x)`` as a statement of its own, its arguments as statements before it: only the
    call itself is left to a scalar loop (the arguments, and a coefficient function of the angle,
    go to the vector loops)."""
    out, k = [], 0
    for sym, expr in stmts:
        for call in sorted(expr.atoms(sp.atan2), key=sp.default_sort_key):
            args = []
            for arg in call.args:
                if not arg.is_Symbol:
                    name = sp.Symbol(f"atan2_arg{k}_{len(args)}", real=True)
                    out.append((name, arg))
                    arg = name
                args.append(arg)
            angle = sp.Symbol(f"atan2_{k}", real=True)
            out.append((angle, sp.atan2(*args)))
            expr = expr.subs(call, angle)
            k += 1
        out.append((sym, expr))
    return out


def _isolate_coefficient_arguments(stmts, coefficients):
    """The argument of every coefficient function that is not a symbol (``c_asinc(atan2_quadrant(…))``) as
    a statement of its own before its user: the scalar loop that recomputes the coefficient beyond its
    series' range then reads the argument from a row instead of computing it again."""
    out, k = [], 0
    for sym, expr in stmts:
        for call in sorted(_calls(expr, coefficients), key=sp.default_sort_key):
            if not call.args[0].is_Symbol:
                name = sp.Symbol(f"coef_arg{k}", real=True)
                out.append((name, call.args[0]))
                expr = expr.subs(call.args[0], name)
                k += 1
        out.append((sym, expr))
    return out


def _plan(stmts, coefficients):
    """Loop index of every statement: vector loop of round r = 2r, scalar loop = 2r + 1."""
    defined = {s for s, _ in stmts}
    kind, deps, ready, loop = {}, {}, {}, {}
    for sym, expr in stmts:
        kind[sym] = "scalar" if expr.has(sp.atan2) else "coef" if _calls(expr, coefficients) else "plain"
        deps[sym] = expr.free_symbols & defined
        r = max((ready[d] for d in deps[sym]), default=0)
        loop[sym] = 2 * r + (1 if kind[sym] == "scalar" else 0)
        ready[sym] = r + (0 if kind[sym] == "plain" else 1)
    users: dict = {s: [] for s, _ in stmts}
    for sym, _ in stmts:
        for d in deps[sym]:
            users[d].append(sym)
    last = max(loop.values())
    for sym, _ in reversed(stmts):  # sink plain statements towards their first use, outputs to the end
        if kind[sym] != "plain":
            continue
        first = min((loop[u] for u in users[sym]), default=last)
        loop[sym] = max(loop[sym], first - first % 2)
    used_in: dict = {s: set() for s, _ in stmts}
    for sym, _ in stmts:
        for d in deps[sym]:
            used_in[d].add(loop[sym])
            if kind[sym] == "coef":
                used_in[d].add(loop[sym] + 1)  # the scalar loop's recomputation
    stored = {s for s, _ in stmts if kind[s] == "coef" or used_in[s] - {loop[s]}}
    return kind, loop, stored


def render_soa_kernel(kernel: Kernel, coefficients: dict, block: int, user_functions=(), fixed=(),
                      vector_names=None) -> tuple[str, dict]:
    """Source of the SoA form ``<kernel.name>_soa(n, v)`` of ``kernel`` (``<kernel.name>_soa(n, v, u)``
    with ``fixed`` inputs), and its row layout.

    Parameters
    ----------
    kernel : Kernel
        The per-element kernel (inputs, outputs, optional return value, stages).
    coefficients : dict of str to Coefficient
        The coefficient functions the kernel calls (their series go into the vector loops).
    block : int
        Elements per call at most (the row length of ``v``).
    user_functions : sequence of str
        The names the per-element kernel calls (printed as they are in the scalar loops).
    fixed : sequence of str
        Inputs that do not change from call to call (reference values, stiffness): read from the rows of a
        second array ``u`` (component k of element e at ``u[k*block + e]``), which the caller fills once
        instead of gathering them into ``v`` at every call.  (Its own array, not an offset into a larger
        one: an index that the compiler cannot prove non-negative takes numba's wrap-around select on
        every load, and the loop then ran at half speed.)
    vector_names : dict of str to str, optional
        Names under which the vector loops call some of the ``user_functions`` (their inlined forms).

    Returns
    -------
    source : str
    layout : dict
        ``"inputs"``: ``(name, first row, count)`` of every input of ``v``, in order; ``"fixed"`` the same
        of the rows of ``u`` (``"fixed_rows"`` of them); ``"outputs"`` the same of every output (the return
        value last, one row, named ``"returns"``); ``"rows"``: rows of ``v``.
    """
    outputs = [(name, len(comps)) for name, comps, _ in kernel.outputs]
    exprs = [e for _, comps, _ in kernel.outputs for e in comps]
    if kernel.returns is not None:
        exprs.append(kernel.returns[0])
        outputs.append(("returns", 1))
    staged, rest, reduced = _shared_subexpressions(kernel.stages, exprs, sp.numbered_symbols("t"))
    out_syms = [sp.Symbol(f"out_{k}", real=True) for k in range(len(reduced))]
    stmts = _isolate_atan2(list(staged) + list(rest) + list(zip(out_syms, reduced)))
    stmts = _isolate_coefficient_arguments(stmts, set(coefficients))

    layout, row = {"inputs": [], "fixed": [], "outputs": []}, 0
    input_row, fixed_row = {}, {}
    for name, comps, _ in kernel.inputs:
        comps = comps if isinstance(comps, (list, tuple)) else [comps]
        rows = fixed_row if name in fixed else input_row
        first = len(fixed_row) if name in fixed else row
        layout["fixed" if name in fixed else "inputs"].append((name, first, len(comps)))
        for s in comps:
            rows[s] = first
            first += 1
        row = row if name in fixed else first
    layout["fixed_rows"] = len(fixed_row)
    out_row = {}
    k = 0
    for name, count in outputs:
        layout["outputs"].append((name, row, count))
        for _ in range(count):
            out_row[out_syms[k]] = row
            row, k = row + 1, k + 1

    kind, loop, stored = _plan(stmts, set(coefficients))
    temp_row = {}
    for sym, _ in stmts:
        if sym in stored and sym not in out_row:
            temp_row[sym] = row
            row += 1
    layout["rows"] = row
    where = {**input_row, **temp_row, **out_row}

    scalar_printer = _printer(user_functions)
    vector_printer = PythonVectorPrinter(user_functions, coefficients, vector_names or {})

    def at(sym):
        if sym in fixed_row:
            return f"u[{fixed_row[sym] * block} + e]" if fixed_row[sym] else "u[e]"
        return f"v[{where[sym] * block} + e]" if where[sym] else "v[e]"

    body = []
    n_loops = max(loop.values()) + 2
    for lp in range(n_loops):
        in_loop = [(s, e) for s, e in stmts if loop[s] == lp]
        fixes = [(s, e) for s, e in stmts if kind[s] == "coef" and loop[s] + 1 == lp]
        if not in_loop and not fixes:
            continue
        local = {s for s, _ in in_loop}
        needed = set().union(*(e.free_symbols for _, e in in_loop + fixes)) - local
        body.append("    for e in range(n):")
        body += [f"        {s.name} = {at(s)}" for s in sorted(needed, key=lambda s: (s not in fixed_row,
                                                                                   where.get(s, fixed_row.get(s))))]
        printer = vector_printer if lp % 2 == 0 else scalar_printer
        for sym, expr in in_loop:
            text = printer.doprint(expr)
            if sym in out_row:
                body.append(f"        {at(sym)} = {text}")
                continue
            body.append(f"        {sym.name} = {text}")
            if sym in stored:
                body.append(f"        {at(sym)} = {sym.name}")
        for sym, expr in fixes:
            limits = sorted({(scalar_printer.doprint(f.args[0]), coefficient_series(coefficients[f.func.__name__])[0])
                             for f in _calls(expr, set(coefficients))})
            cond = " or ".join(f"abs({arg}) >= {thr!r}" for arg, thr in limits)
            body.append(f"        if {cond}:")
            body.append(f"            {at(sym)} = {scalar_printer.doprint(expr)}")

    doc = [
        f'    """{kernel.doc.strip()}', "",
        f"    Structure of arrays: the same arithmetic as ``{kernel.name}`` for ``n`` ≤ {block} elements at once,",
        f"    component k of element e at ``v[k*{block} + e]`` (derivations/soa.py).  Rows of ``v``:",
    ]
    def rows(items, what):
        return [f"    {first}–{first + count - 1}: {what} ``{name}``" if count > 1 else f"    {first}: {what} ``{name}``"
                for name, first, count in items]

    doc += rows(layout["inputs"], "input") + rows(layout["outputs"], "output")
    doc.append(f"    {len(input_row) + len(out_row)}–{row - 1}: values passed between the loops.")
    if fixed_row:
        doc += ["    Rows of ``u`` (filled once by the caller):"] + rows(layout["fixed"], "input")
    doc += ["", "    Parameters (in this order)", "    ----------",
            "    n : int", f"        elements in this call (≤ {block})",
            f"    v : array ({row * block},)", "        the rows above: inputs read, outputs written"]
    if fixed_row:
        doc += [f"    u : array ({len(fixed_row) * block},)", "        the rows of the fixed inputs (read only)"]
    doc.append('    """')
    args = "n, v, u" if fixed_row else "n, v"
    lines = ["@vector_kernel", f"def {kernel.name}_soa({args}):"] + doc + body
    return "\n".join(lines) + "\n", layout


class PythonVectorPrinter:
    """The per-element kernel's printer for a vector loop: a coefficient function ``c`` is printed as
    ``c_short`` (:func:`render_short_series`), ``branch_sign`` as the inlined ``branch_sign_select``."""

    def __init__(self, user_functions, coefficients, vector_names=None):
        names = {name: name for name in user_functions}
        names.update({name: f"{name}_short" for name in coefficients})
        names.update(vector_names or {})
        if "branch_sign" in names:
            names["branch_sign"] = "branch_sign_select"
        self._printer = PythonCodePrinter({"fully_qualified_modules": True, "user_functions": names, "strict": True})

    def doprint(self, expr) -> str:
        return self._printer.doprint(expr)
