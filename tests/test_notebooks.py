"""Every lesson in notebooks/ runs as a Jupyter notebook, as a student opens it.

Each ``notebooks/*.py`` (jupytext percent format) is converted to a notebook and
executed cell by cell by a real IPython kernel (nbclient) whose working
directory is an unrelated temporary folder — so a lesson that finds the
repository's files only from the repository root fails here.  The lessons'
own asserts are the checks; ``FLEXMBS_QUICK=1`` shortens their runs.  New
lesson files are picked up automatically.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py"))


def test_the_lessons_exist():
    stems = [p.stem[:2] for p in NOTEBOOKS]
    assert stems[:6] == ["01", "02", "03", "04", "05", "06"] and len(set(stems)) == len(stems) and "09" in stems


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_executes_in_a_kernel(notebook, tmp_path, monkeypatch):
    jupytext = pytest.importorskip("jupytext", reason="the test extra installs jupytext")
    nbclient = pytest.importorskip("nbclient", reason="the test extra installs nbclient")
    pytest.importorskip("ipykernel", reason="the test extra installs ipykernel")

    nb = jupytext.read(notebook)
    assert sum(c.cell_type == "markdown" for c in nb.cells) >= 1, "a lesson explains itself in markdown cells"
    # the kernel inherits this environment: quick runs, headless figures, and this tree imported first
    monkeypatch.setenv("FLEXMBS_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()  # raises CellExecutionError, naming the cell, if any cell fails
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors
