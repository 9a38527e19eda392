"""Sizes a reader can hold in mind, read from the sources with ``ast`` (nothing is imported).

A hand-written module of the engine (``reference/``, the generated kernels of
``reference/generated/`` excepted) stays under ~500 lines, split along a line the
paper draws when it grows (model assembly, constraints, solution loop); a module
that stays longer for a reason says so in its docstring with its length ("about N
lines") and the reason.  No hand-written function of the engine is over 80 lines, nor takes more
than 10 parameters unless its docstring says why in a paragraph ``Takes N parameters: <reason>.`` (N exact, so
that the reason is read again when the signature changes).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULE_LINES = 500
FUNCTION_LINES = 80
PARAMETERS = 10
REASON = re.compile(r"^\s*Takes (\d+) parameters: \S", re.M)
"""The reason's first line; the reason may go on over the next lines."""


def engine_modules():
    return [p for p in sorted((ROOT / "reference").rglob("*.py")) if "generated" not in p.relative_to(ROOT).parts]


def test_long_engine_modules_give_their_reason():
    unexplained = []
    for path in engine_modules():
        source = path.read_text(encoding="utf-8")
        lines = source.count("\n")
        if lines > MODULE_LINES:
            doc = ast.get_docstring(ast.parse(source)) or ""
            if not re.search(r"about \d+ lines", doc):
                unexplained.append(f"{path.relative_to(ROOT)} ({lines} lines)")
    assert not unexplained, ("split these along a line the paper draws, or say in the docstring why "
                             f"(\"about N lines\" and the reason): {unexplained}")


def test_no_engine_function_over_80_lines():
    long = []
    for path in engine_modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > FUNCTION_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, f"split these into steps a reader can test one at a time: {long}"


def parameter_count(node: ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda) -> int:
    """Positional and keyword-only parameters, ``*args`` and ``**kwargs`` one each; ``self`` and ``cls``
    not counted."""
    a = node.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg not in ("self", "cls")]
    return len(names) + (a.vararg is not None) + (a.kwarg is not None)


def long_parameter_lists(source: str, name: str) -> list[str]:
    """``name:function (N parameters)`` for each function of ``source`` over :data:`PARAMETERS` whose
    docstring lacks the line ``Takes N parameters: <reason>.`` with its exact N."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and parameter_count(node) > PARAMETERS:
            n = parameter_count(node)
            if str(n) not in REASON.findall(ast.get_docstring(node) or ""):
                found.append(f"{name}:{node.name} ({n} parameters)")
    return found


def test_the_parameter_check_reads_the_reason_and_its_count():
    eleven = ", ".join(f"a{k}" for k in range(11))
    bare = f"def f({eleven}):\n    \"\"\"Sum.\"\"\"\n"
    assert long_parameter_lists(bare, "m") == ["m:f (11 parameters)"]
    reasoned = f"def f({eleven}):\n    \"\"\"Sum.\n\n    Takes 11 parameters: a kernel's arrays.\n    \"\"\"\n"
    assert long_parameter_lists(reasoned, "m") == []
    assert long_parameter_lists(reasoned.replace("Takes 11", "Takes 12"), "m") == ["m:f (11 parameters)"]
    method = "class C:\n    def g(self, *args, b, c, d, e, f, g, h, i, j, **kw):\n        pass\n"
    assert long_parameter_lists(method, "m") == ["m:g (11 parameters)"]  # self not counted, *args and **kw one each


def test_long_parameter_lists_give_their_reason():
    unexplained = [item for path in engine_modules()
                   for item in long_parameter_lists(path.read_text(encoding="utf-8"),
                                                    ".".join(path.relative_to(ROOT).with_suffix("").parts))]
    assert not unexplained, ("group these parameters (a record, the Model, the layout they come from), or say in "
                             f"the docstring why not (\"Takes N parameters: <reason>.\"): {unexplained}")
