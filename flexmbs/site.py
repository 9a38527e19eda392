"""The documentation site's generated pages (docs/conf.py calls :func:`write_generated_pages`).

What can drift from the code is generated when the site is built, never written by hand: the
deck's key tables (:mod:`flexmbs.deck_reference`), the gallery (one entry per ``models/*.toml``: its
``[meta]``, its checks with their tolerances and reasons, the report's figures and interactive view of it), the
lessons (``notebooks/*.py``, copied for MyST-NB to read as notebooks) and the verification report
(``reports/verification.md``, the output of ``flexmbs report``).

The built site is checked as a reader sees it by :func:`check_site` (``make docs-check``, ``python -m
flexmbs.site check build/docs``): headless Chromium (:mod:`flexmbs.browser`) renders its main pages with no
network, and any raw LaTeX, console error, failed load or broken link or anchor is reported.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import tomllib
from pathlib import Path
from urllib.parse import unquote, urlsplit

from flexmbs.browser import Browser, BrowserError, chromium
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
    (docs/conf.py ``nb_custom_formats``; the lesson files name their kernel but not its language); its answers
    (cells tagged ``solution``) collapsed, its checks (``check``) left out of the page."""
    import jupytext

    nb = jupytext.reads(text, fmt="py:percent")
    nb.metadata.setdefault("language_info", {"name": "python", "pygments_lexer": "ipython3"})
    for cell in nb.cells:  # an exercise's answer (collapsed in Jupyter) is collapsed on the page too; the
        tags = cell.metadata.get("tags", [])  # lesson's checks (its asserts, run by the tests) are left out
        if "solution" in tags and "hide-cell" not in tags:
            cell.metadata["tags"] = [*tags, "hide-cell"]
        elif "check" in tags and "remove-cell" not in tags:
            cell.metadata["tags"] = [*tags, "remove-cell"]
    return nb


PAGES = ("index.html", "getting_started.html", "modelling.html", "deck.html", "_generated/deck_keys.html",
         "api.html#reference.Domain",
         "formulation.html#7-stabilised-lagrange-multipliers-parkchiou-family-a-reconstruction",
         "_generated/lessons/02_beam_rollup.html", "_generated/lessons/10_modes_buckling.html")
"""The pages ``make docs-check`` renders: the index, getting started, the modelling guide, the deck reference
(prose and key tables), the API's ``Domain``, formulation §7 (the multipliers), lesson 2 and lesson 10."""

_RAW_LATEX = r"\$\$|\\\(|\\\)|\\\[|\\\]|\$\\[a-zA-Z]|\\(?:frac|mathsf|mathbf|mathcal|tilde|qquad|quad|left|right)\b"
"""Raw LaTeX in a page's text: dollar or backslash delimiters, or a TeX command, outside the rendered equations."""

_SURVEY = r"""
document.readyState === "complete" && (async () => { try {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) { await MathJax.startup.promise; }
  const raw = new RegExp(%s);
  const skip = new Set(["SCRIPT", "STYLE", "CODE", "PRE", "TEXTAREA", "MJX-CONTAINER", "MJX-ASSISTIVE-MML"]);
  const found = [];
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    let p = n.parentElement, skipped = false;
    for (; p; p = p.parentElement) { if (skip.has(p.tagName)) { skipped = true; break; } }
    if (!skipped && raw.test(n.data)) { found.push(n.data.trim().slice(0, 160)); }
  }
  const math = document.querySelectorAll(".math").length;
  const rendered = document.querySelectorAll("mjx-container").length;
  const errors = [...document.querySelectorAll("mjx-merror")].map(e => e.getAttribute("data-mjx-error") || e.textContent);
  const links = [...document.querySelectorAll("a[href]")].map(a => a.href);
  const views = window.flexmbsViews || [];
  for (const t0 = Date.now(); views.some(v => !v.ready) && Date.now() - t0 < 30000;) {
    await new Promise(done => setTimeout(done, 50));
  }
  const drawn = views.map(v => {
    if (!v.ready) { return null; }
    const c = v.canvas, d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    let inked = 0;
    for (let i = 0; i < d.length; i += 4) {
      if (d[i + 3] > 0 && (d[i] < 200 || d[i + 1] < 200 || d[i + 2] < 200)) { inked++; }
    }
    return {drawn: v.drawn, inked};
  });
  const anchor = location.hash && document.getElementById(decodeURIComponent(location.hash.slice(1)));
  if (anchor) { anchor.scrollIntoView(); }
  return JSON.stringify({raw: found, math, rendered, errors, links, views: drawn});
} catch (e) { return JSON.stringify({failed: String(e)}); } })()
"""
"""What :func:`check_site` waits for on each page (the ready expression of :meth:`flexmbs.browser.Browser.open`, its
``%s`` filled with :data:`_RAW_LATEX`): once the page has loaded and MathJax has typeset it, the page's raw LaTeX,
equations, typeset equations, MathJax errors and links as JSON, and for each interactive 3D view
(:mod:`flexmbs.view`, awaited until it is ready, at most 30 s) what it drew: its count of drawn items and its
canvas's inked pixels (painted, not near-white), null when it never became ready; the page scrolled to its
anchor for the screenshot."""


