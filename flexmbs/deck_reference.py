"""The deck's key tables, generated from the deck reader itself (the documentation's deck reference).

Nothing here restates a key: every deck in ``models/`` is read by
:func:`reference.io.deck.load_deck` with a recording :class:`~reference.io.deck_reader.Reader`,
which notes every table's allowed and required keys (``Reader.keys``), every value's check
(``Reader.number``, ``vector``, ``integer``, ``choice`` …, with their ranges and options), the
value the reader used when a deck left a key out (its default), and which keys name nodes or time
functions.  The keys of the kinds (time functions, springs) and of the algorithms come from the
registries the reader looks them up in (``TIME_FUNCTIONS``, ``SPRING_KEYS``, ``ALGORITHMS``).  The
message column is the reader's own message for a wrong value of that key.  A key the reader
accepts but no gallery deck uses is listed with its type left blank, and a table no gallery deck has is
only named among the deck's tables.

``python -m flexmbs.deck_reference`` prints the Markdown; the documentation build writes it into
the deck reference page (``docs/conf.py``).
"""

from __future__ import annotations

import re
from contextlib import contextmanager
from pathlib import Path

import numpy as np

import reference.io.deck as deck_module
from reference.algorithms import ALGORITHMS
from reference.io.deck_connectors import SPRING_KEYS
from reference.io.deck_reader import DeckError, Reader

ROOT = Path(__file__).resolve().parent.parent
NAMED = {"sections", "time_functions", "checks", "crosscheck"}
"""Tables of named entries (``[sections.NAME]``): the name is not a key."""
KINDS = {"time_functions": "kind", "springs": "kind", "solver": "algorithm"}
"""Tables whose keys depend on the value of one key: one key table per value."""
_ENTRY = re.compile(r"^(?P<table>[a-z_]+)(?P<index>\[\d+\])?(?:\.(?P<rest>.+))?$")
_BAD = {"number": "x", "integer": 0, "vector": [1.0], "direction": [0.0, 0.0, 0.0], "rotation": [1.0, 1.0, 0.0, 0.0],
        "string": 1, "boolean": "yes", "choice": "?", "label": "a/b"}
"""A wrong value for each check, to show the reader's message for it."""


def _split(entry: str):
    """(table pattern, key) of an entry such as ``beams[2].section`` or ``sections.arm.EA``; None if not a key."""
    m = _ENTRY.match(entry)
    if not m or " " in entry:
        return None
    table, rest = m["table"], m["rest"]
    if m["index"]:
        pattern = f"[[{table}]]"
    elif table in NAMED:
        if rest is None or "." not in rest:
            return (f"[{table}.NAME]", None) if rest else None
        rest = rest.split(".", 1)[1]
        pattern = f"[{table}.NAME]"
    else:
        pattern = f"[{table}]"
    if rest is None:
        return pattern, None
    key = re.sub(r"\[\d+\]$", "", rest)
    if "." in key:  # rigid_bodies[i].points.NAME
        head, _, _ = key.partition(".")
        return pattern, f"{head}.NAME"
    return pattern, key


class _Recorder(Reader):
    """A deck reader that notes what it checks (the vocabulary of :class:`Reader`)."""

    def __init__(self, path, book):
        super().__init__(path)
        self.book = book
        self.present: dict[str, set] = {}
        self.depth = 0

    def keys(self, table, entry, required=(), optional=()):
        if isinstance(table, dict):
            self.present[entry] = set(table)
            where = _split(entry)
            if where:
                self.book.table(where[0], required, optional, table)
        return super().keys(table, entry, required, optional)

    def _note(self, check, value, entry, **how):
        where = _split(entry) if self.depth == 0 else None
        if not where or where[1] is None:
            return
        parent, _, key = entry.rpartition(".")
        key = re.sub(r"\[\d+\]$", "", key)
        if re.search(r"\[\d+\]$", entry):  # an item of a list checked one by one
            check = f"list of {check}s"
        absent = parent in self.present and key not in self.present[parent]
        self.book.value(where[0], where[1], check, how, value if absent else _GIVEN)

    def _nested(self, method, *args, **kwargs):
        self.depth += 1
        try:
            return method(*args, **kwargs)
        finally:
            self.depth -= 1

    def number(self, value, entry, positive=False, nonnegative=False):
        self._note("number", value, entry, positive=positive, nonnegative=nonnegative)
        return super().number(value, entry, positive, nonnegative)

    def integer(self, value, entry, minimum=1, maximum=None, fix=""):
        self._note("integer", value, entry, minimum=minimum, maximum=maximum)
        return super().integer(value, entry, minimum, maximum, fix)

    def vector(self, value, entry, n=3):
        self._note("vector", value, entry, n=n)
        return self._nested(super().vector, value, entry, n)

    def direction(self, value, entry):
        self._note("direction", value, entry)
        return self._nested(super().direction, value, entry)

    def rotation(self, value, entry):
        self._note("rotation", value, entry)
        return self._nested(super().rotation, value, entry)

    def string(self, value, entry):
        self._note("string", value, entry)
        return super().string(value, entry)

    def boolean(self, value, entry):
        self._note("boolean", value, entry)
        return super().boolean(value, entry)

    def choice(self, value, entry, options, what="value", describe=""):
        self._note("choice", value, entry, options=tuple(options), what=what, describe=describe)
        return super().choice(value, entry, options, what, describe)

    def label(self, value, entry):
        self._note("label", value, entry)
        return self._nested(super().label, value, entry)


