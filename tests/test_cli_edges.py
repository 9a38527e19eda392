"""The command line's rough edges, each fixed: version, plot without options or on a wrong file,
the animation's drawing, a refined cross-check's own files, progress timing, a warning-free install."""

from __future__ import annotations

import io
import time
import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import flexmbs
from flexmbs.cli import main
from flexmbs.plot import configuration, geometry
from flexmbs.progress import ProgressBar

ROOT = Path(__file__).resolve().parent.parent


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"flexmbs {flexmbs.__version__}"


def test_plot_without_options_says_what_it_can_plot(tmp_path, capsys):
    assert main(["plot", str(tmp_path / "results.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nothing to plot" in err
    assert all(option in err for option in ("--node", "--drift", "--energy", "--animate"))


@pytest.mark.parametrize("content", [b"not an HDF5 file\n", None])
def test_plot_of_a_non_results_file_is_one_line_naming_it(tmp_path, capsys, content):
    path = tmp_path / "deck.toml"
    if content is not None:
        path.write_bytes(content)
    assert main(["plot", str(path), "--drift"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and "Traceback" not in err


@pytest.fixture(scope="module")
def three_bar_run():
    from reference.io.deck import load_deck

    domain = load_deck(ROOT / "models" / "three_bar.toml", overrides={"t_end": 0.5}).domain
    return domain, domain.solve()


def test_animation_draws_rigid_bars_as_segments_and_magnifies_the_deflection(three_bar_run):
    domain, r = three_bar_run
    shapes = geometry(domain)
    assert set(shapes) == {"crank", "rocker"}
    i = len(r.time) - 1
    lines = dict(configuration(r, i, shapes))
    crank = lines["crank"]
    # the crank is drawn from O1 to A: its end points are 1 apart and one of them is the pivot O1 = origin
    assert len(crank) >= 2
    spans = [np.linalg.norm(a - b) for a in crank for b in crank]
    assert max(spans) == pytest.approx(1.0, abs=1e-6)
    assert min(np.linalg.norm(crank, axis=1)) < 1e-6
    coupler = lines["coupler"]
    magnified = dict(configuration(r, i, shapes, magnify=50.0))["coupler"]
    chord = coupler[0] + np.linspace(0, 1, len(coupler))[:, None] * (coupler[-1] - coupler[0])
    assert np.max(np.abs(magnified - chord)) == pytest.approx(50.0 * np.max(np.abs(coupler - chord)), rel=1e-9)
    assert np.max(np.abs(coupler - chord)) > 0.0


def test_animate_writes_a_gif_with_progress(tmp_path, three_bar_run, capsys):
    from flexmbs.plot import animate
    from reference.io.deck import load_deck
    from reference.io.results import load_results

    domain, _ = three_bar_run
    path = tmp_path / "r.h5"
    domain_again = load_deck(ROOT / "models" / "three_bar.toml", overrides={"t_end": 0.1}).domain
    domain_again.solve(results_path=path)
    stream = io.StringIO()
    out = animate(load_results(path), tmp_path / "m.gif", every=2, magnify=50.0, progress=ProgressBar("anim", stream))
    assert out.stat().st_size > 1000
    assert "100.0%" in stream.getvalue()


def test_refined_crosscheck_writes_its_own_files(monkeypatch, tmp_path):
    import crosscheck.harness

    outs = []

    def fake_run(deck, out, refine=1, **kwargs):
        outs.append((Path(out), refine))
        ref = SimpleNamespace(wall_time=0.0)
        return {"verdicts": [], "reference": ref, "exudyn_wall": 0.0, "figure": Path(out) / "f.png"}

    monkeypatch.setattr(crosscheck.harness, "run", fake_run)
    monkeypatch.chdir(tmp_path)
    deck = str(ROOT / "models" / "three_bar.toml")  # the command reads its [crosscheck] tables first
    assert main(["crosscheck", deck]) == 0
    assert main(["crosscheck", deck, "--refine", "8"]) == 0
    (plain, r1), (refined, r8) = outs
    assert (r1, r8) == (1, 8) and plain != refined and plain.name == "three_bar_crosscheck"
    assert refined.name == "three_bar_crosscheck_refine8"


def test_refined_crosscheck_figure_has_its_own_name():
    """The harness names the refined run's figure ``crosscheck_<name>_refine<R>.png`` (no stale figure)."""
    text = (ROOT / "crosscheck" / "harness.py").read_text()
    assert 'f"_refine{refine}"' in text and 'f"crosscheck_{name}.png"' in text


def test_progress_bar_times_only_its_own_run():
    """A bar made before another engine's run starts its clock at its first report, so that its
    elapsed time and the summary's solve time agree."""
    stream = io.StringIO()
    bar = ProgressBar("Exudyn", stream)
    time.sleep(0.3)
    bar(0.0, 0.0)
    bar(1.0, 1.0)
    elapsed = float(stream.getvalue().split("elapsed ")[1].split(" s")[0])
    assert elapsed < 0.2


def test_pyproject_license_is_spdx_and_extras_install_the_notebook_kernel():
    """setuptools ≥ 77 warns (three times per install) about ``license = {text = …}``; the SPDX string does not."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["license"] == "MIT"
    assert any(r.replace(" ", "").startswith("setuptools>=77") for r in meta["build-system"]["requires"])
    extras = meta["project"]["optional-dependencies"]
    for pkg in ("jupytext", "nbclient", "ipykernel"):
        assert any(r.startswith(pkg) for r in extras["test"])
    assert any(r.startswith("jupyterlab") for r in extras["notebooks"])
    makefile = (ROOT / "Makefile").read_text()
    assert "test]" in makefile and "notebooks:" in makefile


def test_drawing_follows_the_connectivity_through_a_shared_node():
    """Two beams joined at a shared node (``end_node``/``start_node``) are drawn without a gap."""
    from flexmbs.plot import chains
    from reference.io.deck import load_deck

    domain = load_deck(ROOT / "models" / "curved_cantilever.toml").domain
    beams = chains(domain)
    assert beams["arc1"][-1] == beams["arc2"][0] == "mid"
    assert len(beams["arc1"]) == len(domain.elements) // 2 + 1
