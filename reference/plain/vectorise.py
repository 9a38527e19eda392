"""The generated physics run on NumPy arrays, element-wise over many elements at once, without numba.

The sympy-generated kernels (``reference/generated/*.py``, from ``derivations/*.py``) are straight-line
scalar code: they read inputs by index (``x1[0]``), combine them with ``+ - * / **`` and ``math``
functions and a few small helper functions (``c_sinc``, ``c_asinc``, ``atan2_quadrant``, …), and write
outputs by index (``s[0] = …``).  The same code object, run with a NumPy ``math`` and NumPy versions of
the helpers, evaluates E elements at once when every input is passed in *structure-of-arrays* form: an
array input of k components as a (k, E) array (``x1[0]`` is then the E first coordinates), a scalar
input as an (E,) array, an output allocated (k, E).  :func:`plain` makes that twin of a kernel: it
rebinds the kernel's Python function (``dispatcher.py_func``; the function itself under
``NUMBA_DISABLE_JIT=1``) to new globals with :func:`types.FunctionType`, so that numba never compiles
anything (calling a numba dispatcher from Python would).

A helper with branches (``if abs(a) < 0.05: return <series>``, ``atan2_quadrant``'s argument
reduction) cannot take arrays as it is: its ``if`` statements are rewritten into element-wise selects
(:class:`_Selects`): every branch is evaluated for every element, and each element takes the value of
the branch its own arguments choose, the same value the scalar function returns for it.  A function
with loops, or ``if`` statements that do more than assign names and return, is not rewritten; its twin
calls the scalar function element after element (:func:`_element_by_element`, slow but exact).  The element,
joint, force and rotation kernels of ``reference/generated/`` are all straight-line (rebound) or rewritten; only
the compiled block loop ``beam2_soa.py``, which the reference path has no use for, has loops.

NumPy's fixed cost per operation (about a microsecond, whatever the array's length) outweighs the work on a
few elements: for fewer than :data:`LOOP_BELOW` elements the scalar function element after element in Python
is faster, and :func:`twin` picks that.  Results equal the compiled kernels' to round-off: NumPy's ``sin``,
``cos``, ``sqrt`` and ``**`` may differ from the C library's in the last bit (the element loop calls the C
library's, as the compiled kernels do).
"""

from __future__ import annotations

import ast
import dis
import functools
import inspect
import math
import textwrap
import types

import numpy as np

_RENAMED = {"atan2": "arctan2", "atan": "arctan", "asin": "arcsin", "acos": "arccos", "fabs": "abs",
            "pow": "power", "atanh": "arctanh", "asinh": "arcsinh", "acosh": "arccosh"}
NUMPY_MATH = types.SimpleNamespace(**{
    name: getattr(np, _RENAMED.get(name, name))
    for name in dir(math) if not name.startswith("_") and hasattr(np, _RENAMED.get(name, name))
})
"""The ``math`` of a plain twin: every function of :mod:`math` that NumPy has as an element-wise ufunc
(``math.atan2`` → ``np.arctan2``, …) and the constants ``pi``, ``e``, ``inf``, ``nan``."""

LOOP_BELOW = 8
"""Below this many elements :func:`twin` calls the scalar function element by element: NumPy's fixed cost per
operation then outweighs the Python loop (the crossover of Beam2's and beam3's forces and tangents, between 4
and 16 elements: docs/benchmarks.md)."""

_BUILTINS = {"min": np.minimum, "max": np.maximum}
"""Builtins a generated function may call on two numbers, in their element-wise form."""


def _python_function(function) -> types.FunctionType:
    """The plain Python function of a numba dispatcher, or ``function`` itself (``NUMBA_DISABLE_JIT=1``)."""
    return getattr(function, "py_func", function)


def _is_kernel(value) -> bool:
    """True for a function (or a numba dispatcher of one) whose twin a generated kernel must call."""
    return isinstance(_python_function(value), types.FunctionType)


def _branches(code: types.CodeType) -> bool:
    """True if the bytecode jumps (an ``if``, a loop, a conditional expression): not straight-line code."""
    return any("JUMP" in instruction.opname or instruction.opname.startswith("FOR_ITER")
               for instruction in dis.get_instructions(code))


