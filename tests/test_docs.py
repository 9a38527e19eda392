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


TIMING = re.compile(r"\d\s?(?:ns|µs|ms)\b|µs|\(measured[:;)]|measured\)|measured with ``perf``")


def test_the_engine_docstrings_log_no_timings():
    """The engine's docstrings and comments give the design reason in words; the timings behind it live in
    docs/benchmarks.md §10 (a timing in the code goes stale with the next optimisation, silently)."""
    hits = [f"{p.relative_to(ROOT)}:{i + 1}" for p in sorted((ROOT / "reference").rglob("*.py"))
            if "generated" not in p.parts
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines()) if TIMING.search(line)]
    assert not hits, "move the measurement to docs/benchmarks.md §10: " + ", ".join(hits)