def _ids(path: Path, cache: dict) -> set[str]:
    """The ``id`` and ``name`` attributes of an HTML file (the anchors a link's fragment may name)."""
    if path not in cache:
        text = path.read_text(encoding="utf-8", errors="replace")
        cache[path] = set(re.findall(r'\b(?:id|name)="([^"]+)"', text))
    return cache[path]


def check_site(site: Path, pages=PAGES, screenshots: Path | None = None, report: Path | None = None) -> list[str]:
    """Render ``pages`` of the built site ``site`` in headless Chromium, offline, and return the problems
    found, one line each (none: the pages pass).

    Each page is loaded from its file, MathJax is awaited, and the rendered page is checked for: raw LaTeX in
    its text (``$$``, ``\\(``, a TeX command outside the typeset equations), equations that MathJax did not
    typeset or typeset with an error, an interactive 3D view that does not draw (a blank canvas), console
    errors, uncaught exceptions and failed loads (a file missing from the site, or a resource from the network),
    and links to a missing page or to an anchor the target page does not have.  ``screenshots``: a folder that
    receives one PNG per page, scrolled to the page's anchor.  ``report``: the self-contained HTML report
    (``reports/verification.html``, :func:`flexmbs.report.write_html`), checked the same way after the site's
    pages (its problems named by its file name; its screenshot ``verification.png``).
    """
    site = Path(site).resolve()
    problems: list[str] = []
    anchors: dict = {}
    with Browser(width=1280, height=1600) as browser:
        for page in pages:
            name, _, fragment = page.partition("#")
            path = site / name
            if not path.exists():
                problems.append(f"{page}: not in the site")
                continue
            if fragment and fragment not in _ids(path, anchors):
                problems.append(f"{page}: no anchor #{fragment} in the page")
            stem = name.removesuffix(".html").replace("/", "_").removeprefix("_generated_")
            problems += _check_page(browser, path, page, fragment, site, anchors,
                                    screenshots and Path(screenshots) / f"{stem}.png")
        if report is not None:
            report = Path(report).resolve()
            problems += _check_page(browser, report, report.name, "", report.parent, anchors,
                                    screenshots and Path(screenshots) / f"{report.stem}.png")
    return problems