@functools.cache
def plain(function) -> types.FunctionType:
    """The NumPy twin of a generated kernel (a numba dispatcher or a plain function).

    It takes the kernel's arguments in structure-of-arrays form (module docstring) and returns what the
    kernel returns, element-wise (an (E,) array for a number).  Straight-line code is the kernel's own
    code object with NumPy globals: ``math`` is :data:`NUMPY_MATH`, every function it calls is that
    function's twin (recursively), ``min``/``max`` are element-wise.  A function with branches is
    rewritten into selects (module docstring).  Twins are made once per function.
    """
    py = _python_function(function)
    namespace = _namespace(py)
    if not _branches(py.__code__):
        return types.FunctionType(py.__code__, namespace, py.__name__, py.__defaults__, py.__closure__)
    try:
        return _selected(py, namespace)
    except (_Unsupported, OSError):  # a construct not rewritten, or no source to rewrite
        return _element_by_element(py)


def twin(function, elements: int) -> types.FunctionType:
    """The faster twin of a kernel for ``elements`` elements: :func:`plain` from :data:`LOOP_BELOW` on, else
    :func:`element_loop` (the same arguments and results either way)."""
    return plain(function) if elements >= LOOP_BELOW else element_loop(function)


@functools.cache
def element_loop(function) -> types.FunctionType:
    """The twin of a kernel that calls its scalar form once per element (:func:`_element_by_element`)."""
    return _element_by_element(_python_function(function))


def _namespace(py: types.FunctionType) -> dict:
    """The globals of ``py``'s twin: its own globals with ``math``, the kernels it calls and ``min``/``max``
    replaced by their element-wise forms (only the names its code uses)."""
    namespace = dict(py.__globals__)
    for name in _names(py.__code__):
        value = namespace.get(name)
        if name == "math" and value is math:
            namespace[name] = NUMPY_MATH
        elif value is not None and value is not _own(py) and _is_kernel(value):
            namespace[name] = plain(value)
        elif value is None and name in _BUILTINS:
            namespace[name] = _BUILTINS[name]
    return namespace


def _own(py: types.FunctionType):
    """The dispatcher or function that the global name of ``py`` refers to (a recursive call is left
    alone: no generated kernel recurses)."""
    return py.__globals__.get(py.__name__)


def _names(code: types.CodeType) -> set:
    """The global names ``code`` and the code objects nested in it read."""
    found = set(code.co_names)
    for constant in code.co_consts:
        if isinstance(constant, types.CodeType):
            found |= _names(constant)
    return found


class _Unsupported(Exception):
    """A construct :class:`_Selects` does not rewrite."""


class _Selects:
    """Rewrite a scalar function's ``if`` statements into element-wise selects.

    Supported: assignments to names, ``return``, and ``if``/``else`` statements (nested) made of such
    statements; no loops, no ``and``/``or``/conditional expressions, no chained comparisons.  An element
    is *done* once one of its branches has returned: ``_done`` (bool array) and ``_out`` (its values)
    carry that.  Each ``if`` evaluates its test once, where the scalar function does, into a mask for its
    body (``_c<k>``) and one for its ``else`` (``_e<k>``), both within the enclosing branch's; an
    assignment under a mask ``c`` becomes ``name = where(c & ~_done, value, name)`` (each name of a tuple
    assignment from the tuple's own item, all read before any is written), a ``return e`` under ``c``
    stores ``e`` into ``_out`` where ``c & ~_done`` and marks those elements done.  The function returns
    ``_out``.
    """

    def __init__(self):
        self.count = 0

    def rewrite(self, function: ast.FunctionDef) -> ast.FunctionDef:
        for node in ast.walk(function):
            if isinstance(node, (ast.BoolOp, ast.IfExp, ast.For, ast.While, ast.Lambda)) or (
                    isinstance(node, ast.Compare) and len(node.ops) > 1):
                raise _Unsupported(type(node).__name__)
        body = [_parse("_done = _np_false"), _parse("_out = _np_zero")]
        for statement in function.body:
            if not _is_docstring(statement):
                body += self._statement(statement, None)
        body.append(_parse("return _out"))
        function.body, function.decorator_list = body, []
        return function

    def _statement(self, statement: ast.stmt, condition: str | None) -> list:
        if isinstance(statement, ast.If):
            self.count += 1
            test, inside, outside = f"_t{self.count}", f"_c{self.count}", f"_e{self.count}"
            out = [_assign(test, statement.test)]
            within = (lambda e: e) if condition is None else (lambda e: _call("_np_and", _load(condition), e))
            out += [_assign(inside, within(_load(test))),
                    _assign(outside, within(_call("_np_not", _load(test))))]
            out += [s for item in statement.body for s in self._statement(item, inside)]
            return out + [s for item in statement.orelse for s in self._statement(item, outside)]
        live = _call("_np_not", _load("_done"))
        mask = live if condition is None else _call("_np_and", _load(condition), live)
        if isinstance(statement, ast.Return) and statement.value is not None:
            return [_assign("_out", _call("_np_where", mask, statement.value, _load("_out"))),
                    _assign("_done", _call("_np_or", _load("_done"), mask))]
        if isinstance(statement, ast.Assign) and len(statement.targets) == 1:
            return self._assignment(statement.targets[0], statement.value, mask, condition is None)
        raise _Unsupported(type(statement).__name__)

    @staticmethod
    def _assignment(target: ast.expr, value: ast.expr, mask: ast.expr, unconditional: bool) -> list:
        if isinstance(target, ast.Name):
            targets, values = [target.id], [value]
        elif (isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple) and len(target.elts) == len(value.elts)
              and all(isinstance(t, ast.Name) for t in target.elts)):
            targets, values = [t.id for t in target.elts], list(value.elts)
        else:
            raise _Unsupported(type(target).__name__)
        if unconditional:
            return [ast.Assign([target], value)]
        selected = [_call("_np_where", mask, v, _load(t)) for t, v in zip(targets, values)]
        return [ast.Assign([ast.Tuple([ast.Name(t, ast.Store()) for t in targets], ast.Store())],
                           ast.Tuple(selected, ast.Load()))]


