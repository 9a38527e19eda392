"""Runs stopped by signals leave readable files and say so in one line (``tests/stop_runs.py``;
``make signals`` runs 20 SIGKILL and 10 SIGTERM/SIGHUP trials); a crash mid-run records "failed"."""

from __future__ import annotations

import random
import signal

import h5py
import numpy as np
import pytest

import stop_runs
from reference.domain import SolverSettings
from reference.elements import Section
from reference.interactions import NodalLoad

from conftest import cantilever

SEC = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)


def test_sigkill_at_random_moments_leaves_no_file_or_a_readable_one(tmp_path):
    rng = random.Random(20261123)
    left = [stop_runs.kill_trial(tmp_path, 0, rng.uniform(0.0, 0.5), running=False)]
    left += [stop_runs.kill_trial(tmp_path, k, rng.uniform(0.0, 1.0), running=True) for k in (1, 2)]
    assert all(s == "no file" or s.startswith("running") for s in left), left
    assert any(s.startswith("running") for s in left[1:]), left  # the run was killed while writing


def test_ctrl_c_during_start_up_is_quiet(tmp_path):
    assert stop_runs.early_interrupt_trial(tmp_path, 0, random.Random(7).uniform(0.0, 1.5))


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_stops_the_run_with_a_status_and_one_line(tmp_path, sig):
    assert stop_runs.stop_trial(tmp_path, 0, sig, 0.3)


def test_an_exception_during_the_run_records_failed(tmp_path, monkeypatch):
    """The crash of the issue (dt = 1e-300, t_end = 1e-299, which the deck refuses) forced through
    the API, and an exception thrown from inside the loop: the file says "failed: …", never "completed"."""
    d, nodes = cantilever(2, SEC)
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, 1e-3])))
    d.solver = SolverSettings(dt=1e-300, t_end=1e-299, output_every=1)
    try:
        r = d.solve(results_path=tmp_path / "tiny.h5")
        status = r.status
    except Exception:
        status = h5py.File(tmp_path / "tiny.h5").attrs["status"]
    assert status == "completed" and len(r.time) == 11 or status.startswith("failed: ")

    def broken_progress(fraction, t):
        if fraction > 0.5:
            raise ZeroDivisionError("float division by zero")

    d.solver = SolverSettings(dt=1e-3, t_end=0.05, output_every=5)
    with pytest.raises(ZeroDivisionError):
        d.solve(results_path=tmp_path / "r.h5", progress=broken_progress)
    with h5py.File(tmp_path / "r.h5") as f:
        assert f.attrs["status"] == "failed: ZeroDivisionError: float division by zero"
        assert f["time"].shape[0] >= 5
    assert d.last_run["status"].startswith("failed")
