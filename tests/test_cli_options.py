"""Every numeric option of the command line refuses nan, inf, 0 and negatives where they mean nothing,
in one line with exit 2; ``flexmbs plot`` on a file without records and with a wrong animation name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexmbs.cli import main

ROOT = Path(__file__).resolve().parent.parent
DECK = str(ROOT / "models" / "three_bar.toml")

BAD = [
    (["run", DECK, "--t-end"], ["nan", "0", "-1", "inf", "1e999", "x"]),
    (["run", DECK, "--dt"], ["nan", "0", "-1e-4", "inf"]),
    (["run", DECK, "--refine"], ["0", "-2", "1.5", "nan", "３"]),
    (["run", DECK, "--vtk-every"], ["-1", "nan", "2.5"]),
    (["crosscheck", DECK, "--t-end"], ["nan", "0", "-1"]),
    (["crosscheck", DECK, "--exudyn-dt"], ["nan", "0", "-0.01", "inf"]),
    (["crosscheck", DECK, "--refine"], ["0", "-2"]),
    (["plot", "r.h5", "--drift", "--magnify"], ["nan", "0", "-50", "inf"]),
    (["plot", "r.h5", "--drift", "--every"], ["0", "-1", "nan"]),
    (["plot", "r.h5", "--animate"], ["a.txt", "motion", ".gif", "a.gif.png"]),
    (["view", "r.h5", "--max-frames"], ["0", "1", "-5", "nan", "2.5"]),
    (["view", "r.h5", "--out"], ["view.png", "view", ".html"]),
    (["bench", "--repeat"], ["0", "-3", "nan"]),
    (["sweep", "study.toml", "--workers"], ["0", "-1", "nan", "1000000"]),
    (["sweep", "study.toml", "--scheduler"], ["127.0.0.1", "tcp://127.0.0.1", "tcp://127.0.0.1:0", "host:x"]),
]


@pytest.mark.parametrize("argv, value", [(argv, v) for argv, values in BAD for v in values],
                         ids=lambda x: x if isinstance(x, str) else x[0] + " " + x[-1])
def test_a_meaningless_option_value_is_one_line_and_exit_2(argv, value, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main([*argv[:-1], f"{argv[-1]}={value}"])  # --opt=VALUE: argparse takes "-1e-4" for an option otherwise
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    option = argv[-1]
    assert f"argument {option}" in err and "error" in err and "e.g." in err, err
    assert not list(tmp_path.iterdir())  # refused before anything was read, run or written


def test_good_values_pass_the_validators():
    from flexmbs.cli import parser

    args = parser().parse_args(["run", DECK, "--t-end", "0.5", "--dt", "1e-4", "--refine", "2", "--vtk-every", "0"])
    assert (args.t_end, args.dt, args.refine, args.vtk_every) == (0.5, 1e-4, 2, 0)
    args = parser().parse_args(["plot", "r.h5", "--magnify", "50", "--every", "3", "--animate", "out.GIF"])
    assert (args.magnify, args.every, args.animate) == (50.0, 3, "out.GIF")
    args = parser().parse_args(["sweep", "s.toml", "--scheduler", "tcp://10.0.0.1:8786"])
    assert args.scheduler == "tcp://10.0.0.1:8786"
    assert parser().parse_args(["sweep", "s.toml", "--workers", "1"]).workers == 1


def _results_without_records(path: Path, status: str | None) -> None:
    """A results file as a SIGKILL before the first flush leaves it (status "running"), or closed empty."""
    from reference.io.deck import load_deck
    from reference.io.results import ResultsWriter

    domain = load_deck(DECK).domain
    writer = ResultsWriter(path, domain, domain.algorithm())
    if status is None:
        writer.f.close()
    else:
        writer.close(status)


@pytest.mark.parametrize("status", [None, "interrupted at t = 0"])
def test_plot_of_a_file_without_records_is_one_line_with_its_status(tmp_path, capsys, status):
    path = tmp_path / "results.h5"
    _results_without_records(path, status)
    assert main(["plot", str(path), "--drift", "--energy", "--animate", "m.gif"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "no records" in err and repr(status or "running") in err and str(path) in err


def test_a_wrong_animation_name_is_refused_before_any_frame(tmp_path, capsys, monkeypatch):
    """The issue's --animate a.txt rendered every frame, then failed; now nothing is drawn."""
    import flexmbs.plot

    drawn = []
    monkeypatch.setattr(flexmbs.plot, "configuration", lambda *a, **k: drawn.append(1) or [("x", np.zeros((1, 3)))])
    with pytest.raises(SystemExit):
        main(["plot", str(tmp_path / "r.h5"), "--animate", "a.txt"])
    assert not drawn and ".gif" in capsys.readouterr().err
