"""``flexmbs sweep``: a 2 × 2 study of the roll-up on Dask gives the numbers of the serial runs."""

from __future__ import annotations

import csv
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("dask.distributed")

from flexmbs.cli import main as cli  # noqa: E402
from flexmbs.sweep import cases, load_study, run_case, run_study  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
STUDY = f"""deck = "{(ROOT / 'models' / 'embedded_beam.toml').as_posix()}"
description = "roll-up: mesh × damping, first 0.05 s"

[grid]
refine = [1, 2]
damping = [20.0, 25.0]
t_end = [0.05]
"""


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    path = tmp_path_factory.mktemp("study") / "rollup_study.toml"
    path.write_text(STUDY)
    return load_study(path)


@pytest.fixture(scope="module")
def serial(study, tmp_path_factory):
    """The four cases run one after the other in this process."""
    out = tmp_path_factory.mktemp("serial")
    return [run_case(study.deck, case, out / f"case_{k}") for k, case in enumerate(cases(study))]


def values(row: dict) -> dict:
    return {k: float(v) for k, v in row.items() if k not in ("status", "wall_time", "results", "case")}


def read_summary(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_local_cluster_gives_the_serial_numbers(study, serial, tmp_path, capsys):
    """`flexmbs sweep STUDY --workers 2`: four rows in case order, every value equal to the serial
    run's (same compiled code on the same machine: bit for bit; the CSV keeps 17 digits), each case
    with its own results file, progress lines on the terminal."""
    assert [r["status"] for r in serial] == ["completed"] * 4
    assert cli(["sweep", str(study.path), "--out", str(tmp_path), "--workers", "2"]) == 0
    rows = read_summary(tmp_path / "summary.csv")
    assert [int(r["case"]) for r in rows] == [0, 1, 2, 3]
    for row, ref in zip(rows, serial):
        assert row["status"] == "completed"
        assert values(row) == values(ref)
        assert Path(row["results"]).is_file() and Path(row["results"]).parent.parent == tmp_path
    assert {"check.tip_vs_elastica.x", "check.tip_vs_elastica.z", "strain_final", "dissipated_final"} <= set(rows[0])
    # the grid really changes the answer: damping changes the dissipation, refine the tip
    assert float(rows[0]["dissipated_final"]) != float(rows[1]["dissipated_final"])
    assert float(rows[0]["check.tip_vs_elastica.z"]) != float(rows[2]["check.tip_vs_elastica.z"])
    err = capsys.readouterr().err
    assert "[4/4]" in err and "refine = 2, damping = 25.0" in err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_external_scheduler_gives_the_serial_numbers(study, serial, tmp_path):
    """A `dask scheduler` and a `dask worker` started here (loopback only) run the same study
    with the same numbers; both processes are stopped at the end (bounded waits)."""
    from dask.distributed import Client

    dask = str(Path(sys.executable).parent / "dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    log = open(tmp_path / "dask.log", "w")
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=log, stderr=log, env=env)]
    try:
        deadline = time.monotonic() + 30
        while True:  # wait until the scheduler listens
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline or procs[0].poll() is not None:
                    pytest.fail(f"the dask scheduler did not start: {(tmp_path / 'dask.log').read_text()[-500:]}")
                time.sleep(0.2)
        procs.append(subprocess.Popen([dask, "worker", address, "--nworkers", "1", "--nthreads", "1",
                                       "--host", "127.0.0.1", "--no-dashboard"], stdout=log, stderr=log, env=env))
        with Client(address, timeout="20s") as client:
            client.wait_for_workers(1, timeout=60)
        rows = run_study(study, tmp_path / "out", scheduler=address, progress=lambda line: None)
        for row, ref in zip(rows, serial):
            assert row["status"] == "completed"
            assert values(row) == values(ref)
        assert len(read_summary(tmp_path / "out" / "summary.csv")) == 4
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=5)
        log.close()


def test_a_failed_case_is_a_row_with_its_error(study, tmp_path):
    """A case the deck reader refuses (negative damping) is recorded, not raised."""
    row = run_case(study.deck, {"damping": -1.0, "t_end": 0.05}, tmp_path)
    assert row["status"].startswith("failed:") and "solver.damping" in row["status"]
    assert "\n" not in row["status"]


