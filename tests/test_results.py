"""The results file contract (reference/io/results.py), and a run that blows up keeps what it wrote."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from reference.domain import SolverSettings
from reference.elements import Section
from reference.errors import SolverDiverged
from reference.interactions import NodalLoad
from reference.io.results import Results, load_results

from conftest import cantilever

SEC = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)

CONTRACT = {
    "time": 1, "nodes/id": 1, "nodes/label": 1, "nodes/position": 3, "nodes/rotation": 3, "nodes/velocity": 3,
    "nodes/angular_velocity": 3, "constraints/violation_norm": 1, "constraints/velocity_violation_norm": 1,
    "energy/kinetic": 1, "energy/strain": 1, "energy/external_work": 1,
}


def test_results_in_memory_take_the_histories_by_their_names():
    """``Results(**arrays)``: each history under its attribute name (``Results.ARRAYS``, ``energy``); a name it
    does not know is refused with the known ones, not kept as an attribute nobody reads."""
    time, x = np.array([0.0, 1.0]), np.zeros((2, 1, 3))
    r = Results(time=time, positions=x, labels=["a"], energy={"kinetic": np.ones(2)})
    assert r.time is time and r.positions is x and r.energy["kinetic"][1] == 1.0 and r.labels == ["a"]
    with pytest.raises(TypeError, match=r"unknown histories \['position'\]; known: .*positions"):
        Results(time=time, position=x)


def test_results_file_honours_the_contract(tmp_path):
    d, nodes = cantilever(3, SEC)
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 1e-3, 0.0])))
    d.solver = SolverSettings(dt=1e-3, t_end=0.05, output_every=10)
    r = d.solve(results_path=tmp_path / "r.h5")
    with h5py.File(tmp_path / "r.h5") as f:
        for name, ndim in CONTRACT.items():
            assert f[name].ndim == ndim, name
        assert f["nodes/position"].shape == (6, 4, 3) and f["nodes/rotation"].shape == (6, 4, 4)
        for key in ("engine", "engine_version", "deck", "deck_sha256", "algorithm", "dt", "created", "flexmbs_version"):
            assert key in f.attrs, key
        assert f.attrs["dt"] == 1e-3
    back = load_results(tmp_path / "r.h5")
    assert np.array_equal(back.positions, r.positions) and back.labels == r.labels
    assert np.allclose(np.linalg.norm(back.rotations, axis=2), 1.0)


def test_blow_up_stops_with_a_message_and_keeps_the_results(tmp_path):
    """dt far above the critical step: SolverDiverged names the time and the fix; the file
    is valid up to the last output and says how the run ended."""
    d, nodes = cantilever(3, SEC)
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, 1e-3])))
    d.solver = SolverSettings(dt=2.5 * d.critical_time_step(), t_end=2000 * 2.5 * d.critical_time_step(), output_every=5)
    with pytest.raises(SolverDiverged, match="critical"):
        d.solve(results_path=tmp_path / "r.h5")
    back = load_results(tmp_path / "r.h5")
    assert back.status.startswith("diverged")
    assert len(back.time) >= 1 and np.all(np.isfinite(back.positions))


def test_writer_copies_each_record_and_flushes_in_blocks(tmp_path, monkeypatch):
    """The solution loop hands the writer the same arrays every record (overwritten in place):
    each record must be copied at append; blocks are written when they fill up (FLUSH_BYTES)."""
    from reference.io import results as res

    record_bytes = (1 + 2 * 3 + 1) * 8  # time, position (2, 3), strain
    monkeypatch.setattr(res, "FLUSH_BYTES", 3 * record_bytes)  # blocks of 4 records
    monkeypatch.setattr(res, "FLUSH_SECONDS", 1e9)
    position, strain = np.zeros((2, 3)), np.zeros(())
    writer = res.ResultsWriter(tmp_path / "r.h5", labels=["a", "b"], ids=[1, 2])
    for k in range(10):
        position[:] = k
        strain[()] = 10.0 * k
        writer.append({"time": 0.1 * k, "position": position, "strain": strain})
        assert writer.n == 4 * ((k + 1) // 4), k  # records in the file: written at every 4th
    writer.close()
    with h5py.File(tmp_path / "r.h5") as f:
        assert np.array_equal(f["time"][()], 0.1 * np.arange(10))
        assert np.array_equal(f["nodes/position"][()], np.arange(10.0)[:, None, None] * np.ones((10, 2, 3)))
        assert np.array_equal(f["energy/strain"][()], 10.0 * np.arange(10)) and f.attrs["status"] == "completed"


STALLED_WRITER = """
import sys, time
import numpy as np
from reference.io.results import ResultsWriter
writer = ResultsWriter(sys.argv[1], labels=["a"], ids=[1])
for k in range(3):  # three records within a few ms: none is written by an append
    writer.append({"time": 0.1 * k, "position": np.full((1, 3), float(k))})
print("appended", flush=True)
time.sleep(60)  # a run stalled between two outputs
"""


def test_a_stalled_writer_killed_by_sigkill_keeps_its_records(tmp_path):
    """Issue 38, item 28: the flush was driven by the next append, so the records of a run that stalled
    after them were lost to SIGKILL.  Three records appended at once, then nothing: killed 1.5 s later (more
    than FLUSH_SECONDS = 0.5 s, the age the timer thread guarantees, with margin for a loaded machine), the
    file holds all three."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    path = tmp_path / "stalled.h5"
    root = Path(__file__).resolve().parent.parent
    proc = subprocess.Popen([sys.executable, "-c", STALLED_WRITER, str(path)], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(root)})
    try:
        assert proc.stdout.readline().strip() == "appended"
        time.sleep(1.5)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    with h5py.File(path) as f:
        assert f.attrs["status"] == "running"
        assert np.array_equal(f["time"][()], [0.0, 0.1, 0.2])
        assert np.array_equal(f["nodes/position"][:, 0, 0], [0.0, 1.0, 2.0])
