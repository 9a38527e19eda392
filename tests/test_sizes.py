"""Sizes a reader can hold in mind, read from the sources with ``ast`` (nothing is imported).

A hand-written module of the engine (``reference/``, the generated kernels of
``reference/generated/`` excepted) stays under ~500 lines, split along a line the
paper draws when it grows (model assembly, constraints, solution loop); a module
that stays longer for a reason says so in its docstring with its length ("about N
lines") and the reason.  No hand-written function of the engine is over 80 lines.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULE_LINES = 500
FUNCTION_LINES = 80


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
