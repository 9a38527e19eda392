"""Sphinx configuration of the flexmbs documentation site (``make docs``; docs/index.md says why Sphinx).

The pages are the Markdown files of docs/ (MyST), the API reference from the docstrings (autodoc with
napoleon: the docstrings are numpydoc), and three kinds of pages generated here before the build
reads its sources, into docs/_generated/ (not tracked): the deck's key tables from the deck reader
(:mod:`flexmbs.deck_reference`), the gallery from models/*.toml and the report's figures, and the
lessons (notebooks/*.py, jupytext percent format) rendered by MyST-NB.

``FLEXMBS_DOCS_EXECUTE=1`` (``make docs``) executes the lessons at build time, so their pages show
the outputs and figures; without it (the tests' quick build) they are rendered without outputs.
"""

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
# the build reads decks and imports modules but solves nothing: no numba compilation (about a minute) in
# this process; the kernels executing the lessons do not inherit the setting (numba reads it on import)
_JIT = os.environ.pop("NUMBA_DISABLE_JIT", None)
os.environ["NUMBA_DISABLE_JIT"] = "1"
import numba  # noqa: E402,F401

os.environ.pop("NUMBA_DISABLE_JIT")
if _JIT is not None:
    os.environ["NUMBA_DISABLE_JIT"] = _JIT

from flexmbs.site import write_generated_pages  # noqa: E402

EXECUTE = os.environ.get("FLEXMBS_DOCS_EXECUTE") == "1"
if EXECUTE:  # the kernels inherit this: their figures are captured as outputs (not so under MPLBACKEND=Agg)
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
write_generated_pages(HERE / "_generated", execute=EXECUTE)

project = "flexmbs"
author = "flexmbs contributors"
# MathJax from the site's own files (_static/mathjax, copied from the sphinx-mathjax-offline package, MathJax
# 3.2.2): the equations render without a network (a classroom, a cluster); it sets ``mathjax_path``, so it
# comes after sphinx.ext.mathjax
extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.mathjax", "sphinx-mathjax-offline"]
exclude_patterns = ["_build", "conf.py", "Thumbs.db", ".DS_Store"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
nb_custom_formats = {".py": "flexmbs.site.read_lesson"}
nb_execution_mode = "cache" if EXECUTE else "off"  # a lesson is executed again only when it changed
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 4
suppress_warnings = ["myst.header"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": True}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
nitpicky = False
html_theme = "furo"
html_title = "flexmbs"
