"""Formula time functions: a user's expression in t, its derivative and its integral.

A deck may give a time function as a formula, ``expr = "sin(3*t)**2"``.  The
text is read with sympy's parser under three restrictions, so that no user text
is ever executed: every token must be a number, an operator, a parenthesis,
the variable ``t``, the constants ``pi`` and ``E`` or a function of
:data:`FUNCTIONS`; the parser gets no builtins and no automatic symbols; the
result must be a real expression whose only free symbol is ``t``.

The derivative is ``sympy.diff`` and the integral ``∫_0^t f`` the antiderivative
``sympy.integrate`` finds, minus its value at 0 (refused when sympy finds none
in closed form with the functions below).  Why the three are not emitted as
numba source like the derived kernels of ``reference/generated/``: decks arrive
at run time, and the compiled time-stepping kernel calls every time function
through one routine (:func:`reference.interactions.tf_value`), so new source
would mean recompiling the whole step for every formula (tens of seconds, and a
cache keyed by deck).  Instead each expression is compiled once into a short
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
    t = _symbol()
    names = {"t": t, "pi": sp.pi, "E": sp.E, "abs": sp.Abs, "sign": sp.sign}
    names.update({f: getattr(sp, f) for f in FUNCTIONS if f not in names})
    glob = {"__builtins__": {}, "Integer": sp.Integer, "Float": sp.Float, "Rational": sp.Rational}
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