@pytest.mark.parametrize("text, message", [
    ('deck = "nowhere.toml"\n[grid]\nrefine = [1]\n', "deck: no such deck file"),
    (STUDY.replace("[grid]", "[grids]"), "grids: unknown key"),
    (STUDY.replace("refine = [1, 2]", "refine = 2"), "grid.refine: expected a non-empty list"),
    (STUDY.replace("damping = [20.0, 25.0]", "dampnig = [20.0]"), "grid.dampnig: unknown name"),
    (STUDY.replace("damping = [20.0, 25.0]", '"sections.rolup.EI2" = [100.0]'),
     "no table 'sections.rolup'; did you mean 'rollup'?"),
    (STUDY.replace("damping = [20.0, 25.0]", '"solver.damping" = ["high"]'), "is a number, the override a string"),
    ("deck = \n", "not valid TOML"),
])
def test_bad_study_files_get_one_line_errors(tmp_path, capsys, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert cli(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("flexmbs: error: ") and message in err and "\n" not in err


def test_dotted_overrides_reach_the_model():
    """A dotted override is the deck's value replaced: EI2 of the roll-up's section, the beam's
    element count, the solver's damping."""
    from reference.io.deck import load_deck

    deck = ROOT / "models" / "embedded_beam.toml"
    d = load_deck(deck, overrides={"sections.rollup.EI2": 120.0, "beams.0.elements": 6, "solver.damping": 20.0}).domain
    assert d.elements[0].formulation.section.EI2 == 120.0
    assert len(d.elements) == 6 and d.solver.damping == 20.0


def test_make_study_from_python_validates_like_a_file():
    """The Python face (for the report's convergence studies): the same cases and the same checks."""
    from flexmbs.sweep import make_study
    from reference.io.deck import DeckError

    deck = ROOT / "models" / "embedded_beam.toml"
    study = make_study(deck, {"refine": [1, 2, 4], "t_end": [0.05]})
    assert cases(study) == [{"refine": r, "t_end": 0.05} for r in (1, 2, 4)]
    with pytest.raises(DeckError, match=r"sections\.rollup\.EJ2: unknown key; did you mean 'EI2'\?"):
        make_study(deck, {"sections.rollup.EJ2": [1.0]})


def test_a_check_named_status_cannot_overwrite_the_summary_s_status(tmp_path):
    """The issue's deck check called ``status`` replaced the status column; check columns are ``check.NAME``."""
    from flexmbs.sweep import make_study, write_summary

    text = (ROOT / "models" / "embedded_beam.toml").read_text()
    deck = tmp_path / "status_check.toml"
    deck.write_text(text + '\n[checks.status]\ndescription = "the tip"\nobservable = "position:beam:end"\n'
                    'tolerance = 1.0\nreason = "a name the summary also uses"\n')
    row = run_case(deck, {"t_end": 0.01}, tmp_path / "case")
    assert row["status"] == "completed" and {"check.status.x", "check.tip_vs_elastica.z"} <= set(row)
    write_summary(tmp_path / "summary.csv", make_study(deck, {"t_end": [0.01]}), {0: row})
    (written,) = read_summary(tmp_path / "summary.csv")
    assert written["status"] == "completed" and float(written["check.status.x"]) == row["check.status.x"]


def test_ctrl_c_in_a_grid_of_ten_million_cases_keeps_the_finished_rows_in_one_line(tmp_path):
    """Ctrl-C at the terminal (SIGINT to the whole process group, workers included) once the summary
    has a row, in a study of 10⁷ cheap cases (the issue's grid: every case was submitted before Ctrl-C was
    looked at, so it was ignored, no row was written and Dask printed CRITICAL tracebacks; at 20,000 cases
    four tracebacks): the first rows come at once, and the study ends within 20 s of the Ctrl-C (the stop
    is seen within POLL = 0.05 s; the rest is closing the cluster's processes: 3.7 s of the 5.1 s measured
    on two cores at load 10) with exit 130, one line besides the progress lines, and a valid summary of
    the finished cases."""
    import signal

    from flexmbs.sweep import n_cases

    deck = (ROOT / "models" / "physical_pendulum.toml").as_posix()  # a rigid pendulum, 2 explicit steps a case
    damping = ", ".join(f"{k / 1000:.3f}" for k in range(1000))
    names = ", ".join(f'"n{k}"' for k in range(10_000))
    study = tmp_path / "huge_study.toml"
    study.write_text(f'deck = "{deck}"\n[grid]\nt_end = [0.002]\ndamping = [{damping}]\n"meta.name" = [{names}]\n')
    n = n_cases(load_study(study))
    assert n == 10**7
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-m", "flexmbs", "sweep", str(study), "--out", str(tmp_path / "out"),
                             "--workers", "1"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    summary = tmp_path / "out" / "summary.csv"
    try:
        deadline = time.monotonic() + 120
        while not (summary.exists() and len(read_summary(summary)) >= 3) and proc.poll() is None:
            assert time.monotonic() < deadline, "no case finished in 120 s"
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGINT)
        sent = time.monotonic()
        out, err = proc.communicate(timeout=60)
        stopped = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
    lines = [line for line in err.splitlines() if not line.startswith(("[", "flexmbs sweep: "))]
    assert proc.returncode == 130 and len(lines) == 1, (proc.returncode, err[-3000:])
    assert "Traceback" not in err and "CRITICAL" not in err
    assert stopped <= 20.0, stopped
    assert lines[0].startswith("flexmbs: interrupted; ") and f"of {n} cases had finished" in lines[0]
    rows = read_summary(summary)
    assert 3 <= len(rows) < n and all(r["status"] == "completed" for r in rows)
    assert f"{len(rows)} of {n}" in lines[0] and not (tmp_path / "out" / "summary.csv.part").exists()


def test_a_scheduler_address_without_port_is_one_line(study, tmp_path, capsys):
    """The issue's `--scheduler 127.0.0.1` ended in a 51-line traceback: the command refuses it in one
    line, and so does the Python face (a DeckError naming the address)."""
    from reference.io.deck import DeckError

    with pytest.raises(SystemExit) as exit_:
        cli(["sweep", str(study.path), "--scheduler", "127.0.0.1"])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and "\n" not in err and "tcp://127.0.0.1:8786" in err
    with pytest.raises(DeckError, match=r"cannot reach the Dask scheduler at 127\.0\.0\.1: missing port"):
        run_study(study, tmp_path, scheduler="127.0.0.1", progress=lambda line: None)