def _is_docstring(statement: ast.stmt) -> bool:
    return isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant)


def _parse(source: str) -> ast.stmt:
    return ast.parse(source).body[0]


def _load(name: str) -> ast.Name:
    return ast.Name(name, ast.Load())


def _call(name: str, *arguments: ast.expr) -> ast.Call:
    return ast.Call(ast.Name(name, ast.Load()), list(arguments), [])


def _assign(name: str, value: ast.expr) -> ast.Assign:
    return ast.Assign([ast.Name(name, ast.Store())], value)


_SELECT_GLOBALS = {"_np_where": np.where, "_np_and": np.logical_and, "_np_or": np.logical_or,
                   "_np_not": np.logical_not, "_np_false": np.False_, "_np_zero": 0.0}


def _selected(py: types.FunctionType, namespace: dict) -> types.FunctionType:
    """:class:`_Selects` applied to ``py``'s source, compiled in ``namespace``; every branch is evaluated for
    every element, so the floating-point warnings of the branches an element does not take (``sin(a)/a`` at
    ``a = 0``) are silenced."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(py)))
    function = _Selects().rewrite(tree.body[0])
    module = ast.fix_missing_locations(ast.Module([function], []))
    scope = dict(namespace, **_SELECT_GLOBALS)
    source_file = inspect.getsourcefile(py) or "<generated>"
    exec(compile(module, source_file, "exec"), scope)  # noqa: S102 - the engine's own source, rewritten
    selects = scope[py.__name__]

    @functools.wraps(py)
    def quiet(*arguments):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return selects(*arguments)

    return quiet


def _element_by_element(py: types.FunctionType) -> types.FunctionType:
    """The twin of a function :class:`_Selects` cannot rewrite: its scalar form (:func:`_scalar`) called once per
    element, in Python, on each argument's element (module docstring's layout: the elements are the last axis
    of every array argument whose last axis has the largest length E; an output's element is a view, so the
    scalar function's writes land in it; a number is passed as it is); returns the (E,) array of its return
    values.  Slow, and exactly the scalar function's numbers."""
    scalar = _scalar(py)

    @functools.wraps(py)
    def each(*arguments):
        arrays = [a for a in arguments if isinstance(a, np.ndarray) and a.ndim]
        E = max((a.shape[-1] for a in arrays), default=1)
        per_element = [isinstance(a, np.ndarray) and a.ndim > 0 and a.shape[-1] == E for a in arguments]
        values = [scalar(*(a[..., e] if mine else a for a, mine in zip(arguments, per_element))) for e in range(E)]
        return np.array(values, dtype=float)

    each.element_by_element = True
    return each


@functools.cache
def _scalar(function) -> types.FunctionType:
    """A kernel's Python function rebound so that every kernel it calls is that kernel's own scalar form, in turn
    (never a numba dispatcher, which would compile when called from Python)."""
    py = _python_function(function)
    namespace = dict(py.__globals__)
    for name in _names(py.__code__):
        value = namespace.get(name)
        if value is not None and value is not _own(py) and _is_kernel(value):
            namespace[name] = _scalar(value)
    return types.FunctionType(py.__code__, namespace, py.__name__, py.__defaults__, py.__closure__)


__all__ = ["LOOP_BELOW", "NUMPY_MATH", "element_loop", "plain", "twin"]
