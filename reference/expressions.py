"""Formula time functions: a user's expression in t, its derivative and its integral.

A deck may give a time function as a formula, ``expr = "sin(3*t)**2"``.  The
text is read with sympy's parser under three restrictions, so that no user text
is ever executed: every token must be a number, an operator, a parenthesis,
the variable ``t``, the constants ``pi`` and ``E`` or a function of
:data:`FUNCTIONS`; the parser gets no builtins and no automatic symbols; the
result must be a real expression whose only free symbol is ``t``.

**Pathological formulas** are refused before sympy evaluates anything (it would compute
``9**9**9``, an integer of 370 million digits, for minutes): the text is parsed unevaluated
and :func:`_bounded` walks the tree with an upper bound of log₁₀|value| for every constant
part.  Refused: a formula over :data:`MAX_CHARS` characters or :data:`MAX_NODES` operations (a
hand-written time function is a line); a constant exponent above :data:`MAX_EXPONENT` in
magnitude (``t**1e9`` overflows the double range for t > 1.0000007, ``t**100`` only for
t > 1200); a constant above 1e300 (the double range ends at 1.8e308); an exponential (``exp``,
``sinh``, ``cosh``, a power with t in the exponent) of an exponential — ``exp(exp(t))``
overflows for t > 6.6 and no loading history needs it.

The derivative is ``sympy.diff`` and the integral ``∫_0^t f`` the antiderivative
``sympy.integrate`` finds, minus its value at 0 (refused when sympy finds none
in closed form with the functions below).  Why the three are not emitted as
numba source like the derived kernels of ``reference/generated/``: decks arrive
at run time, and the compiled time-stepping kernel calls every time function
through one routine (:func:`reference.interactions.tf_value`), so new source
would mean recompiling the whole step for every formula (docs/benchmarks.md §9,
and a cache keyed by deck).  Instead each expression is compiled once into a short
postfix (reverse Polish) program of plain numbers, stored in the time
function's parameter row, and :func:`rpn_eval` — compiled once with the engine —
runs it: the same double-precision arithmetic as generated code, no compilation
per deck, and it runs unchanged with ``NUMBA_DISABLE_JIT=1``.

Parameter row of an expression time function::

    [n_value, n_derivative, n_integral (−1: none), depth, program...]

each program a sequence of ``(opcode, operand)`` pairs (value, then derivative,
then integral); ``depth`` is the largest stack the programs need.
"""

from __future__ import annotations

import functools
import io
import math
import tokenize

import numpy as np

from reference.jit import kernel

PUSH, TIME, ADD, MUL, POW = 0, 1, 2, 3, 4
UNARY = {"sin": 10, "cos": 11, "tan": 12, "exp": 13, "log": 14, "sqrt": 15, "sinh": 16, "cosh": 17,
         "tanh": 18, "asin": 19, "acos": 20, "atan": 21, "Abs": 22, "sign": 23}
FUNCTIONS = ("sin", "cos", "tan", "exp", "log", "sqrt", "sinh", "cosh", "tanh", "asin", "acos", "atan", "abs",
             "sign")
"""The functions a formula may call (``abs`` is read as sympy's ``Abs``)."""
CONSTANTS = ("pi", "E")
MAX_CHARS = 500
"""Longest formula [characters]."""
MAX_NODES = 200
"""Most operations, numbers and names in one formula."""
MAX_EXPONENT = 100.0
"""Largest magnitude of a constant exponent (module docstring)."""
MAX_MAGNITUDE = 300.0
"""Largest log₁₀ of a constant part (the double range ends at 10^308)."""
GROWING = ("exp", "sinh", "cosh")
OPERATORS = {"+", "-", "*", "/", "**", "^", "(", ")", ","}


class ExpressionError(ValueError):
    """A formula that cannot be used: it does not parse, uses an unknown name, or has no closed form."""


