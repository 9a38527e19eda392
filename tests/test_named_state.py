"""The engine reads its state, settings and packed parameters by name (issue 37 item 3).

The clock, the energy guard and the settings of the compiled generalized-α and Newton loops are records
(:func:`reference.state.record_dtype`), read by name (``clock.t`` in a kernel, ``clock["t"]`` in Python); the
packed joint, force-element and master/slave parameters are split into named views by one accessor each, next
to the layout it reads.  No other reader indexes ``par``, ``clock``, ``guard`` or ``small`` at a literal slot.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from reference.algorithms import alpha_steps, newton_steps
from reference.state import CLOCK, GUARD, new_clock

ENGINE = Path(__file__).resolve().parents[1] / "reference"
NAMES = {"par", "clock", "guard", "small"}

LAYOUTS = {("connector.py", "body_fixed_parts"), ("joints/master_slave.py", "pair_parts")}
"""The accessors that define a packed layout (the only functions allowed literal slices of ``par``)."""


class _Reads(ast.NodeVisitor):
    """The literal-slot subscripts of one file, each with its innermost function."""

    def __init__(self, file: str):
        self.file, self.stack, self.found = file, ["<module>"], []

    def visit_FunctionDef(self, node):
        self.stack.append(node.name)
        self.generic_visit(node)
        self.stack.pop()

    def visit_Subscript(self, node):
        base = node.value.attr if isinstance(node.value, ast.Attribute) else getattr(node.value, "id", None)
        index = node.slice
        number = isinstance(index, ast.Constant) and isinstance(index.value, int)
        record = number and index.value == 0 and base in ("clock", "guard", "par")
        if base in NAMES and (number or isinstance(index, ast.Slice)) and not record:
            self.found.append((self.file, self.stack[-1], ast.unparse(node)))
        self.generic_visit(node)


def _literal_reads():
    """``(file, function, source)`` of every ``par``/``clock``/``guard``/``small`` subscript by a literal
    integer or slice in reference/, but for ``[0]`` of ``clock``/``guard``/``par``: the record of a one-element
    record array (a float array's slot 0 read as a record would fail at once: a record does no arithmetic)."""
    found = []
    for path in sorted(ENGINE.rglob("*.py")):
        if path.parent.name == "plain":
            continue  # the reference path reads the packed layouts vectorised over all joints (its own task)
        reads = _Reads(path.relative_to(ENGINE).as_posix())
        reads.visit(ast.parse(path.read_text(encoding="utf-8")))
        found += reads.found
    return found


def test_no_reader_indexes_a_slot():
    """Only the two layout accessors slice ``par``; nothing reads a slot by its number (before: 137 reads)."""
    reads = _literal_reads()
    outside = [r for r in reads if (r[0], r[1]) not in LAYOUTS]
    assert outside == [], outside
    assert {(r[0], r[1]) for r in reads} == LAYOUTS  # the accessors are found: the scan itself works


def test_records_are_named_and_flat():
    """Every record field is a float of its own (numba compiles a field as an array slot), and the
    run state starts where the algorithms expect it: the clock at t₀, step 0, no work; the guard off."""
    for dtype in (CLOCK, GUARD, alpha_steps.PAR, newton_steps.PAR):
        assert all(dtype.fields[name][0] == np.float64 for name in dtype.names)
        assert dtype.itemsize == 8 * len(dtype.names)  # no padding: aligned f8 fields
    clock = new_clock(1.5)[0]
    assert [clock[name] for name in ("t", "n", "work", "dissipated")] == [1.5, 0.0, 0.0, 0.0]
    par = alpha_steps.new_par(h=1e-3, h_next=1e-3)[0]
    assert [par[name] for name in ("h", "h_next", "accepted", "h_min", "h_max")] == [1e-3, 1e-3, 0.0, np.inf, 0.0]
    assert np.isnan(par["error"])


def test_a_record_view_reads_and_writes_the_records_fields():
    """:class:`reference.state.RecordView` (the Python drivers' access to a kernel's record): every field of the
    generalized-α record reads what the numpy.void reads, and a write through the view is what the void and the
    array then hold."""
    from reference.algorithms.alpha_steps import PAR, new_par
    from reference.state import RecordView

    par = new_par(h=1e-3, alpha_m=0.2, U=np.nan)
    par[0]["dt_max"] = np.inf
    view = RecordView(par)
    for name in PAR.names:
        assert np.array_equal(view[name], par[0][name], equal_nan=True), name
    for k, name in enumerate(PAR.names):
        view[name] = k + 0.5
    assert [float(par[0][name]) for name in PAR.names] == [k + 0.5 for k in range(len(PAR.names))]
