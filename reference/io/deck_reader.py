"""Deck files: from a path to a TOML table, and the vocabulary that validates its values.

Nothing here knows the deck's tables (they are read by :mod:`reference.io.deck`):
the guards around the TOML parser (size, encoding, nesting), the override of
single values by their dotted name, and :class:`Reader`, whose checks (a number,
a vector, a label, the keys of a table, …) raise :class:`DeckError` with one
message ``FILE: ENTRY: problem; fix`` of at most :data:`MESSAGE_CHARS`
characters after the file name, offending values abbreviated to
:data:`MESSAGE_VALUE` characters (:func:`show`).
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
import unicodedata
from pathlib import Path

import numpy as np

from reference.validation import ZERO_DIRECTION, not_integer, unusable_label


class DeckError(ValueError):
    """A deck that cannot be run; the message names the file, the entry and the fix."""


MAX_BYTES = 4 * 2**20
"""Largest deck file [bytes]: decks are hand-written; this bounds the parser's time and memory."""
MAX_NESTING = 32
"""Deepest nesting of arrays and inline tables, and most parts of one dotted key (``a.b.c``)."""
MAX_MAGNITUDE = 1e30
"""Every number is 0 or of magnitude in [1e-30, 1e30]: no consistent set of units needs more, and the
products the model forms of such numbers (inertias, constraint matrices) stay finite."""
MESSAGE_VALUE = 60
"""Longest rendering of an offending value in a message [characters]."""
MESSAGE_CHARS = 300
"""Longest message after the file name [characters]."""

_TOKEN = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:\\.|[^"\\\n])*"|\'[^\'\n]*\'|#[^\n]*'
                    r"|[\[{]|[\]}]|(?<![0-9])\.|\.(?![0-9])|\n")


def _clip(text: str, n: int) -> str:
    """``text`` on one line (control characters such as a newline in a quoted key escaped), at most n characters."""
    text = "".join(repr(c)[1:-1] if unicodedata.category(c)[0] == "C" else c for c in text)
    return text if len(text) <= n else text[: n - 1] + "…"


def show(value) -> str:
    """``repr(value)``, abbreviated to :data:`MESSAGE_VALUE` characters (huge lists stay readable)."""
    text = repr(value)
    if len(text) <= MESSAGE_VALUE:
        return text
    size = f" ({len(value)} items)" if isinstance(value, (list, dict, str)) else ""
    return text[: MESSAGE_VALUE - 10] + "…" + text[-5:] + size


def _structure_problem(text: str) -> str:
    """Why ``text`` is too deeply nested for the TOML parser, or ``""``.

    Scans brackets and dots outside strings and comments: more than :data:`MAX_NESTING` open
    ``[``/``{`` at once, or a dotted key of more than :data:`MAX_NESTING` parts on one line,
    would send :mod:`tomllib` into deep recursion or gigabytes of nested tables.
    """
    depth = dots = 0
    line = 1
    for m in _TOKEN.finditer(text):
        tok = m.group()
        if tok in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return f"line {line}: arrays or inline tables nested more than {MAX_NESTING} deep"
        elif tok in "]}":
            depth = max(depth - 1, 0)
        elif tok == ".":
            dots += 1
            if dots >= MAX_NESTING:
                return f"line {line}: a dotted key of more than {MAX_NESTING} parts"
        elif tok == "\n":
            line, dots = line + 1, 0
        else:
            line += tok.count("\n")
    return ""


