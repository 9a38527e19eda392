"""The documentation site (``make docs``): its quick variant builds with warnings as errors.

The quick variant is what ``make docs`` builds less the lessons' execution and the embedded report;
numba's JIT is off (the build reads decks and imports modules, it solves nothing).  A broken link
between pages, a malformed docstring or table, or a lesson MyST-NB cannot read fails the build.
The getting-started page's Python examples run as doctests.  The built pages hold no raw LaTeX (a ``$$`` block
that touches a paragraph is not display math for MyST: it comes out as a stray ``$`` and inline math whose
delimiters pair with the wrong ones), and, where Chromium is installed, render offline with their equations
typeset by the site's own MathJax, no console error and no broken link or anchor; so does the HTML verification
report, every interactive 3D view in it drawn.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

from flexmbs.browser import chromium, open_page
from flexmbs.site import PAGES, VIEWS, check_site

ROOT = Path(__file__).resolve().parent.parent


def _env():
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env.pop("FLEXMBS_DOCS_EXECUTE", None)
    return env


@pytest.fixture(scope="module")
def quick_site(tmp_path_factory):
    """The quick variant of the site, built once for the tests of this module (warnings are errors)."""
    pytest.importorskip("sphinx", reason="the test extra installs sphinx")
    pytest.importorskip("myst_nb", reason="the test extra installs myst-nb")
    out = tmp_path_factory.mktemp("site") / "html"
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", str(out)],
                         cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return out


def test_quick_site_builds_without_warnings(quick_site):
    out = quick_site
    api = (out / "api.html").read_text(encoding="utf-8")
    for name in ("Domain", "Domain.solve", "Domain.add_beam", "SolverSettings", "Section", "PointToPoint",
                 "algorithms.base.Algorithm"):
        assert f'id="reference.{name}"' in api, name
    # the deck reference is generated from the reader: its message for a wrong value is the reader's own
    keys = (ROOT / "docs" / "_generated" / "deck_keys.md").read_text(encoding="utf-8")
    assert re.search(r"\| `rho_inf` \| generalized-α: spectral radius [^|]+ \| no \| number ≥ 0 \| `0.8` \|", keys)
    assert "deck.toml: solver.damping: must not be negative, got -1.0" in keys
    assert re.search(r"\| `element` \| the element family[^|]+ \| no \| one of `beam2`, `beam2_se3`, `beam3` \| `'beam2'` \|",
                     keys)
    lessons = sorted(p.stem for p in (out / "_generated" / "lessons").glob("*.html"))
    assert lessons == sorted(p.stem for p in (ROOT / "notebooks").glob("[0-9][0-9]_*.py"))
    gallery = (out / "_generated" / "gallery.html").read_text(encoding="utf-8")
    decks = sorted((ROOT / "models").glob("*.toml"))
    assert all(f'id="{p.stem.replace("_", "-")}"' in gallery for p in decks)
    assert len(re.findall(r"<img ", gallery)) >= len(decks)
    # each deck's interactive view (reports/views/, written by `flexmbs report`), drawn in place offline
    views = len([p for p in VIEWS.glob("*.html") if (ROOT / "models" / p.name).with_suffix(".toml").exists()])
    assert gallery.count('<div class="flexmbs-view">') == views > 0
    if chromium() is None:
        pytest.skip("no chromium executable: the gallery's views were not opened (apt-get install chromium)")
    seen = open_page(out / "_generated" / "gallery.html", screenshot=False, timeout=120,
                     ready=f"window.flexmbsViews && window.flexmbsViews.length === {views} && "
                     "window.flexmbsViews.every(function (v) { return v.ready && v.drawn > 0; })")
    assert seen.requests == [] and seen.errors == [], (seen.requests, seen.errors)


def test_examples_run_as_doctests():
    """The getting-started page's first model in Python (a pendulum whose angular velocity after 10 ms is
    checked against α t) and the examples in the docstrings of the modules exported from ``reference`` run
    as doctests, in one process with the JIT off."""
    modules = ["reference", "reference.domain", "reference.interactions", "reference.forces", "reference.joints.joint",
               "reference.elements.section", "reference.algorithms.base", "reference.io.deck"]
    code = ("import doctest, importlib, sys\n"
            "results = [doctest.testfile(sys.argv[1], module_relative=False)]\n"
            f"results += [doctest.testmod(importlib.import_module(name)) for name in {modules!r}]\n"
            "print(results[0].attempted, sum(r.attempted for r in results[1:]))\n"
            "sys.exit(1 if any(r.failed for r in results) else 0)\n")
    run = subprocess.run([sys.executable, "-c", code, str(ROOT / "docs" / "getting_started.md")], cwd=ROOT,
                         env=_env(), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    page, docstrings = map(int, run.stdout.split()[-2:])
    assert page >= 10 and docstrings >= 10  # the page's pendulum; the package's and NodalLoad's examples


class _RawLatex(HTMLParser):
    """The text of a page outside its equations (elements of class ``math``, which MathJax typesets) and outside
    code, scripts and styles, where a ``$``, ``\\(``, ``\\)``, ``\\[`` or ``\\]`` is LaTeX the reader would see raw."""

    VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}
    SKIP = {"script", "style", "code", "pre", "textarea"}

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.open: list[tuple[str, bool]] = []
        self.raw: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag not in self.VOID:
            self.open.append((tag, tag in self.SKIP or "math" in (dict(attrs).get("class") or "").split()))

    def handle_endtag(self, tag):
        for i in range(len(self.open) - 1, -1, -1):
            if self.open[i][0] == tag:
                del self.open[i:]
                break

    def handle_data(self, data):
        if not any(skip for _, skip in self.open) and re.search(r"\$|\\[()\[\]]", data):
            self.raw.append(f"line {self.getpos()[0]}: {data.strip()[:120]!r}")


def test_no_raw_latex_in_the_pages(quick_site):
    """Every equation of the site's pages (docs/*.md, the lessons, the docstrings) is inside an element MathJax
    typesets: no ``$`` or backslash delimiter is left in the text (formulation §7's multiplier equation and lesson
    2's strain energy were a stray ``$`` and mispaired inline math when written as ``$$`` inside a paragraph)."""
    pages = sorted(p for p in quick_site.rglob("*.html") if "_sources" not in p.parts)
    assert len(pages) > 20
    raw = {}
    for page in pages:
        parser = _RawLatex()
        parser.feed(page.read_text(encoding="utf-8"))
        if parser.raw:
            raw[str(page.relative_to(quick_site))] = parser.raw
    assert not raw, raw
    # MathJax is the site's own copy: nothing is loaded from a network
    formulation = (quick_site / "formulation.html").read_text(encoding="utf-8")
    scripts = re.findall(r'<script[^>]*src="([^"]+)"', formulation)
    assert "_static/mathjax/tex-chtml.js" in scripts and not [s for s in scripts if "//" in s], scripts
    assert (quick_site / "_static" / "mathjax" / "tex-chtml.js").is_file()


@pytest.mark.skipif(chromium() is None, reason="no Chromium on the PATH (Debian: apt-get install chromium; README.md, "
                                               "`make docs-check`)")
def test_pages_render_offline_in_chromium(quick_site, tmp_path):
    """``make docs-check`` on the quick site: the index, getting started, the deck reference, the API's Domain,
    formulation §7 and lessons 2 and 10 rendered in headless Chromium with the network cut off: the
    equations typeset by the site's MathJax, no raw LaTeX in the rendered text, no console error or failed load,
    no link to a missing page or anchor."""
    problems = check_site(quick_site, screenshots=tmp_path)
    assert not problems, "\n".join(problems)
    assert len(list(tmp_path.glob("*.png"))) == len(PAGES)


@pytest.mark.skipif(chromium() is None, reason="no Chromium on the PATH (Debian: apt-get install chromium)")
def test_site_check_reports_what_a_reader_would_see(tmp_path):
    """The site check on a page with every fault it looks for, written at the end of the page where the check's
    answer comes right after them (a console message or exception that arrived together with a reply of the
    browser was once dropped): each fault is one line, and a page or anchor missing from the site is named."""
    (tmp_path / "index.html").write_text('<html><body><p id="here">fine</p></body></html>', encoding="utf-8")
    (tmp_path / "bad.html").write_text(
        '<html><body><p>raw $$x^2$$ here</p><a href="gone.html">a</a><a href="index.html#nowhere">b</a>'
        '<a href="index.html#here">c</a><img src="https://example.org/x.png"><img src="missing.png">'
        '<canvas id="blank" width="20" height="20"></canvas><script>window.flexmbsViews = [{ready: true, drawn: 0, '
        'canvas: document.getElementById("blank")}];</script>'
        '<script>console.error("boom"); setTimeout(function () { null.x; }, 0);</script></body></html>',
        encoding="utf-8")
    problems = check_site(tmp_path, pages=("bad.html", "index.html#here", "index.html#elsewhere", "absent.html"))
    expected = ["bad.html: raw LaTeX in the text: 'raw $$x^2$$ here'",
                "bad.html: 3D view 1 of 1 drew nothing (0 items, 0 inked pixels)",
                "bad.html: console error: boom",
                "bad.html: uncaught exception: TypeError: Cannot read properties of null (reading 'x')",
                "bad.html: console error: Failed to load resource: net::ERR_INTERNET_DISCONNECTED "
                "https://example.org/x.png",
                "bad.html: console error: Failed to load resource: net::ERR_FILE_NOT_FOUND "
                + (tmp_path / "missing.png").as_uri(),
                "bad.html: loaded from the network: https://example.org/x.png",
                "bad.html: broken link to gone.html",
                "bad.html: link to a missing anchor index.html#nowhere",
                "index.html#elsewhere: no anchor #elsewhere in the page",
                "absent.html: not in the site"]
    for line in expected:
        assert any(problem.startswith(line) for problem in problems), (line, problems)
    assert len(problems) == len(expected), problems


@pytest.mark.skipif(chromium() is None, reason="no Chromium on the PATH (Debian: apt-get install chromium)")
def test_the_html_report_renders_offline_with_every_view_drawn(tmp_path):
    """``make docs-check``'s last page: the HTML report written from the committed ``reports/verification.md``
    (its figures embedded, its views beside it) rendered offline: no raw LaTeX, no console error or network load,
    no broken link or anchor (the contents table's anchors, the links to the views), and each deck's embedded 3D
    view drawn (items drawn and a canvas that is not blank); its screenshot written."""
    from flexmbs.site import _fresh_report

    source = ROOT / "reports" / "verification.md"
    (tmp_path / "verification.md").write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
    for folder in ("figures", "views"):
        (tmp_path / folder).symlink_to(ROOT / "reports" / folder, target_is_directory=True)
    report = _fresh_report(tmp_path / "verification.html")
    page = report.read_text(encoding="utf-8")
    views = page.count('<div class="flexmbs-view">')
    assert views == len(re.findall(r"^\[[^\]]+\]\(views/", source.read_text(encoding="utf-8"), re.M)) >= 20
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "index.html").write_text("<html><body></body></html>", encoding="utf-8")
    problems = check_site(tmp_path / "site", pages=(), screenshots=tmp_path / "shots", report=report)
    assert not problems, "\n".join(problems)
    assert (tmp_path / "shots" / "verification.png").stat().st_size > 10_000  # a page, not an empty image


