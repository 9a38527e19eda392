"""`flexmbs plot RESULTS --mode K`: a mode of a results file as an animated VTKHDF file (mode_animation.py).

The results file is synthetic — written here with h5py in the layout of a file of `flexmbs run`
(copied from one: /time, /nodes/*, /energy/*, /constraints/*, /elements/*, /joints/label and the
attributes, the deck text among them) plus the linearised analysis' /modes datasets — so that the
mode shapes are arbitrary numbers, not one solver's output.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from flexmbs.cli import main
from reference.io.mode_animation import amplitude
from reference.io.vtk import Layout
from reference.rotation import EulerParameters, RotationVector

from conftest import cantilever
from test_vtk import SEC, read  # read: vtkHDFReader, step by step

ROOT = Path(__file__).resolve().parent.parent
DECK = """[meta]
name = "mode demo"
description = "a cantilever of 4 elements and a free rigid bar, for the mode animation"

[sections.s]
EA = 1e4
GA2 = 1e4
GA3 = 1e4
GJ = 1.0
EI2 = 1.0
EI3 = 1.0
rhoA = 1.0
rhoJ1 = 2e-4
rhoJ2 = 1e-4
rhoJ3 = 1e-4

[[beams]]
label = "beam"
start = [0.0, 0.0, 0.0]
end = [2.0, 0.0, 0.0]
elements = 4
section = "s"

[[beams]]
label = "bar"
start = [0.0, 1.0, 0.0]
end = [1.0, 1.0, 0.0]
elements = 1
section = "s"
rigid = true

[[clamps]]
node = "beam:start"

