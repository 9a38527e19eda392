"""The documentation site's generated pages (docs/conf.py calls :func:`write_generated_pages`).

What can drift from the code is generated when the site is built, never written by hand: the
deck's key tables (:mod:`flexmbs.deck_reference`), the gallery (one entry per ``models/*.toml``: its
``[meta]``, its checks with their tolerances and reasons, the report's figures and interactive view of it), the
lessons (``notebooks/*.py``, copied for MyST-NB to read as notebooks) and the verification report
(``reports/verification.md``, the output of ``flexmbs report``).
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

from flexmbs.deck_reference import markdown as deck_key_tables

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "reports" / "figures"
VIEWS = ROOT / "reports" / "views"


def _cell(value) -> str:
    return str(value).replace("|", "\\|").replace("\n", " ")


def _provenance(meta: dict) -> str:
    prov = meta.get("provenance", "")
    if isinstance(prov, dict):
        return "; ".join(f"{k}: {v}" for k, v in prov.items())
    return str(prov)


def gallery(out: Path) -> str:
    """The gallery page: every deck of ``models/`` with its checks, the report's figures of it and its interactive
    view (``reports/views/NAME.html``, :mod:`flexmbs.view`), drawn in place."""
    from flexmbs.view import from_page, script

    lines = ["# Gallery", "",
             "Every deck in `models/`, as `flexmbs report` verifies it: what it models and where it comes from, "
             "its checks (the reference, the tolerance and why), and the figures of the last report "
             "(`make report` redraws them; [the report](report.md) has the computed values).  Run one with "
             "`flexmbs run models/NAME.toml`, and look at it in 3D with `flexmbs view out/NAME/results.h5`: "
             "each deck's view below turns with the mouse, plays, and colours the beams by a section force.", ""]
    views = 0
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for path in sorted((ROOT / "models").glob("*.toml")):
        deck = tomllib.loads(path.read_text(encoding="utf-8"))
        meta = deck.get("meta", {})
        name = meta.get("name", path.stem)
        lines += [f"## {path.stem}", "", f"`models/{path.name}` — {meta.get('description', '')}", ""]
        if meta.get("provenance"):
            lines += [f"**Provenance:** {_provenance(meta)}", ""]
        solver = deck.get("solver", {})
        lines += [f"**Algorithm:** `{solver.get('algorithm', 'staggered_central_difference')}`", ""]
        figures = sorted({*FIGURES.glob(f"{name}*.png"), *FIGURES.glob(f"{path.stem}*.png"),
                          *FIGURES.glob(f"crosscheck_{name}*.png"), *FIGURES.glob(f"crosscheck_{path.stem}*.png")})
        for fig in figures:
            shutil.copy2(fig, out / "figures" / fig.name)
            lines += [f"![{fig.stem}](figures/{fig.name})", ""]
        view = VIEWS / f"{path.stem}.html"
        if view.is_file():  # raw HTML on one line: a Markdown HTML block ends at the blank line after it
            lines += [from_page(view.read_text(encoding="utf-8")), "", f"*Interactive view of the report's run of "
                      f"`{path.stem}` (drag to turn, shift-drag to pan, wheel to zoom).*", ""]
            views += 1
        checks = deck.get("checks", {})
        if checks:
            lines += ["| check | what | reference | tolerance | why this tolerance |", "|---|---|---|---|---|"]
            for key, spec in checks.items():
                tol = spec.get("tolerance", "")
                if spec.get("relative_to"):
                    tol = f"{tol} of the {spec['relative_to']}"
                lines.append(f"| `{key}` | {_cell(spec.get('description', spec.get('observable', '')))} | "
                             f"{_cell(spec.get('reference', ''))} | {_cell(tol)} | {_cell(spec.get('reason', ''))} |")
            lines.append("")
        cross = deck.get("crosscheck", {})
        if cross:
            lines += ["Cross-checked with Exudyn: " + ", ".join(
                f"`{spec.get('observable', key)}` within {spec.get('tolerance')}"
                + (f" of the {spec['relative_to']}" if spec.get("relative_to") else "") for key, spec in cross.items())
                + ".", ""]
    if views:
        lines += [script(), ""]
    return "\n".join(lines)


def report(out: Path, embed: bool) -> str:
    """The verification report's page: the committed ``reports/verification.md`` (with its figures) or a
    pointer to it (the tests' quick build)."""
    source = ROOT / "reports" / "verification.md"
    head = ["# Verification report", "",
            "`flexmbs report` (or `make report`) runs every deck of the gallery, checks every number against its "
            "reference and writes `reports/verification.md` and a self-contained `reports/verification.html`.", ""]
    if not embed or not source.exists():
        return "\n".join(head + ["This build does not embed the report: build the site with `make docs`, or read "
                                 "`reports/verification.md`."])
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for fig in FIGURES.glob("*.png"):
        shutil.copy2(fig, out / "figures" / fig.name)
    text = source.read_text(encoding="utf-8")
    body = text.split("\n", 1)[1] if text.startswith("# ") else text
    body = body.replace("](docs/", "](../").replace("`docs/", "`docs/")
    return "\n".join(head) + "\n" + _views_in_place(body, source.parent)


def _views_in_place(markdown: str, base: Path) -> str:
    """The report's links to its interactive views (``[…](views/NAME.html)`` opening a paragraph) as the views
    themselves, the viewer's script once at the end; a link to a view that is not there loses its link."""
    from flexmbs.html import VIEW
    from flexmbs.view import from_page, script

    lines, views = [], 0
    for line in markdown.splitlines():
        view = VIEW.match(line)
        if view:
            page = base / view.group(1)
            line = VIEW.sub(lambda m: m.group(0)[1:m.group(0).index("](")], line, count=1)
            if page.is_file():
                lines += [from_page(page.read_text(encoding="utf-8")), ""]
                views += 1
        lines.append(line)
    return "\n".join(lines + (["", script(), ""] if views else []))


def write_generated_pages(out: Path, execute: bool = False) -> None:
    """Write the generated pages into ``out`` (``docs/_generated``); ``execute``: the full build (the lessons
    are executed by MyST-NB, and the report is embedded)."""
    out.mkdir(parents=True, exist_ok=True)
    keys = ["# Deck keys", "", deck_key_tables(deck_page="../deck.md")]
    pages = {"deck_keys.md": "\n".join(keys), "gallery.md": gallery(out), "report.md": report(out, execute)}
    lessons = out / "lessons"
    lessons.mkdir(exist_ok=True)
    for old in lessons.glob("*.py"):
        old.unlink()
    for lesson in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py")):
        shutil.copy2(lesson, lessons / lesson.name)
    for name, text in pages.items():
        path = out / name
        if not path.exists() or path.read_text(encoding="utf-8") != text:  # unchanged pages are not rebuilt
            path.write_text(text, encoding="utf-8")


def read_lesson(text: str):
    """A lesson (jupytext percent format) as a notebook for MyST-NB, its cells highlighted as Python
    (docs/conf.py ``nb_custom_formats``; the lesson files name their kernel but not its language)."""
    import jupytext

    nb = jupytext.reads(text, fmt="py:percent")
    nb.metadata.setdefault("language_info", {"name": "python", "pygments_lexer": "ipython3"})
    for cell in nb.cells:  # an exercise's answer (collapsed in Jupyter) is collapsed on the page too
        tags = cell.metadata.get("tags", [])
        if "solution" in tags and "hide-cell" not in tags:
            cell.metadata["tags"] = [*tags, "hide-cell"]
    return nb
