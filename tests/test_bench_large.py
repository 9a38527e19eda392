"""The large-model section of ``flexmbs bench`` (flexmbs/bench_large.py, issue 25 item 4) in its small
version: the same code on a 200-element rod (20 steps) and the roll-up refined twice (24 elements).  No
timing is asserted (a test never fails on wall time): the answers the timings rest on are.  PyElastica is
left out: its kernels compile for ~30 s on a cold cache (``flexmbs bench --large --quick`` runs it; its
small-mesh numbers are quoted below)."""

from __future__ import annotations

import os

import numpy as np
import pytest


def rows(lines: list[str], header: str) -> list[list[str]]:
    """The cells of the markdown table that follows the line starting with ``header``."""
    start = next(k for k, line in enumerate(lines) if line.startswith(header))
    table = []
    for line in lines[start + 1:]:
        if table and not line.startswith("|"):
            break
        if line.startswith("|") and not line.startswith("|---"):
            table.append([cell.strip() for cell in line.strip("|").split("|")])
    return table[1:]  # without the header row


@pytest.fixture(scope="module")
def bench():
    from flexmbs.bench_large import large_models

    targets = []
    lines = large_models(quick=True, targets=targets, pyelastica=False)
    return lines, targets


def test_explicit_rod(bench):
    """flexmbs' tip at dt against its run at dt/2 is within 2e-3 (second order, 20 steps at 3/4 of the
    critical step; measured 5.9e-4; PyElastica's 7.0e-4, the two codes' tips 6e-4 apart), flexmbs is stable
    up to its own critical step estimate at least, and the whole ``solve()`` ends at the same tip, digit for
    digit, as the compiled stepping it times."""
    lines, _ = bench
    table = {r[0]: r for r in rows(lines, "**Explicit")}
    assert float(table["flexmbs"][3]) < 2e-3
    assert table["flexmbs"][4].startswith(("1 ×", "1.5 ×", "2 ×", "3 ×"))
    assert table["flexmbs, whole `solve()`"][2] == table["flexmbs"][2]
    assert "PyElastica" not in table


def test_thread_table_covers_every_core_and_is_bit_for_bit(bench):
    from flexmbs.bench_large import thread_counts

    lines, targets = bench
    table = rows(lines, "**Threads")
    counts = thread_counts()
    assert counts[0] == 1 and counts[-1] == len(os.sched_getaffinity(0))
    assert [int(r[1]) for r in table] == counts * 2  # both models, every count
    assert all(r[4] == "bit for bit" for r in table)


def test_static_rollup_closes_the_circle_in_both_codes(bench):
    """At k = 2 the roll-up's closed form (a full circle: exact for the polygon of equal chords too) puts the
    tip on the clamp; both codes reach the 1e-6 L of the bench's rule (measured 8e-14 and 1.4e-8 L)."""
    lines, targets = bench
    table = {r[0]: r for r in rows(lines, "**Static roll-up")}
    assert set(table) == {"flexmbs", "Exudyn"}
    assert all(float(r[3]) <= 1e-6 for r in table.values())
    assert any("static roll-up" in t.what for t in targets)


def test_generalized_alpha_errors_converge_in_both_codes(bench):
    """Each code's error against its own reference (dt = 0.0125) falls by more than 3× from dt = 0.1 to 0.05
    (second order: 4×; measured 5.1× and 4.8×), and the two references differ by less than 2e-3 L on 24
    elements (lumped against consistent mass; measured 6.5e-4 L)."""
    lines, _ = bench
    table = rows(lines, "**Generalized-α roll-up")
    err = {(r[0], r[1]): float(r[3]) for r in table if not r[3].startswith("failed")}
    for code in ("flexmbs", "Exudyn"):
        assert err[code, "0.1"] / err[code, "0.05"] > 3.0
    header = next(line for line in lines if line.startswith("**Generalized-α roll-up"))
    assert float(header.split("references differ by ")[1].split()[0]) < 2e-3


def test_linear_fit_reports_the_largest_deviation():
    """A cost exactly a + b K is on the line (deviation at round-off); one size 20 % high shows up."""
    from flexmbs.bench_scaling import linear_fit

    K = np.array([50, 100, 200, 400, 1000])
    a, b, worst = linear_fit(K, 3e-6 + 8e-7 * K)
    assert (a, b) == pytest.approx((3e-6, 8e-7)) and worst < 1e-12
    cost = 3e-6 + 8e-7 * K
    cost[2] *= 1.2
    assert linear_fit(K, cost)[2] > 0.1