def test_the_html_report_is_written_again_when_its_markdown_is_newer(tmp_path):
    """``make docs-check --report``: the HTML report (not committed) is written from the Markdown beside it when
    missing or older, left alone otherwise; with neither, there is nothing to check."""
    from flexmbs.site import _fresh_report

    html, md = tmp_path / "verification.html", tmp_path / "verification.md"
    assert _fresh_report(html) is None
    md.write_text("# report\n\nfirst\n", encoding="utf-8")
    assert _fresh_report(html) == html and "<p>first</p>" in html.read_text(encoding="utf-8")
    html.write_text("kept", encoding="utf-8")
    os.utime(md, (html.stat().st_mtime - 10, html.stat().st_mtime - 10))
    assert _fresh_report(html) == html and html.read_text(encoding="utf-8") == "kept"
    md.write_text("# report\n\nsecond\n", encoding="utf-8")
    os.utime(md, (html.stat().st_mtime + 10, html.stat().st_mtime + 10))
    assert "<p>second</p>" in _fresh_report(html).read_text(encoding="utf-8")


def test_every_deck_key_has_a_row_with_its_meaning():
    """The deck reference (``python -m flexmbs.deck_reference``) has a table for every table the reader accepts and
    a row for every key of each, the keys of every kind (time functions, springs, algorithms) included, each row
    with a meaning; the keys no gallery deck uses are typed from the reader's checks too (a joint's ``reference``,
    ``mode`` and ``formulation``, ``[[prescribed_displacements]]``), and the joints' ``kind`` says that a drive is
    one equation that needs a joint beside it."""
    from flexmbs.deck_reference import markdown
    from reference.algorithms import ALGORITHMS
    from reference.io.deck import TIME_FUNCTIONS, TOP_LEVEL
    from reference.io.deck_connectors import SPRING_KEYS

    rows: dict[str, dict[str, list[str]]] = {}
    section = None
    for line in markdown().splitlines():
        if line.startswith("## ") or line.startswith("### "):
            section = line.strip("# ")
        elif line.startswith("| `"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            rows.setdefault(section, {})[cells[0].strip("`")] = cells[1:]
    empty = [f"{s}: {k}" for s, keys in rows.items() for k, cells in keys.items() if not cells[0]]
    assert not empty, f"keys without a meaning: {empty}"
    assert set(rows["The deck's tables"]) == set(TOP_LEVEL)
    tables = {s.split("`")[1].strip("[]").split(".")[0] for s in rows if s.startswith("`[")}
    assert tables == set(TOP_LEVEL), set(TOP_LEVEL) ^ tables
    for kind, (_, required, optional) in TIME_FUNCTIONS.items():
        assert {*required, *optional} - {"kind"} <= set(rows[f'`kind = "{kind}"`']), kind
    for kind, (required, optional) in SPRING_KEYS.items():
        assert {*required, *optional} <= set(rows[f'`kind = "{kind}"`']), kind
    for name, cls in ALGORITHMS.items():
        assert {*cls.deck_required, *cls.deck_optional} <= set(rows[f'`algorithm = "{name}"`']), name
    joints = rows["`[[joints]]`"]
    assert joints["mode"][2] == "one of `position`, `velocity`" and joints["mode"][3] == "`'position'`"
    assert joints["formulation"][2] == "one of `jacobian`, `master_slave`, `augmented_lagrangian`"
    assert "unknown joint formulation '?'" in joints["formulation"][4]
    assert joints["reference"][2].startswith("3 numbers")
    assert "one equation" in joints["kind"][0] and "`revolute`" in joints["kind"][0]
    prescribed = rows["`[[prescribed_displacements]]`"]
    assert set(prescribed) == {"node", "direction", "time_function", "label", "point"}
    assert prescribed["direction"][2] == "3 numbers, not all 0"
    assert {"description", "tolerance", "reason", "observable"} <= set(rows["`[checks.NAME]`"])
