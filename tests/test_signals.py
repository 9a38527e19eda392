"""Runs stopped by signals leave readable files and say so in one line (``tests/stop_runs.py``;
``make signals`` runs 20 SIGKILL and 10 SIGTERM/SIGHUP trials); a crash mid-run records "failed"."""

from __future__ import annotations

import os
import random
import signal
import sys
import time

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
    """Three Ctrl-Cs in the first 2 s (``python tests/stop_runs.py --ints 100`` for a hundred): exit
    130, no traceback, a results file only if it says "interrupted"."""
    assert stop_runs.early_interrupts(tmp_path, 3, random.Random(7)) == 0


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_stops_the_run_with_a_status_and_one_line(tmp_path, sig):
    assert stop_runs.stop_trial(tmp_path, 0, sig, 0.3)


@pytest.mark.parametrize("kind", list(stop_runs.LONG_INTERVALS))
def test_ctrl_c_stops_a_run_between_two_outputs_within_a_second(tmp_path, kind):
    """Issue 38, item 1: a compiled call looped to the next output (the error-controlled heavy top looped
    forever at dt_min), and Python's handlers only run between calls: Ctrl-C and SIGTERM were ignored.  With
    outputs 100 s (heavy top, error control) and 2,000 s (explicit) of model time apart, Ctrl-C 1 s after the
    results file appeared ends the run within 1 s of CPU time (stop_runs.PROMPT: wall time on an idle machine),
    exit 130, status "interrupted at t = …"."""
    assert "ended" in stop_runs.stop_trial(tmp_path, 0, signal.SIGINT, 1.0, long_interval=kind)


@pytest.mark.parametrize("kind", ["error_controlled", "arc_length", "modes"])
def test_sigterm_stops_every_kind_of_run_with_a_status_and_one_line(tmp_path, kind):
    """An error-controlled generalized-α run, an arc-length path and the static path of a modes run
    (issue 38): SIGTERM ends each in order (exit 143, one line, status "terminated at …")."""
    assert stop_runs.stop_trial(tmp_path, 0, signal.SIGTERM, 0.3, kind)


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


class _Releaser:
    """An object whose ``__del__`` receives a Ctrl-C, as llvmlite's do while numba loads cached kernels."""

    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # the handler runs here, inside __del__, where Python drops its exception
            pass


def test_a_ctrl_c_landing_in_a_del_is_not_lost(capsys):
    """The issue's lost Ctrl-C (3 in 109 trials): the stop raised inside a ``__del__`` is dropped by
    Python; it is not printed, and it is raised again — the signal sent anew, and at the next safe point."""
    from flexmbs import signals

    saved = {sig: signal.getsignal(sig) for sig in signals.SIGNAL_NAMES}
    hook = sys.unraisablehook
    try:
        signals.install_signal_handlers()
        with pytest.raises(KeyboardInterrupt):
            _Releaser()
            deadline = time.monotonic() + 5.0
            while time.monotonic() < deadline:  # the signal sent again ends this wait
                time.sleep(0.001)
        assert signals.STOP.signum == signal.SIGINT and not signals.STOP.lost
        with pytest.raises(KeyboardInterrupt):  # a safe point raises a stop that was recorded
            signals.check_signals()
        signals.STOP.__init__()
        signals.check_signals()  # nothing recorded: nothing raised
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        sys.unraisablehook = hook
    err = capsys.readouterr().err
    assert "Exception ignored" not in err and "Traceback" not in err, err
