"""``flexmbs run`` writes a deck's sensitivities into its results file, ``flexmbs plot --sensitivity`` draws them
(issue 40)."""

import h5py
import numpy as np

from flexmbs.cli import main

TABLE = '\n[sensitivities]\nparameters = ["loads[0].moment", "sections.rollup.EI2"]\noutputs = ["position:beam:end"]\n'


def test_run_writes_and_plot_draws_the_sensitivities(tmp_path):
    deck = tmp_path / "rollup.toml"
    deck.write_text(open("models/embedded_beam_static.toml").read() + TABLE)
    out = tmp_path / "out"
    assert main(["run", str(deck), "--out", str(out), "--no-vtk", "--backend", "reference"]) == 0
    with h5py.File(out / "results.h5") as f:
        load = np.asarray(f["sensitivities/load_factor"])
        d = np.asarray(f["sensitivities/position:beam:end/loads[0].moment"])
        assert np.array_equal(load, np.asarray(f["time"]))  # one value per load step, at the outputs
    assert d.shape == (21, 3)
    # the roll-up's Beam2 tip at k = 1 (load step 10) against the circle's (−L, −2L/π): 0.5 % L (mesh error,
    # as tests/test_sensitivity_static.py)
    assert np.max(np.abs(d[10, [0, 2]] - [-10.0, -20.0 / np.pi])) <= 5e-3 * 10.0
    assert main(["plot", str(out / "results.h5"), "--sensitivity", "position:beam:end", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "sensitivity_position_beam_end.png").stat().st_size > 0
    assert main(["plot", str(out / "results.h5"), "--sensitivity", "position:beam:start", "--out",
                 str(tmp_path)]) == 2


def test_a_sensitivity_the_run_cannot_give_is_one_line_with_status_2(tmp_path, capsys):
    """`flexmbs run` of a modes deck whose [sensitivities] ask for damped modes' derivatives: exit status 2 and
    one line (the refusal is a ParameterError, in the CLI's table of expected failures), no traceback."""
    from flexmbs.verification.sensitivities import PENDULUM

    deck = tmp_path / "damped.toml"
    deck.write_text(PENDULUM.replace("HINGE", "-0.5").replace("stiffness = 5.0", "stiffness = 5.0\ndamping = 0.1")
                    + '\n[sensitivities]\nparameters = ["springs[0].stiffness"]\n')
    assert main(["run", str(deck), "--out", str(tmp_path / "out"), "--no-vtk"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("flexmbs: error: mode sensitivities of damped") and "\n" not in err
