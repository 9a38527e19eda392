"""The README's table "Where the paper is in the code" points to files that exist, and the three paths it promises
(the Beam2 forces, a revolute joint's Jacobian, one Park step; issue 37) are each at most three files, each file
linked to the next by an import or a citation, and every function they name is defined in one of them."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BACKTICKED = re.compile(r"`([^`]+)`")
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)?")


def _section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("## Where the paper is in the code")
    return text[start:text.index("\n## ", start + 1)]


def _paths(cell: str) -> list[str]:
    """The repository paths named in backticks, ``a/{b,c}.py`` expanded."""
    found = []
    for token in BACKTICKED.findall(cell):
        if "/" not in token:
            continue
        brace = re.search(r"\{([^}]*)\}", token)
        found += ([token[:brace.start()] + part + token[brace.end():] for part in brace[1].split(",")]
                  if brace else [token])
    return found


def _chains() -> dict[str, str]:
    """The bullets under the table, by their bold name: ``- **the Beam2 forces**: …``."""
    bullets = re.findall(r"^- \*\*(.+?)\*\*: (.+?)(?=^- |^\n|\Z)", _section(), re.M | re.S)
    return {name: " ".join(body.split()) for name, body in bullets}


def _first_clause(text: str) -> str:
    """``text`` up to its first ``;`` outside parentheses: the path itself, before an aside."""
    depth = 0
    for k, ch in enumerate(text):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if ch == ";" and depth == 0:
            return text[:k]
    return text


def test_every_row_of_the_table_points_to_files_that_exist():
    rows = [line for line in _section().splitlines() if line.startswith("| ") and not line.startswith("| paper")]
    assert len(rows) >= 8
    missing = [path for row in rows for path in _paths(row.split(" | ")[-1]) if not (ROOT / path).exists()]
    assert not missing, f"the README's table names files that do not exist: {missing}"


def _names(earlier: str, later: str) -> bool:
    """Whether one of two files names the other, by path or as a module (``reference.plain.model``)."""
    def mentions(path, other):
        text = (ROOT / path).read_text(encoding="utf-8")
        return other in text or other.removesuffix(".py").replace("/", ".") in text
    return mentions(later, earlier) or mentions(earlier, later)


def test_the_beam_forces_a_revolute_jacobian_and_a_park_step_are_three_files_away():
    chains = _chains()
    assert set(chains) >= {"the Beam2 forces", "a revolute joint's Jacobian", "one Park step"}, chains
    for name, text in chains.items():
        chain = [p for p in _paths(_first_clause(text)) if p.endswith(".py")]
        assert 1 <= len(chain) <= 3, f"{name}: {chain}"
        files = _paths(text)
        assert all((ROOT / p).exists() for p in files), f"{name}: {files}"
        unlinked = [(a, b) for a, b in zip(chain, chain[1:]) if not _names(a, b)]
        assert not unlinked, f"{name}: neither file names the other: {unlinked}"
        # every function or class it names is defined in one of its files or on the reference path
        sources = "\n".join((ROOT / p).read_text(encoding="utf-8")
                            for p in {*files, *map(str, (ROOT / "reference" / "plain").glob("*.py"))})
        named = [t for t in BACKTICKED.findall(text) if "/" not in t and IDENTIFIER.fullmatch(t)]
        undefined = [t for t in named if not re.search(rf"^\s*(?:def|class) {t.split('.')[-1]}\b", sources, re.M)]
        assert named and not undefined, f"{name}: names nothing defined there: {undefined}"
