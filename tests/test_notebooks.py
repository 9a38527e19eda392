"""Every lesson in notebooks/ runs as a Jupyter notebook, as a student opens it.

Each ``notebooks/*.py`` (jupytext percent format) is converted to a notebook and
executed cell by cell by a real IPython kernel (nbclient) whose working
directory is an unrelated temporary folder — so a lesson that finds the
repository's files only from the repository root fails here.  The lessons'
own asserts are the checks; ``FLEXMBS_QUICK=1`` shortens their runs.  New
lesson files are picked up automatically.

Exercises: questions under a ``## Exercises`` heading, answers after a ``## Answers`` heading in
code cells tagged ``solution`` whose source is collapsed (Jupyter's
``"jupyter": {"source_hidden": true}``), so they run — and are checked — with the lesson.  One
of them, tagged ``rerun`` as well, answers an exercise that changes the model and reruns it.

Numbers quoted in a lesson's text are tagged where the output can confirm them: a number
followed (after an optional unit) by ``<!-- check NAME rel|abs TOL -->`` must match the
variable ``NAME`` of the executed notebook to within TOL (relative or absolute).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py"))
QUOTED = re.compile(r"(?P<number>[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)(?:\s*[^\s\d<>]+)?\s*"
                    r"<!--\s*check\s+(?P<name>\w+)\s+(?P<kind>rel|abs)\s+(?P<tolerance>\S+)\s*-->")


def quoted_numbers(nb) -> list[tuple[str, float, str, float]]:
    """(name, quoted value, "rel" or "abs", tolerance) of every tagged number in the markdown."""
    return [(m["name"], float(m["number"]), m["kind"], float(m["tolerance"]))
            for c in nb.cells if c.cell_type == "markdown" for m in QUOTED.finditer(c.source)]


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
    quoted = quoted_numbers(nb)
    names = sorted({name for name, *_ in quoted})
    nb.cells.append(nbformat_cell(jupytext, f"import json\nprint('QUOTED' + json.dumps({{n: float(globals()[n]) for n in {names!r}}}))"))
    client.execute()  # raises CellExecutionError, naming the cell, if any cell fails
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors
    # run as a notebook or as a script, a lesson saves its figures into figures/<lesson>/ where it runs
    plots = sum(c.source.count("plt.subplots(") + c.source.count("plt.figure(") for c in nb.cells if c.cell_type == "code")
    saved = sorted(p.name for p in (tmp_path / "figures" / notebook.stem).glob("*.png"))
    assert len(saved) == plots and all(p.stat().st_size > 1000 for p in (tmp_path / "figures" / notebook.stem).glob("*.png")), (
        f"{notebook.name}: {plots} figures drawn, saved: {saved}")
    printed = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                      if o.output_type == "stream")
    assert "np.float64(" not in printed, "print plain numbers (float(...) or a format), not numpy reprs"
    if notebook.stem == "10_modes_buckling":  # the cantilever's modes and the lateral buckling modes, interactive
        views = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                 if "flexmbs-view-frame" in o.get("data", {}).get("text/html", "")]
        assert len(views) == 2
    values = json.loads(printed.rsplit("QUOTED", 1)[1])
    for name, number, kind, tolerance in quoted:
        scale = abs(values[name]) if kind == "rel" else 1.0
        assert abs(number - values[name]) <= tolerance * scale, (
            f"{notebook.name}: the text quotes {number:g} for {name}, the run gives {values[name]:.6g}")


def nbformat_cell(jupytext, source: str):
    """A code cell for ``source``, of the notebook format jupytext reads."""
    return jupytext.reads(f"# %%\n{source}\n", fmt="py:percent").cells[0]


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_lesson_asks_first_and_hides_its_answers(notebook):
    jupytext = pytest.importorskip("jupytext", reason="the test extra installs jupytext")
    cells = jupytext.read(notebook).cells

    def heading(title):
        found = [i for i, c in enumerate(cells) if c.cell_type == "markdown" and re.search(rf"^## {title}\b", c.source, re.M)]
        assert found, f"{notebook.name}: no '## {title}' heading"
        return found[0]

    exercises, answers = heading("Exercises"), heading("Answers")
    text = "\n".join(c.source for c in cells[exercises:answers + 1] if c.cell_type == "markdown")
    questions = text[text.index("## Exercises"):text.index("## Answers")] if "## Answers" in text else ""
    solutions = [i for i, c in enumerate(cells) if "solution" in c.metadata.get("tags", [])]
    assert questions.count("**Exercise") >= 2, f"{notebook.name}: two exercises, asked before the answers"
    assert "change the model and rerun" in questions, f"{notebook.name}: an exercise that changes the model and reruns it"
    assert len(solutions) >= 2 and min(solutions) > answers, f"{notebook.name}: the answers come after the questions"
    for i in solutions:
        assert cells[i].cell_type == "code" and cells[i].metadata.get("jupyter", {}).get("source_hidden") is True, (
            f"{notebook.name}: answer cell {i} is collapsed (jupyter.source_hidden)")
    assert all(i in solutions for i, c in enumerate(cells) if c.cell_type == "code" and i > answers), (
        f"{notebook.name}: every code cell under '## Answers' is a hidden answer")
    assert any("rerun" in cells[i].metadata.get("tags", []) for i in solutions), (
        f"{notebook.name}: one answer (tagged rerun) changes the model and reruns it")


def test_quoted_numbers_are_read_with_their_unit_and_tolerance():
    jupytext = pytest.importorskip("jupytext", reason="the test extra installs jupytext")
    nb = jupytext.reads("# %% [markdown]\n# peaks at 3.7<!-- check peak rel 0.05 --> µm, drifts by\n"
                        "# 1.3e-5 J<!-- check drift abs 1e-6 -->, moves 2.1 %<!-- check lag rel 0.1 -->\n",
                        fmt="py:percent")
    assert quoted_numbers(nb) == [("peak", 3.7, "rel", 0.05), ("drift", 1.3e-5, "abs", 1e-6), ("lag", 2.1, "rel", 0.1)]


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_student_cells_hold_no_checks(notebook):
    """The code a student reads and edits teaches; the lesson's checks (its asserts, which the test above runs) are
    in cells tagged ``check``, collapsed in Jupyter and left out of the site, or in the collapsed answers."""
    import ast

    jupytext = pytest.importorskip("jupytext", reason="the test extra installs jupytext")
    nb = jupytext.read(notebook)
    found = []
    for i, cell in enumerate(nb.cells):
        tags = cell.metadata.get("tags", [])
        if cell.cell_type != "code" or "check" in tags or "solution" in tags:
            continue
        source = "\n".join("" if line.startswith(("%", "!")) else line for line in cell.source.split("\n"))
        found += [f"cell {i}, line {node.lineno}: {ast.get_source_segment(source, node)[:80]}"
                  for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Assert)]
    assert not found, f"{notebook.name}: asserts in student cells: {found}"
    for i, cell in enumerate(nb.cells):
        if "check" in cell.metadata.get("tags", []):
            assert cell.metadata.get("jupyter", {}).get("source_hidden"), f"{notebook.name}: check cell {i} not collapsed"
