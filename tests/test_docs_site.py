"""The documentation site (``make docs``): its quick variant builds with warnings as errors.

The quick variant is what ``make docs`` builds less the lessons' execution and the embedded report;
numba's JIT is off (the build reads decks and imports modules, it solves nothing).  A broken link
between pages, a malformed docstring or table, or a lesson MyST-NB cannot read fails the build.
The getting-started page's Python examples run as doctests.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _env():
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env.pop("FLEXMBS_DOCS_EXECUTE", None)
    return env


def test_quick_site_builds_without_warnings(tmp_path):
    pytest.importorskip("sphinx", reason="the test extra installs sphinx")
    pytest.importorskip("myst_nb", reason="the test extra installs myst-nb")
    out = tmp_path / "html"
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", str(out)],
                         cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    api = (out / "api.html").read_text(encoding="utf-8")
    for name in ("Domain", "Domain.solve", "Domain.add_beam", "SolverSettings", "Section", "PointToPoint",
                 "algorithms.base.Algorithm"):
        assert f'id="reference.{name}"' in api, name
    # the deck reference is generated from the reader: its message for a wrong value is the reader's own
    keys = (ROOT / "docs" / "_generated" / "deck_keys.md").read_text(encoding="utf-8")
    assert "| `rho_inf` | no | number ≥ 0 | `0.8` |" in keys
    assert "deck.toml: solver.damping: must not be negative, got -1.0" in keys
    assert "| `element` | no | one of `beam2`, `beam2_se3`, `beam3` | `'beam2'` |" in keys
    lessons = sorted(p.stem for p in (out / "_generated" / "lessons").glob("*.html"))
    assert lessons == sorted(p.stem for p in (ROOT / "notebooks").glob("[0-9][0-9]_*.py"))
    gallery = (out / "_generated" / "gallery.html").read_text(encoding="utf-8")
    decks = sorted((ROOT / "models").glob("*.toml"))
    assert all(f'id="{p.stem.replace("_", "-")}"' in gallery for p in decks)
    assert len(re.findall(r"<img ", gallery)) >= len(decks)
    # each deck's interactive view (reports/views/, written by `flexmbs report`), drawn in place offline
    from flexmbs.browser import chromium, open_page
    from flexmbs.site import VIEWS

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