_GIVEN = object()


class _Book:
    """What the recording reader saw, by table pattern and key, in the order the reader reads them."""

    def __init__(self):
        self.tables: dict[str, dict] = {}
        self.sequences: list[list[str]] = []
        self.kind: dict[str, str] = {}

    def start(self):
        """A new deck: the order of its tables is noted apart."""
        self.sequences.append([])

    @property
    def order(self) -> list[str]:
        """The tables in the reader's order: every deck's order of its tables merged (a topological sort)."""
        after = {p: set() for p in self.tables}
        for seq in self.sequences:
            for first, then in zip(seq, seq[1:]):
                after[then].add(first)
        order, left = [], list(self.tables)
        while left:
            ready = next((p for p in left if after[p] <= set(order)), left[0])
            order.append(ready)
            left.remove(ready)
        return order

    def table(self, pattern, required, optional, table):
        if self.sequences and pattern not in self.sequences[-1]:
            self.sequences[-1].append(pattern)
        t = self.tables.setdefault(pattern, {})
        for key in list(required) + list(optional):
            t.setdefault(key, {"required": set(), "checks": {}, "defaults": []})["required"].add(key in required)
        disc = KINDS.get(pattern.strip("[]").split(".")[0])
        self.kind[pattern] = table.get(disc, "") if disc else ""

    def value(self, pattern, key, check, how, default):
        t = self.tables.setdefault(pattern, {})
        k = t.setdefault(key, {"required": set(), "checks": {}, "defaults": []})
        k["checks"].setdefault(check, how)
        if default is not _GIVEN:
            k["defaults"].append((self.kind.get(pattern, ""), default))

    def node(self, entry, kind):
        where = _split(entry)
        if where and where[1]:
            t = self.tables.setdefault(where[0], {})
            t.setdefault(where[1], {"required": set(), "checks": {}, "defaults": []})["checks"].setdefault(kind, {})


@contextmanager
def _recording(book):
    """Node and time-function references are resolved by the deck module's reference table: note them too."""
    refs = deck_module._References
    node, tf = refs.node, refs.time_function

    def noted_node(self, ref, entry):
        book.node(entry, "node")
        return node(self, ref, entry)

    def noted_tf(self, table, entry):
        for key in ("time_function", "force_function"):
            if key in table:
                book.node(f"{entry}.{key}", "time function")
        return tf(self, table, entry)

    refs.node, refs.time_function = noted_node, noted_tf
    reader = deck_module.Reader
    try:
        yield
    finally:
        refs.node, refs.time_function = node, tf
        deck_module.Reader = reader


def record(decks=None) -> _Book:
    """Read every deck (default: ``models/*.toml``) with the recording reader."""
    book = _Book()
    with _recording(book):
        deck_module.Reader = lambda path: _Recorder(path, book)
        for path in decks or sorted((ROOT / "models").glob("*.toml")):
            book.start()
            deck_module.load_deck(path)
    return book


def _type(checks: dict) -> str:
    """The check of a key in words (its type and range)."""
    words = []
    for check, how in checks.items():
        if check == "number":
            words.append("number > 0" if how["positive"] else "number ≥ 0" if how["nonnegative"] else "number")
        elif check == "integer":
            words.append(f"integer ≥ {how['minimum']}" + (f", ≤ {how['maximum']:g}" if how["maximum"] else ""))
        elif check == "vector":
            words.append(f"{how['n']} numbers")
        elif check == "direction":
            words.append("3 numbers, not all 0")
        elif check == "rotation":
            words.append("4 numbers (Euler parameters), unit norm")
        elif check == "choice":
            words.append("one of " + ", ".join(f"`{o}`" for o in how["options"]))
        elif check == "label":
            words.append("name (1–200 printable characters, no `/` or `\\`)")
        elif check in ("node", "time function"):
            words.append(f"{check} reference")
        else:
            words.append(check)
    if "string" in checks and len(words) > 1:  # a label or a choice is a string checked further
        words.remove("string")
    return "; ".join(dict.fromkeys(words))


