"""The command line: run writes results and VTK; errors are one line and exit status 2."""

from __future__ import annotations

import io
import re
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from flexmbs.cli import main
from flexmbs.progress import ProgressBar

from test_deck import GOOD, write
from test_docs import FORBIDDEN

ROOT = Path(__file__).resolve().parent.parent


def test_run_writes_results_and_vtk(tmp_path, capsys):
    deck = write(tmp_path, GOOD)
    assert main(["run", str(deck), "--out", str(tmp_path / "out")]) == 0
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        assert f["time"].shape == (5,)
        assert f.attrs["status"] == "completed" and f.attrs["engine"] == "flexmbs-reference"
        assert f.attrs["deck"] == deck.read_text()
    assert (tmp_path / "out" / "vtk" / "tiny.vtkhdf").exists()
    assert "outputs to t = 0.02" in capsys.readouterr().out


def test_bad_deck_gives_one_line_and_status_2(tmp_path, capsys):
    deck = write(tmp_path, GOOD.replace("elements = 4", "elemnts = 4"))
    assert main(["run", str(deck), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("flexmbs: error:") and len(err.splitlines()) == 1
    assert "beams[0].elemnts" in err and "Traceback" not in err


def test_bad_deck_in_a_real_process_gives_one_line_and_status_2(tmp_path):
    """`python -m flexmbs run` as a user runs it: exit status 2, one stderr line, no traceback."""
    deck = write(tmp_path, GOOD.replace('node = "b:end"', 'node = "b:tip"'))
    proc = subprocess.run([sys.executable, "-m", "flexmbs", "run", str(deck), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert lines[0] == f"flexmbs: error: {deck}: loads[0].node: beam 'b' has no node 'tip'; " \
                       "use 'b:start', 'b:mid', 'b:end' or an index 0…4"
    assert not (tmp_path / "out" / "results.h5").exists()


@pytest.mark.parametrize("args, words", [
    (["run", "no/such/deck.toml"], "no/such/deck.toml: no such deck file"),
    (["run", "DECK", "--dt", "1.0"], "dt override (--dt): dt = 1 is above the critical time step"),
    (["run", "DECK", "--t-end", "0.0215"], "t_end override (--t-end)"),
])
def test_run_errors_are_one_line_with_status_2(tmp_path, capsys, args, words):
    deck = write(tmp_path, GOOD)
    args = [str(deck) if a == "DECK" else a for a in args]
    assert main(args + ["--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("flexmbs: error:") and len(err.strip().splitlines()) == 1 and words in err


def test_divergence_is_one_line_naming_the_results_file(tmp_path, capsys, monkeypatch):
    from reference.domain import Domain
    from reference.errors import SolverDiverged

    def blow_up(self, **kwargs):
        kwargs["progress"](0.5, 0.01)
        raise SolverDiverged("the solution became non-finite after t = 0.01 (step 10); "
                             "results up to that time are kept.")

    monkeypatch.setattr(Domain, "solve", blow_up)
    deck = write(tmp_path, GOOD)
    assert main(["run", str(deck), "--out", str(tmp_path / "out")]) == 1  # a failed run, not a user error
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "non-finite after t = 0.01" in err[0] and "results.h5" in err[0]


def test_missing_application_module_is_a_clear_message(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "flexmbs.bench", None)  # makes `import flexmbs.bench` fail
    assert main(["bench"]) == 2
    err = capsys.readouterr().err
    assert "`flexmbs bench` needs the module 'flexmbs.bench'" in err and len(err.strip().splitlines()) == 1


def test_derive_check_passes_when_nothing_is_stale(capsys, monkeypatch):
    """The command's path; the regeneration itself is compared byte for byte with the committed
    code once, in tests/test_generated.py (it takes ~10 s)."""
    import derivations

    monkeypatch.setattr(derivations, "stale", lambda: [])
    assert main(["derive", "--check"]) == 0
    assert "reference/generated/ is up to date" in capsys.readouterr().out


def test_derive_check_names_stale_files_and_exits_1(capsys, monkeypatch):
    import derivations

    monkeypatch.setattr(derivations, "stale", lambda: ["beam2.py", "joints.py"])
    assert main(["derive", "--check"]) == 1
    err = capsys.readouterr().err
    assert "beam2.py, joints.py" in err and "run `flexmbs derive`" in err


class _Stream(io.StringIO):
    def __init__(self, tty):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


def test_progress_bar_is_silent_off_a_terminal_except_the_final_line():
    stream = _Stream(tty=False)
    bar = ProgressBar("run", stream)
    for i in range(1, 101):
        bar(i / 100, i * 0.01)
    bar(1.0, 1.0)  # a repeated final call draws nothing more
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1 and "100.0%" in lines[0] and "t = 1" in lines[0] and "elapsed" in lines[0]


def test_progress_bar_redraws_at_most_ten_times_a_second_on_a_terminal():
    stream = _Stream(tty=True)
    bar = ProgressBar("run", stream)
    for i in range(1000):
        bar(i / 2000, i * 1e-3)  # far faster than 10 Hz: only the first call draws
    assert stream.getvalue().count("\r") == 1 and "eta --" in stream.getvalue()
    bar.close()  # a run that stopped early ends its line
    assert stream.getvalue().endswith("\n")
    bar(1.0, 1.0)
    assert stream.getvalue().count("\r") == 2 and "100.0%" in stream.getvalue()


def test_quick_report_runs_and_every_check_passes(tmp_path, capsys):
    """`flexmbs report --quick` (the reduced report) writes its Markdown and figures and exits 0
    only if every check passes."""
    assert main(["report", "--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "verification_quick.md").read_text()
    assert "**FAIL**" not in text and "checks pass" in text
    # a reviewer can trust it without the authors: commit, versions, warm times, limitations, no outside citations
    for words in ("**Commit:**", "**Date:**", "numba ", "exudyn ", "sympy ", "## Solve times",
                  "compilation", "## Limitations", "Over the whole history"):
        assert words in text, words
    assert not FORBIDDEN.search(text)  # no citation of files outside the repository
    # every table row has as many cells as its header (a "|" inside a cell would split it)
    table = []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            table.append(line.count("|"))
        elif table:
            assert set(table) == {table[0]}, table
            table = []
    # a reader's report: every section in the contents table, each link an anchor of the HTML rendering;
    # no words of a tracker the reader does not have; no critical-step margin where no step is critical
    html = (tmp_path / "verification_quick.html").read_text()
    links = re.findall(r"^- \[[^\]]+\]\(#([^)]+)\)$", text, re.M)
    sections = [line for line in text.splitlines() if line.startswith("## ") and line != "## Contents"]
    assert len(links) == len(sections) > 10
    for link in links:
        assert f'id="{link}"' in html and f'href="#{link}"' in html, link
    assert not re.search(r"\bissue\b|acceptance", text, re.I)
    implicit = [section.split("\n\n![")[0] for section in text.split("\n## ")[1:]
                if "`generalized_alpha`, h =" in section or "`static`, h =" in section]
    assert implicit and not any("margin" in data for data in implicit)
    assert "`staggered_central_difference`, h =" in text and "margin" in text  # the explicit decks keep it
    for fig in ("rollup_fig12.png", "three_bar_fig14.png", "rollup_convergence.png", "rollup_history.png",
                "embedded_beam_sketch.png", "three_bar_sketch.png"):
        assert (tmp_path / "figures" / fig).stat().st_size > 10_000
    # every deck's section links its interactive view (views/NAME.html); the HTML report draws each in place
    # and carries the viewer's script once
    # a deck with a reduced beam is in the section "Reduced bodies", not a deck section of its own
    decks = sorted(p.stem for p in (ROOT / "models").glob("*.toml") if "reduce = " not in p.read_text(encoding="utf-8"))
    assert sorted(re.findall(r"^\[Interactive 3D view of [^\]]+\]\(views/(\w+)\.html\)", text, re.M)) == decks
    assert sorted(p.stem for p in (tmp_path / "views").glob("*.html")) == decks
    assert html.count('<div class="flexmbs-view">') == len(decks) and html.count('"use strict"') == 1


def test_plot_writes_histories_drift_energy_and_animation(tmp_path, capsys):
    deck = write(tmp_path, GOOD)
    assert main(["run", str(deck), "--out", str(tmp_path / "run"), "--no-vtk"]) == 0
    results = tmp_path / "run" / "results.h5"
    assert main(["plot", str(results), "--node", "b:4", "--drift", "--energy", "--animate", "motion.gif",
                 "--out", str(tmp_path / "fig")]) == 0
    for name in ("node_b_4.png", "drift.png", "energy.png", "motion.gif"):
        assert (tmp_path / "fig" / name).stat().st_size > 1000, name
    assert main(["plot", str(results), "--node", "nope"]) == 2
    assert "no node 'nope'" in capsys.readouterr().err


def test_report_header_is_not_made_dirty_by_a_previous_report(tmp_path, monkeypatch):
    """The report's own outputs are tracked (reports/): rewriting them must not mark the next report
    *dirty*; a change to any other tracked file must."""
    from flexmbs import report

    def git(*args):
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path, check=True,
                       capture_output=True)

    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "verification.md").write_text("old\n")
    (tmp_path / "model.toml").write_text("a = 1\n")
    git("init", "-q")
    git("add", ".")
    git("commit", "-qm", "x")
    monkeypatch.setattr(report, "ROOT", tmp_path)
    (tmp_path / "reports" / "verification.md").write_text("new\n")
    assert "dirty" not in "\n".join(report.provenance_header(False))
    (tmp_path / "model.toml").write_text("a = 2\n")
    assert "dirty" in "\n".join(report.provenance_header(False))
