"""``flexmbs bench`` marks every target MET or MISSED, lists the missed ones last and exits 1 when one is
missed (the issue's "VTK output … 23.8 % of the run (target ≤ 20 %)" had no mark and exit 0).  No timing
here: the marks and the summary are decided from the numbers by pure functions."""

from __future__ import annotations

import math

from flexmbs.bench import Target, target_summary


def test_a_value_over_its_target_is_missed_and_fails_the_bench():
    vtk = Target("VTK output, share of the run", 0.238, 0.20, "{:.1%}")
    welded = Target("two beams, welded / sharing the node", 1.4, 2.0, "{:.2f}")
    assert (vtk.met, vtk.mark, welded.met, welded.mark) == (False, "MISSED", True, "MET")
    assert vtk.describe() == "VTK output, share of the run: 23.8% (target ≤ 20.0%)"
    lines, status = target_summary([welded, vtk])
    assert status == 1
    assert lines == ["targets: 1 of 2 met, 1 MISSED:",
                     "  MISSED  VTK output, share of the run: 23.8% (target ≤ 20.0%)"]


def test_all_targets_met_exit_0_and_the_boundary_and_nan():
    assert Target("at the bound", 0.3, 0.3).met
    assert not Target("not measured", math.nan, 0.3).met  # a NaN is never a met target
    lines, status = target_summary([Target("a", 0.1, 0.3), Target("b", 0.3, 0.3)])
    assert (lines, status) == (["targets: all 2 met"], 0)