class Reader:
    """Validation helpers that know the file name for their messages."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, entry: str, problem: str, fix: str = "") -> DeckError:
        """``FILE: ENTRY: problem; fix``; the part after the file name is kept to :data:`MESSAGE_CHARS`."""
        entry = _clip(entry, 60)
        room = MESSAGE_CHARS - len(entry) - 6  # ": " after the file and the entry, "; " before the fix
        if len(problem) + len(fix) > room:
            fix = _clip(fix, max(room // 3, room - len(problem)))
            problem = _clip(problem, room - len(fix))
        return DeckError(f"{self.path}: {entry}: {problem}" + (f"; {fix}" if fix else ""))

    def label(self, value, entry: str) -> str:
        """A name used in references, messages and file names: printable, no path separators."""
        self.string(value, entry)
        if unusable_label(value):
            raise self.fail(entry, f"unusable name {show(value)}",
                            "give 1–200 printable characters without '/' or '\\' (e.g. 'arm_2')")
        return value

    def keys(self, table, entry: str, required=(), optional=()) -> None:
        if not isinstance(table, dict):
            raise self.fail(entry, f"expected a table, got {type(table).__name__}")
        allowed = list(required) + list(optional)
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1)
                hint = f"did you mean '{close[0]}'?" if close else f"valid keys: {', '.join(allowed)}"
                raise self.fail(f"{entry}.{key}", "unknown key", hint)
        for key in required:
            if key not in table:
                raise self.fail(entry, f"missing required key '{key}'", f"required keys: {', '.join(required)}")

    def number(self, value, entry: str, positive=False, nonnegative=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(entry, f"expected a number, got {show(value)}")
        if value != 0 and not 1.0 / MAX_MAGNITUDE <= abs(value) <= MAX_MAGNITUDE:
            raise self.fail(entry, f"{value:g} is outside the range of the format (0 or a magnitude from "
                            f"{1 / MAX_MAGNITUDE:g} to {MAX_MAGNITUDE:g})", "check the units")
        if positive and not value > 0:
            raise self.fail(entry, f"must be positive, got {show(value)}", "give a value > 0")
        if nonnegative and value < 0:
            raise self.fail(entry, f"must not be negative, got {show(value)}")
        return float(value)

    def integer(self, value, entry: str, minimum=1, maximum=None, fix: str = "") -> int:
        if not_integer(value, minimum):
            raise self.fail(entry, f"expected an integer ≥ {minimum}, got {show(value)}")
        if maximum is not None and value > maximum:
            raise self.fail(entry, f"{value} is above the limit of {maximum}", fix)
        return int(value)

    def vector(self, value, entry: str, n=3) -> np.ndarray:
        if not isinstance(value, list) or len(value) != n:
            raise self.fail(entry, f"expected a list of {n} numbers, got {show(value)}")
        return np.array([self.number(v, f"{entry}[{i}]") for i, v in enumerate(value)])

    def direction(self, value, entry: str) -> np.ndarray:
        """A non-zero 3-vector (a joint axis, a section axis)."""
        vec = self.vector(value, entry)
        if not math.hypot(*vec) > 0.0:
            raise self.fail(entry, *ZERO_DIRECTION)
        return vec

    def rotation(self, value, entry: str) -> np.ndarray:
        """Euler parameters of unit norm (within 1e-6)."""
        rot = self.vector(value, entry, 4)
        norm = math.hypot(*rot)
        if not abs(norm - 1.0) <= 1e-6:
            raise self.fail(entry, f"Euler parameters must have unit norm, got |q| = {norm:.6g}",
                            "normalise them (identity: [1, 0, 0, 0])")
        return rot

    def string(self, value, entry: str) -> str:
        if not isinstance(value, str):
            raise self.fail(entry, f"expected a string, got {show(value)}")
        return value

    def boolean(self, value, entry: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(entry, f"expected true or false, got {show(value)}")
        return value

    def choice(self, value, entry: str, options, what: str = "value", describe: str = "") -> str:
        """A string that must be one of ``options``; the fix is a close match or the list (or ``describe``)."""
        if not isinstance(value, str) or value not in options:
            close = difflib.get_close_matches(value, list(options), n=1) if isinstance(value, str) else []
            raise self.fail(entry, f"unknown {what} {show(value)}",
                            f"did you mean '{close[0]}'?" if close else describe or f"one of: {', '.join(options)}")
        return value

    def tables(self, parent, key, entry: str | None = None) -> dict:
        """A table of named entries (``[sections.NAME]``, ``points.NAME``)."""
        value = parent.get(key, {})
        if not isinstance(value, dict):
            raise self.fail(entry or key, f"expected a table of named entries, got {show(value)}",
                            f"write it as [{key}.NAME]" if entry is None else "write it as {NAME = ..., ...}")
        return value

    def items(self, deck, key) -> list:
        value = deck.get(key, [])
        if not isinstance(value, list):
            raise self.fail(key, "expected an array of tables", f"write it as [[{key}]]")
        return value


def read_toml(path: Path) -> tuple[str, dict]:
    """The text of the deck file ``path`` and its TOML table, behind the parser's guards.

    Refused with a :class:`DeckError`: not a file, above :data:`MAX_BYTES`, not
    UTF-8, nested deeper than :data:`MAX_NESTING` (:func:`_structure_problem`),
    not valid TOML.
    """
    if not path.is_file():
        raise DeckError(f"{path}: no such deck file" + ("" if not path.exists() else " (it is a directory)"))
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise DeckError(f"{path}: the file is {size / 2**20:.1f} MB, above the deck limit of "
                        f"{MAX_BYTES / 2**20:.0f} MB; is it a deck? (decks are hand-written TOML of a few kB)")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise DeckError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); "
                        "save the deck as UTF-8") from None
    problem = _structure_problem(text)
    if problem:
        raise DeckError(f"{path}: {problem}; flatten the structure (a deck needs at most 3 levels)")
    try:
        deck = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DeckError(f"{path}: not valid TOML: {exc}") from None
    except (RecursionError, MemoryError):
        raise DeckError(f"{path}: not a usable deck: too deeply nested for the TOML parser; "
                        "flatten the structure") from None
    return text, deck


def override_value(deck: dict, key: str, value, rd: Reader) -> None:
    """Set the deck value named ``key`` (dotted: tables by name, arrays of tables by index,
    e.g. ``solver.damping``, ``sections.rollup.EI2``, ``beams.0.elements``) to ``value``.

    The target's table must exist; the value must be a number, string or boolean and, when the
    deck gives the entry, of the same kind.  The deck is then validated as written.
    """
    entry = f"override {key}"
    if not isinstance(value, (int, float, str)):  # bool is an int
        raise rd.fail(entry, f"expected a number, a string or a boolean, got {value!r}")
    parts = key.split(".")
    if any(not p for p in parts):
        raise rd.fail(entry, "empty part in the dotted name", "write e.g. solver.damping")
    table = deck
    for depth, part in enumerate(parts[:-1]):
        here = ".".join(parts[: depth + 1])
        if isinstance(table, list):
            if not (part.isascii() and part.isdigit()) or int(part) >= len(table):
                raise rd.fail(entry, f"{here}: no entry {part!r} in an array of {len(table)}",
                              f"index it 0 … {len(table) - 1}")
            table = table[int(part)]
        elif isinstance(table, dict) and part in table and isinstance(table[part], (dict, list)):
            table = table[part]
        else:
            options = [k for k, v in table.items() if isinstance(v, (dict, list))] if isinstance(table, dict) else []
            close = difflib.get_close_matches(part, options, n=1)
            raise rd.fail(entry, f"the deck has no table {show(here)}",
                          f"did you mean '{close[0]}'?" if close else f"tables here: {', '.join(options) or 'none'}")
    if not isinstance(table, dict):
        raise rd.fail(entry, f"{'.'.join(parts[:-1])} is an array", "name one of its entries by index, e.g. beams.0.elements")
    old = table.get(parts[-1])
    if isinstance(old, (dict, list)):
        raise rd.fail(entry, f"{key} is a table or an array, not a single value", "name one of its values")
    kind = lambda v: "boolean" if isinstance(v, bool) else "number" if isinstance(v, (int, float)) else "string"  # noqa: E731
    if old is not None and kind(old) != kind(value):
        raise rd.fail(entry, f"the deck's {key} is a {kind(old)}, the override a {kind(value)} ({value!r})",
                      f"give a {kind(old)}")
    table[parts[-1]] = value