[solver]
algorithm = "static"
t_end = 1.0
load_steps = 1
"""
FREQUENCY = np.array([0.8, 3.2])
FRAMES = 24


def results_file(tmp_path, dataset: str = "modes", seed: int = 7) -> tuple[Path, dict]:
    """A results file holding two random mode shapes about a deformed, turned configuration."""
    from reference.io.deck import load_deck

    deck = tmp_path / "demo.toml"
    deck.write_text(DECK)
    domain = load_deck(deck).domain
    N = len(domain.nodes)
    rng = np.random.default_rng(seed)
    x0 = np.array([n.position for n in domain.nodes]) + 0.05 * rng.normal(size=(N, 3))
    q0 = np.array([EulerParameters(n.rotation) * RotationVector(0.3 * rng.normal(size=3)).to_euler_parameters()
                   for n in domain.nodes])
    q0 = np.array([q.q for q in q0])
    shape = rng.normal(size=(2, N, 6))
    path = tmp_path / "results.h5"
    with h5py.File(path, "w") as f:
        f["time"] = [0.0]
        f["nodes/id"] = np.arange(N)
        f["nodes/label"] = np.array([n.label for n in domain.nodes], dtype=h5py.string_dtype())
        f["nodes/position"], f["nodes/rotation"] = x0[None], q0[None]
        f["nodes/velocity"] = f["nodes/angular_velocity"] = np.zeros((1, N, 3))
        for name in ("kinetic", "strain", "external_work", "dissipated"):
            f[f"energy/{name}"] = [0.0]
        f["constraints/violation_norm"] = f["constraints/velocity_violation_norm"] = [0.0]
        f["joints/label"] = np.array([], dtype=h5py.string_dtype())
        f["elements/label"] = np.array([e.label for e in domain.elements], dtype=h5py.string_dtype())
        f["elements/section_force"] = f["elements/section_moment"] = np.zeros((1, len(domain.elements), 3))
        if dataset == "modes":
            f["modes/frequency"], f["modes/damping_ratio"], f["modes/shape"] = FREQUENCY, np.zeros(2), shape
        elif dataset == "buckling":
            f["buckling/load_factor"], f["buckling/shape"] = [1.5, 4.0], shape
        f.attrs.update({"engine": "flexmbs-reference", "engine_version": "0.1.0", "deck": DECK,
                        "deck_path": str(deck), "deck_sha256": "", "algorithm": "modes", "dt": 0.0,
                        "created": "2026-01-01T00:00:00+00:00", "flexmbs_version": "0.1.0", "status": "completed"})
    return path, {"domain": domain, "x0": x0, "q0": q0, "shape": shape}


def test_mode_animation_reads_back_frame_by_frame(tmp_path, capsys):
    path, data = results_file(tmp_path)
    assert main(["plot", str(path), "--mode", "2", "--out", str(tmp_path / "out")]) == 0
    file = tmp_path / "out" / "mode_demo_mode2.vtkhdf"
    assert f"wrote {file} (mode 2: 3.2 Hz" in capsys.readouterr().out
    domain, x0, q0, phi = data["domain"], data["x0"], data["q0"], data["shape"][1]
    # the amplitude, from its definition: the largest first-order point displacement φ_u + A₀(φ_θ × s) is 10 % of
    # the diagonal of the points' bounding box — beam nodes (s = 0) and the bar's centre and three named points
    bar = domain.node("bar")
    A = EulerParameters(q0[bar.id]).matrix()
    offsets = [EulerParameters(bar.rotation).matrix().T @ (p - bar.position) for p in bar.points.values()]
    points = [x0[i] for i in range(5)] + [x0[bar.id]] + [x0[bar.id] + A @ s for s in offsets]
    moved = [phi[i, :3] for i in range(5)] + [phi[bar.id, :3]] + [phi[bar.id, :3] + A @ np.cross(phi[bar.id, 3:], s)
                                                                  for s in offsets]
    size = np.linalg.norm(np.ptp(np.array(points), axis=0))
    a = 0.1 * size / max(np.linalg.norm(u) for u in moved)
    for k in (0, 3, 6, 17):
        poly, times = read(file, k)
        # one period in 24 frames; the time steps are τ/f [s]
        assert len(times) == FRAMES and times[k] == pytest.approx(k / FRAMES / FREQUENCY[1], rel=1e-12)
        s = a * np.sin(2.0 * np.pi * k / FRAMES)
        pd = poly.GetPointData()
        u = np.array([pd.GetArray("displacement").GetTuple3(p) for p in range(5)])
        # frame k moves the beam nodes by a sin(2πk/24) φ_u from the configuration linearised about (single
        # precision arrays: 1e-6 of the largest)
        assert np.max(np.abs(u - s * phi[:5, :3])) <= 1e-6 * a * np.max(np.abs(phi[:5, :3])), k
        assert np.allclose(poly.GetPoints().GetPoint(4), x0[4] + s * phi[4, :3], rtol=0, atol=1e-6)
        # the triads turn by exp(s φ_θ) in the body frame: q₀ ⊗ exp(s φ_θ), here from the reference's classes
        A_k = (EulerParameters(q0[2]) * RotationVector(s * phi[2, 3:]).to_euler_parameters()).matrix()
        assert np.allclose(pd.GetArray("triad_1").GetTuple3(2), A_k[:, 0], rtol=0, atol=1e-6)
        assert poly.GetNumberOfLines() == 4 + 3  # the beam's 4 elements and the bar's 3 axis segments


def test_buckling_shapes_are_animated_over_the_phase(tmp_path):
    path, _ = results_file(tmp_path, "buckling")
    assert main(["plot", str(path), "--mode", "1", "--out", str(tmp_path / "out")]) == 0
    _, times = read(tmp_path / "out" / "mode_demo_buckling1.vtkhdf", 0)
    assert np.allclose(times, np.arange(FRAMES) / FRAMES, rtol=0, atol=1e-15)  # no frequency: the phase τ


@pytest.mark.parametrize("dataset, k, words", [
    ("modes", 3, "--mode 3: the file has 2 modes (/modes/shape); give --mode 1 … 2"),
    (None, 1, 'the file has no mode shapes (/modes/shape or /buckling/shape); run a deck with [solver] algorithm = '
              '"modes" or "buckling" (flexmbs run DECK) and give its results.h5'),
])
def test_a_bad_mode_is_one_line_naming_the_file_and_the_fix(tmp_path, capsys, dataset, k, words):
    path, _ = results_file(tmp_path, dataset)
    assert main(["plot", str(path), "--mode", str(k), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err == f"flexmbs: error: {path}: {words}"
    assert not list((tmp_path / "out").glob("*.vtkhdf"))


def test_mode_zero_is_refused_by_the_option(tmp_path, capsys):
    path, _ = results_file(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(["plot", str(path), "--mode", "0"])
    assert stop.value.code == 2 and "'0' is not a whole number ≥ 1" in capsys.readouterr().err


def test_the_mode_animation_needs_no_matplotlib(tmp_path):
    path, _ = results_file(tmp_path)
    code = ("import sys; sys.modules['matplotlib'] = None\n"  # any import of matplotlib fails
            "from flexmbs.cli import main\n"
            f"sys.exit(main(['plot', {str(path)!r}, '--mode', '1', '--out', {str(tmp_path / 'out')!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out" / "mode_demo_mode1.vtkhdf").stat().st_size > 1000


def test_a_mode_that_moves_no_point_turns_by_the_fraction():
    d, nodes = cantilever(4, SEC)
    shape = np.zeros((5, 6))
    shape[:, 3] = np.linspace(0.0, 2.0, 5)  # torsion of a straight beam: no node moves
    q0 = np.array([n.rotation for n in d.nodes])
    assert amplitude(Layout(d), q0, shape) == pytest.approx(0.1 / 2.0, rel=1e-15)  # the largest twist 0.1 rad
    shape[4, 2] = 1e-3  # a tip displacement: 10 % of the 1 m model size
    assert amplitude(Layout(d), q0, shape) == pytest.approx(0.1 / 1e-3, rel=1e-15)