def _check_page(browser, path: Path, page: str, fragment: str, site: Path, anchors: dict,
                screenshot: Path | None) -> list[str]:
    """The problems of one page of :func:`check_site` (``page`` its name in them, ``site`` the folder its links
    are named relative to), its screenshot written to ``screenshot`` when given."""
    try:  # the load's messages arrive before the survey's answer: a short settle
        seen = browser.open(path, ready=_SURVEY % json.dumps(_RAW_LATEX), fragment=fragment, settle=0.1,
                            screenshot=screenshot is not None)
    except BrowserError as error:
        return [f"{page}: {error}"]
    found = json.loads(seen.value)
    if "failed" in found:
        return [f"{page}: the survey script failed: {found['failed']}"]
    problems = [f"{page}: raw LaTeX in the text: {text!r}" for text in found["raw"]]
    problems += [f"{page}: MathJax error: {text}" for text in found["errors"]]
    if found["rendered"] < found["math"]:
        problems.append(f"{page}: {found['math'] - found['rendered']} of {found['math']} equations "
                        "not typeset (MathJax did not load?)")
    views = found["views"]
    problems += [f"{page}: 3D view {k + 1} of {len(views)} " + ("never became ready" if view is None else
                 f"drew nothing ({view['drawn']} items, {view['inked']} inked pixels)")
                 for k, view in enumerate(views) if view is None or not (view["drawn"] > 0 and view["inked"] > 0)]
    problems += [f"{page}: {'uncaught exception' if level == 'exception' else 'console error'}: "
                 + " ".join(str(text).split())  # a stack trace on the same line
                 for level, text in seen.console if level in ("error", "exception")]
    problems += [f"{page}: loaded from the network: {url}" for url in seen.requests]
    for link in dict.fromkeys(found["links"]):
        url = urlsplit(link)
        if url.scheme != "file":
            continue
        target = Path(unquote(url.path))
        if not target.exists():
            problems.append(f"{page}: broken link to {target.relative_to(site) if site in target.parents else target}")
        elif url.fragment and target.suffix == ".html" and unquote(url.fragment) not in _ids(target, anchors):
            problems.append(f"{page}: link to a missing anchor {target.name}#{url.fragment}")
    if screenshot is not None:
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        screenshot.write_bytes(seen.screenshot)
    return problems


def main(argv=None) -> int:
    """``python -m flexmbs.site check [SITE] [--screenshots DIR] [--report HTML]`` (``make docs-check``): exit 1
    and one line per problem when a page fails, 0 and the pages checked when all pass.  ``--report``: the HTML
    report is checked too, written again from the Markdown report beside it (``flexmbs.html.write_html``) when it
    is missing or older."""
    parser = argparse.ArgumentParser(prog="python -m flexmbs.site", description=main.__doc__)
    parser.add_argument("command", choices=["check"])
    parser.add_argument("site", nargs="?", default="build/docs", type=Path)
    parser.add_argument("--screenshots", type=Path, default=None, help="write one PNG per page into this folder")
    parser.add_argument("--report", type=Path, default=None,
                        help="check this HTML report too (reports/verification.html)")
    args = parser.parse_args(argv)
    if chromium() is None:
        print("flexmbs: error: no Chromium on the PATH; install one (Debian: apt-get install chromium)",
              file=sys.stderr)
        return 2
    if not (args.site / "index.html").exists():
        print(f"flexmbs: error: {args.site}: no built site here; build it with `make docs`", file=sys.stderr)
        return 2
    report = args.report and _fresh_report(args.report)
    if args.report is not None and report is None:
        print(f"flexmbs: error: {args.report}: no report here, nor its Markdown beside it; make one with "
              "`flexmbs report`", file=sys.stderr)
        return 2
    try:
        problems = check_site(args.site, screenshots=args.screenshots, report=report)
    except BrowserError as error:
        print(f"flexmbs: error: {error}", file=sys.stderr)
        return 2
    for line in problems:
        print(line)
    if problems:
        return 1
    pages = [*PAGES, *([str(args.report)] if report else [])]
    print(f"{len(pages)} pages rendered offline in headless Chromium: no raw LaTeX, no console errors, "
          "every 3D view drawn, no broken links or anchors: " + ", ".join(pages))
    return 0


def _fresh_report(html: Path) -> Path | None:
    """The HTML report ``html``, written again from the Markdown report beside it when that is newer (or the HTML
    is missing: it is not committed); None when neither is there."""
    from flexmbs.html import write_html

    source = html.with_suffix(".md")
    if source.exists() and (not html.exists() or html.stat().st_mtime < source.stat().st_mtime):
        write_html(source)
    return html if html.exists() else None


if __name__ == "__main__":
    raise SystemExit(main())