@kernel
def rpn_eval(code, start, n, depth, t):
    """Run the postfix program ``code[start : start + 2n]`` at time ``t`` (see the module docstring)."""
    stack = np.empty(max(depth, 1))
    top = 0
    for k in range(n):
        op = int(code[start + 2 * k])
        arg = code[start + 2 * k + 1]
        if op == PUSH:
            stack[top] = arg
            top += 1
        elif op == TIME:
            stack[top] = t
            top += 1
        elif op <= POW:
            b = stack[top - 1]
            a = stack[top - 2]
            top -= 1
            if op == ADD:
                stack[top - 1] = a + b
            elif op == MUL:
                stack[top - 1] = a * b
            else:
                stack[top - 1] = a**b
        else:
            a = stack[top - 1]
            if op == 10:
                r = math.sin(a)
            elif op == 11:
                r = math.cos(a)
            elif op == 12:
                r = math.tan(a)
            elif op == 13:
                r = math.exp(a)
            elif op == 14:
                r = math.log(a) if a > 0.0 else math.nan
            elif op == 15:
                r = math.sqrt(a) if a >= 0.0 else math.nan
            elif op == 16:
                r = math.sinh(a)
            elif op == 17:
                r = math.cosh(a)
            elif op == 18:
                r = math.tanh(a)
            elif op == 19:
                r = math.asin(a) if abs(a) <= 1.0 else math.nan
            elif op == 20:
                r = math.acos(a) if abs(a) <= 1.0 else math.nan
            elif op == 21:
                r = math.atan(a)
            elif op == 22:
                r = abs(a)
            else:
                r = 0.0 if a == 0.0 else math.copysign(1.0, a)
            stack[top - 1] = r
    return stack[0]


@kernel
def expression_value(p, t, which):
    """Value (``which`` 0), derivative (1) or integral from 0 (2) of an expression row ``p``."""
    nv, nd, ni, depth = int(p[0]), int(p[1]), int(p[2]), int(p[3])
    if which == 0:
        return rpn_eval(p, 4, nv, depth, t)
    if which == 1:
        return rpn_eval(p, 4 + 2 * nv, nd, depth, t)
    if ni < 0:
        return math.nan
    return rpn_eval(p, 4 + 2 * nv + 2 * nd, ni, depth, t)


def _symbol():
    import sympy as sp

    return sp.Symbol("t", real=True)


def parse(text: str):
    """The sympy expression of ``text`` (a formula in ``t``), or :class:`ExpressionError`."""
    import sympy as sp
    from sympy.parsing.sympy_parser import auto_number, convert_xor, parse_expr

    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("the expression is empty")
    allowed = set(FUNCTIONS) | set(CONSTANTS) | {"t"}
    try:
        for tok in tokenize.generate_tokens(io.StringIO(text).readline):
            if tok.type == tokenize.NAME and tok.string not in allowed:
                raise ExpressionError(f"unknown name {tok.string!r} in {text!r}: the variable is t; "
                                      f"functions: {', '.join(FUNCTIONS)}; constants: pi, E")
            if tok.type == tokenize.OP and tok.string not in OPERATORS:
                raise ExpressionError(f"operator {tok.string!r} is not allowed in {text!r}; "
                                      "use + - * / ** and parentheses")
            if tok.type not in (tokenize.NAME, tokenize.OP, tokenize.NUMBER, tokenize.NEWLINE, tokenize.NL,
                                tokenize.ENDMARKER, tokenize.INDENT, tokenize.DEDENT):
                raise ExpressionError(f"{text!r} is not a formula in t (unexpected {tok.string!r})")
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ExpressionError(f"{text!r} does not parse ({exc.args[0]})") from None
    if len(text) > MAX_CHARS:
        raise ExpressionError(f"the formula has {len(text)} characters, above the limit of {MAX_CHARS}; "
                              "split it into simpler time functions")
    t = _symbol()
    names = {"t": t, "pi": sp.pi, "E": sp.E, "abs": sp.Abs, "sign": sp.sign}
    names.update({f: getattr(sp, f) for f in FUNCTIONS if f not in names})
    glob = {"__builtins__": {}, "Integer": sp.Integer, "Float": sp.Float, "Rational": sp.Rational,
            "Add": sp.Add, "Mul": sp.Mul, "Pow": sp.Pow}
    short = text if len(text) <= 60 else text[:59] + "…"
    try:
        raw = parse_expr(text, local_dict=names, global_dict=glob, transformations=(auto_number, convert_xor),
                         evaluate=False)
    except Exception as exc:  # sympy reports malformed input with several exception types
        raise ExpressionError(f"{short!r} does not parse ({type(exc).__name__}: {str(exc)[:80]})") from None
    if isinstance(raw, sp.Basic):
        if sum(1 for _ in sp.preorder_traversal(raw)) > MAX_NODES:
            raise ExpressionError(f"{short!r} has more than {MAX_NODES} operations; split it into simpler "
                                  "time functions")
        problem = _bounded(raw, t)[1]
        if problem:
            raise ExpressionError(f"{short!r}: {problem}")
    try:
        expr = parse_expr(text, local_dict=names, global_dict=glob, transformations=(auto_number, convert_xor))
    except Exception as exc:  # sympy reports malformed input with several exception types
        raise ExpressionError(f"{text!r} does not parse ({type(exc).__name__}: {exc})") from None
    if not isinstance(expr, sp.Expr):
        raise ExpressionError(f"{text!r} is not a scalar formula")
    if expr.free_symbols - {t}:
        raise ExpressionError(f"{text!r} uses symbols {sorted(map(str, expr.free_symbols - {t}))}; only t is allowed")
    if expr.has(sp.I, sp.zoo, sp.nan, sp.oo):
        raise ExpressionError(f"{text!r} is not a finite real formula")
    return expr


