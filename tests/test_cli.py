"""The command line: run writes results and VTK; errors are one line and exit status 2."""

from __future__ import annotations

import h5py

from flexmbs.cli import main

from test_deck import GOOD, write


def test_run_writes_results_and_vtk(tmp_path, capsys):
    deck = write(tmp_path, GOOD)
    assert main(["run", str(deck), "--out", str(tmp_path / "out")]) == 0
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        assert f["time"].shape == (5,)
        assert f.attrs["status"] == "completed" and f.attrs["engine"] == "flexmbs-reference"
        assert f.attrs["deck"] == deck.read_text()
    assert (tmp_path / "out" / "vtk" / "tiny.pvd").exists()
    assert "outputs to t = 0.02" in capsys.readouterr().out


def test_bad_deck_gives_one_line_and_status_2(tmp_path, capsys):
    deck = write(tmp_path, GOOD.replace("elements = 4", "elemnts = 4"))
    assert main(["run", str(deck), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("flexmbs: error:") and len(err.splitlines()) == 1
    assert "beams[0].elemnts" in err and "Traceback" not in err


def test_derive_check_passes_on_the_committed_code(capsys):
    assert main(["derive", "--check"]) == 0


def test_quick_report_runs_and_every_check_passes(tmp_path, capsys):
    """`flexmbs report --quick` (the reduced report) writes its Markdown and figures and exits 0
    only if every check passes."""
    assert main(["report", "--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "verification_quick.md").read_text()
    assert "**FAIL**" not in text and "checks pass" in text
    for fig in ("rollup_fig12.png", "three_bar_fig14.png", "rollup_convergence.png"):
        assert (tmp_path / "figures" / fig).stat().st_size > 10_000


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
