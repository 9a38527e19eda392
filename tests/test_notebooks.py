"""Every teaching notebook runs (short horizons, headless) and asserts the numbers it teaches."""

from __future__ import annotations

import os
import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.py"))


def test_the_lessons_are_there():
    assert {"01", "02", "03", "04", "05", "09"} <= {p.stem[:2] for p in NOTEBOOKS}


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(notebook, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.setenv("FLEXMBS_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(ROOT)
    runpy.run_path(str(notebook), run_name="__main__")  # the notebook's own asserts are the test
    assert os.environ["FLEXMBS_QUICK"] == "1"