def _bounded(e, t) -> tuple[float, str]:
    """``(bound, problem)`` of the unevaluated tree ``e``: an upper bound of log₁₀|value| if ``e``
    is constant (``-inf`` for 0, ``inf`` if it depends on t), and why the formula is refused
    (``""`` if it is not; rules in the module docstring)."""
    import sympy as sp

    if e.has(t):
        growth = isinstance(e, sp.Function) and type(e).__name__ in GROWING or \
            isinstance(e, sp.Pow) and e.args[1].has(t)
        for arg in e.args:
            if growth and any(isinstance(a, sp.Function) and type(a).__name__ in GROWING or
                              isinstance(a, sp.Pow) and a.args[1].has(t) for a in sp.preorder_traversal(arg)):
                return math.inf, "an exponential of an exponential overflows within a few units of t; simplify it"
        for arg in e.args:
            problem = _bounded(arg, t)[1]
            if problem:
                return math.inf, problem
        if isinstance(e, sp.Pow) and not e.args[1].has(t):
            return math.inf, _exponent(e.args[1], t)
        return math.inf, ""
    if isinstance(e, sp.Integer):
        return (-math.inf if e == 0 else (abs(int(e)).bit_length() - 1) * math.log10(2.0)), ""
    if isinstance(e, sp.Rational):
        return (abs(e.p).bit_length() - abs(e.q).bit_length() + 1) * math.log10(2.0), ""
    if isinstance(e, sp.Float):
        return (-math.inf if e == 0 else float(sp.log(abs(e), 10))), ""
    bounds = []
    for arg in e.args:
        bound, problem = _bounded(arg, t)
        if problem:
            return math.inf, problem
        bounds.append(bound)
    if isinstance(e, sp.Add):
        bound = max(bounds) + math.log10(len(bounds))
    elif isinstance(e, sp.Mul):
        bound = sum(b for b in bounds if b > -math.inf) if all(b > -math.inf for b in bounds) else -math.inf
    elif isinstance(e, sp.Pow):
        problem = _exponent(e.args[1], t)
        if problem:
            return math.inf, problem
        bound = abs(float(sp.N(e.args[1]))) * abs(bounds[0]) if bounds[0] > -math.inf else 0.0
    elif isinstance(e, sp.Function) and type(e).__name__ in GROWING:
        bound = bounds[0] if bounds[0] > 2.85 else abs(float(sp.N(e.args[0]))) / math.log(10.0)
    else:  # pi, E, and the functions that do not grow: at most their argument (or 1)
        bound = max([0.5] + bounds)
    if bound > MAX_MAGNITUDE:
        return math.inf, f"a constant part exceeds 1e{MAX_MAGNITUDE:.0f} (the double range ends at 1.8e308)"
    return bound, ""


def _exponent(e, t) -> str:
    """Why the constant exponent ``e`` is refused (above :data:`MAX_EXPONENT`), or ``""``."""
    import sympy as sp

    bound, problem = _bounded(e, t)
    if problem:
        return problem
    if bound > math.log10(MAX_EXPONENT) or abs(float(sp.N(e))) > MAX_EXPONENT:
        return f"an exponent above {MAX_EXPONENT:g} overflows the double range; use a smaller power"
    return ""


def compile_program(expr) -> tuple[list[float], int]:
    """Postfix program of a sympy expression: ``(flat (opcode, operand) list, stack depth)``."""
    import sympy as sp

    t = _symbol()
    code: list[float] = []
    depth = [0, 0]

    def push(op, arg=0.0, change=1):
        code.extend((float(op), float(arg)))
        depth[0] += change
        depth[1] = max(depth[1], depth[0])

    def emit(e):
        if not e.free_symbols:
            value = complex(sp.N(e, 17))
            if value.imag != 0.0 or not math.isfinite(value.real):
                raise ExpressionError(f"the constant {e} is not a finite real number")
            push(PUSH, value.real)
        elif e == t:
            push(TIME)
        elif isinstance(e, (sp.Add, sp.Mul)):
            args = e.args
            emit(args[0])
            for a in args[1:]:
                emit(a)
                push(ADD if isinstance(e, sp.Add) else MUL, change=-1)
        elif isinstance(e, sp.Pow):
            base, exp_ = e.args
            if exp_ == sp.Rational(1, 2):
                emit(base)
                push(UNARY["sqrt"], change=0)
            else:
                emit(base)
                emit(exp_)
                push(POW, change=-1)
        elif isinstance(e, sp.Function) and type(e).__name__ in UNARY and len(e.args) == 1:
            emit(e.args[0])
            push(UNARY[type(e).__name__], change=0)
        else:
            raise ExpressionError(f"cannot evaluate {e} (uses {type(e).__name__})")

    emit(expr)
    return code, depth[1]


def integral(expr):
    """``∫_0^t expr`` in closed form, or None if sympy finds none with the supported functions."""
    import sympy as sp

    t = _symbol()
    try:
        anti = sp.integrate(expr, t)
    except Exception:  # sympy's integrator raises several types on what it cannot do
        return None
    if anti.has(sp.Integral):
        return None
    result = sp.simplify(anti - anti.subs(t, 0)) if anti.count_ops() < 200 else anti - anti.subs(t, 0)
    try:
        compile_program(result)
    except ExpressionError:
        return None
    return result


@functools.lru_cache(maxsize=256)
def _parameters(text: str, with_integral: bool) -> tuple:
    return tuple(_build(text, with_integral))


def expression_parameters(text: str, with_integral: bool = False) -> np.ndarray:
    """Parameter row of the formula ``text`` (see the module docstring).

    Raises :class:`ExpressionError` when it does not parse, uses another symbol,
    or (``with_integral``) has no closed-form integral.  Cached by text.
    """
    return np.array(_parameters(text, bool(with_integral)), dtype=float)


def _build(text: str, with_integral: bool) -> np.ndarray:
    import sympy as sp

    expr = parse(text)
    value, d1 = compile_program(expr)
    derivative, d2 = compile_program(sp.diff(expr, _symbol()))
    integ, d3 = [], 0
    n_int = -1
    if with_integral:
        F = integral(expr)
        if F is None:
            raise ExpressionError(f"{text!r} has no closed-form integral with the supported functions "
                                  "(a velocity-mode drive needs ∫f); give the motion itself in position mode, "
                                  "or a formula sympy can integrate")
        integ, d3 = compile_program(F)
        n_int = len(integ) // 2
    head = [len(value) // 2, len(derivative) // 2, n_int, max(d1, d2, d3)]
    return np.array(head + value + derivative + integ, dtype=float)
