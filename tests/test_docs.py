"""The repository is self-contained: its provenance lives in docs/, not in hand-off notes outside it."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FORBIDDEN = re.compile(r"shared/|BENCHMARKS|FORMULATION|DESIGN\.md")


def _files():
    for folder in ("reference", "derivations", "crosscheck", "flexmbs", "models", "notebooks", "docs", "tests", "reports"):
        for path in (ROOT / folder).rglob("*"):
            if path.suffix in {".py", ".toml", ".md"} and "_runs" not in path.parts:
                yield path
    yield ROOT / "README.md"


def test_nothing_cites_files_outside_the_repository():
    hits = [f"{p.relative_to(ROOT)}:{i + 1}" for p in _files() if p != Path(__file__)
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines()) if FORBIDDEN.search(line)]
    assert not hits, "cite docs/formulation.md or docs/benchmarks.md instead: " + ", ".join(hits)


def test_docs_cited_by_the_code_exist():
    cited = {m for p in _files() for m in re.findall(r"docs/[a-z_]+\.md", p.read_text(encoding="utf-8"))}
    missing = sorted(c for c in cited if not (ROOT / c).exists())
    assert not missing


TIMING = re.compile(r"\d\s?(?:ns|µs|ms)\b|µs|\(measured[:;)]|measured\)|measured with ``perf``"
                    r"|\d(?:\.\d+)?\s?s (?:per|a|an|each) (?:step|call|run|kernel|element|deck)\b"
                    r"|\d(?:\.\d+)?\s?s on the\b|\btook \d|\d(?:\.\d+)?\s?(?:×|times) (?:faster|slower)"
                    r"|(?:faster|slower) by \d|speed-?up of \d")
"""A timing in words: a duration in ns, µs or ms; seconds per step, call or run, or "on the" machine; "took" a
number; a speed-up by a factor; a "(measured …)" note."""


def test_the_timing_pattern_finds_the_logs_it_names():
    for log in ("costs 0.4 µs a call", "12 ms", "(measured: 3.1)", "2.5 s per step", "0.7 s on the loaded machine",
                "took 762 steps", "3.4× faster", "slower by 12 %", "a speed-up of 2"):
        assert TIMING.search(log), log
    for design in ("steps of 1e-4 s and bodies", "about every 0.1 s: CallBudget", "measured from the first output",
                   "angular velocities in rad/s"):
        assert not TIMING.search(design), design


def test_the_engine_docstrings_log_no_timings():
    """The engine's docstrings and comments give the design reason in words; the timings behind it live in
    docs/benchmarks.md §10 (a timing in the code goes stale with the next optimisation, silently).  Every module
    of reference/ is read, the generated ones too (their docstrings come from derivations/)."""
    hits = [f"{p.relative_to(ROOT)}:{i + 1}" for p in sorted((ROOT / "reference").rglob("*.py"))
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines()) if TIMING.search(line)]
    assert not hits, "move the measurement to docs/benchmarks.md §10: " + ", ".join(hits)
