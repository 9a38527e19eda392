"""The verification report's "Sensitivities" section (flexmbs/verification/sensitivities.py): the quick subset
runs, on the reference path, a row for each of the four checks and the jointed modes, and every row passes."""

from __future__ import annotations

import re

from flexmbs.report import Check, _table
from flexmbs.verification.sensitivities import report_lines


def test_quick_sensitivity_section_has_the_four_checks_and_they_pass(tmp_path):
    lines, rows = report_lines(True, tmp_path)
    checks = [Check(*row) for row in rows]
    assert lines[0] == "## Sensitivities"
    for subject in ("roll-up", "Euler column", "cantilever", "three-bar", "torsion double pendulum"):
        assert any(c.name.startswith(subject) for c in checks), subject
    # each with its reference, a finite computed measure within its tolerance, and the reason of the tolerance
    for c in checks:
        assert c.passed, (c.name, c.reference, c.computed, c.tolerance)
        assert c.reference and len(c.why) > 20 and 0.0 < c.tolerance < 1.0
    # the closed forms and the central differences both appear
    references = " ".join(c.reference for c in checks)
    assert "central differences" in references and "exact circle" in references and "π²/(4L²)" in references
    # the report's table: one row per check, every row as many cells as the header; no tracker words
    table = _table(checks)
    assert len(table) == 2 + len(checks) and len({row.count("|") for row in table}) == 1
    assert not re.search(r"\bissue\b|acceptance", "\n".join(lines + table), re.I)