def _message(key: str, checks: dict) -> str:
    """The reader's message for a wrong value of the key (its first value check)."""
    for check, how in checks.items():
        if check not in _BAD:
            continue
        rd = Reader(Path("deck.toml"))
        method = getattr(rd, check)
        bad = -1.0 if check == "number" and (how.get("positive") or how.get("nonnegative")) else _BAD[check]
        kwargs = {k: v for k, v in how.items() if k in ("positive", "nonnegative", "minimum", "maximum", "n")}
        args = (how["options"], how["what"], how["describe"]) if check == "choice" else ()
        try:
            method(bad, key, *args, **kwargs)
        except DeckError as exc:
            return str(exc)
    return ""


def _default(info: dict, declared=None, kind=None) -> str:
    if declared is not None:
        return f"`{declared!r}`"
    values = [v for k, v in info["defaults"] if kind is None or k == kind] or [v for _, v in info["defaults"]]
    if not values:
        return ""
    shown = {repr(v.tolist() if isinstance(v, np.ndarray) else v) for v in values}
    return f"`{shown.pop()}`" if len(shown) == 1 else "depends on the deck"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _rows(pattern: str, keys, info: dict, required=None, declared=None, kind=None) -> list[str]:
    lines = ["| key | required | type and range | default when left out | message for a wrong value |",
             "|---|---|---|---|---|"]
    for key in keys:
        k = info.get(key, {"required": set(), "checks": {}, "defaults": []})
        req = (key in required) if required is not None else (
            "yes" if k["required"] == {True} else "in some cases" if True in k["required"] else "no")
        req = {True: "yes", False: "no"}.get(req, req)
        table = pattern.strip("[]")
        entry = f"{table}[0].{key}" if pattern.startswith("[[") else f"{table}.{key}"
        default = "" if req == "yes" else _default(k, (declared or {}).get(key), kind)
        lines.append(f"| `{key}` | {req} | {_cell(_type(k['checks']))} | {_cell(default)} | "
                     f"{_cell(_message(entry, k['checks']))} |")
    return lines


def markdown(book: _Book | None = None, deck_page: str = "docs/deck.md") -> str:
    """The deck's key tables as Markdown (one section per table, in the order the reader reads them);
    ``deck_page`` the link to the deck's prose."""
    book = book or record()
    out = ["Generated from the deck reader (`flexmbs/deck_reference.py`) when the documentation is built: "
           "a *type* is the reader's check of the value, a *default* the value it uses when the key is left out "
           "(\"depends on the deck\": computed from other keys), a *message* what it answers for a wrong value. "
           "A key with no type is accepted but used by no deck of the gallery; its meaning is in the prose of "
           f"[the deck page]({deck_page}).", ""]
    kind_tables = {"[time_functions.NAME]": {k: (req, list(opt), opt) for k, (_, req, opt) in
                                             deck_module.TIME_FUNCTIONS.items()},
                   "[[springs]]": {k: (req, opt, {}) for k, (req, opt) in SPRING_KEYS.items()},
                   "[solver]": {name: (list(cls.deck_required), list(cls.deck_optional), {})
                                for name, cls in ALGORITHMS.items()}}
    seen = {p.strip("[]").split(".")[0] for p in book.tables}
    unseen = [key for key in book.tables.get("[deck]", {}) if key not in seen]
    if unseen:
        out += ["Tables the reader accepts whose keys no gallery deck shows (they are read by the reader's "
                "own checks, described on the deck page): " + ", ".join(f"`{k}`" for k in unseen) + ".", ""]
    for pattern in book.order:
        info = book.tables[pattern]
        out += [f"## `{pattern}`" if pattern != "[deck]" else "## The deck's tables", ""]
        if pattern in kind_tables:
            disc = KINDS[pattern.strip("[]").split(".")[0]]
            out += _rows(pattern, [disc], info) + [""]
            for kind, (req, opt, declared) in kind_tables[pattern].items():
                out += [f"### `{disc} = \"{kind}\"`", ""]
                out += _rows(pattern, [k for k in [*req, *opt] if k != disc], info, set(req), declared, kind) + [""]
        else:
            out += _rows(pattern, list(info), info) + [""]
    return "\n".join(out)


if __name__ == "__main__":
    print(markdown())
