"""Blow-ups that stay finite are stopped with a message naming the likely cause, and keep the file.

The two cases of issue 12: dt = 1.01 × the critical estimate forced through the API (the deck
reader refuses it), and a 2e6 N follower load on the documented cantilever (EA = 1e3 N).  Both
ran to "completed" before, with kinetic + strain energy 5e13 against 2.4e8 of work; both must
stop before that energy is 10 × the work done."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from reference.errors import SolverDiverged
from reference.io.deck import load_deck
from reference.io.results import load_results

from test_reliability import EXAMPLE

MODELS = Path(__file__).resolve().parent.parent / "models"


def test_dt_just_above_the_critical_estimate_is_stopped_naming_the_time_step(tmp_path):
    d = load_deck(MODELS / "embedded_beam.toml").domain
    dt = 1.01 * d.critical_time_step()
    d.solver.dt, d.solver.t_end, d.solver.output_every = dt, 5000 * dt, 50
    with pytest.raises(SolverDiverged) as info:
        d.solve(results_path=tmp_path / "r.h5")
    message = str(info.value)
    assert "energy balance failed" in message and "likely cause: the time step" in message, message
    run = d.last_run
    assert run["energy"] < 10.0 * abs(run["work"]) and run["t"] < 5000 * dt, run
    back = load_results(tmp_path / "r.h5")
    assert back.status.startswith("diverged after t = ") and len(back.time) >= 1
    assert np.all(np.isfinite(back.positions))
    # the same run without the monitor: the energy ends orders of magnitude above the work
    d.solver.t_end = 1000 * dt
    r = d.solve(monitor=False)
    E = r.energy["kinetic"][-1] + r.energy["strain"][-1]
    assert r.status == "completed" and E > 1e3 * abs(r.energy["external_work"][-1])


def test_a_huge_follower_load_is_stopped_naming_the_load(tmp_path):
    path = tmp_path / "follower.toml"
    path.write_text(EXAMPLE.replace("force = [0.0, 0.0, 1e-3]", "force = [0.0, 0.0, 2e6]")
                    .replace('frame = "inertial"', 'frame = "body"').replace("t_end = 0.02 ", "t_end = 2.0 "))
    d = load_deck(path).domain
    with pytest.raises(SolverDiverged) as info:
        d.solve(results_path=tmp_path / "r.h5")
    message = str(info.value)
    assert "likely cause: the loads" in message, message
    run = d.last_run
    assert run["energy"] < 10.0 * abs(run["work"]), run
    assert load_results(tmp_path / "r.h5").status.startswith("diverged")


def test_shipped_models_keep_the_energy_balance(tmp_path):
    """No false alarm: the shipped models run through with the monitor on."""
    for deck, t_end in (("embedded_beam.toml", 0.5), ("three_bar.toml", 1.0)):
        r = load_deck(MODELS / deck, overrides={"t_end": t_end}).solve()
        assert r.status == "completed"


def test_stretch_check_names_the_most_deformed_element():
    """The monitor's compiled screen and its message: an element stretched 12 × (or collapsed, or
    not a number) is named; the worst by |log(ratio)| when several are; a sound mesh passes."""
    from reference.monitor import MAX_STRETCH, BlowUpMonitor

    d = load_deck(MODELS / "embedded_beam.toml").domain
    d.initialization()
    watch = BlowUpMonitor(d, d.solver.dt)
    x = np.array([n.position for n in d.nodes], dtype=float)
    assert watch.stretch(x) is None
    conn, L0 = d.model.elements[0].conn, d.model.elements[0].L0
    i, j = conn[3]
    y = x.copy()
    y[j:] += (1.2 * MAX_STRETCH - 1.0) * (x[j] - x[i])  # element 3 stretched 12 ×, the rest moved rigidly
    message = watch.stretch(y)
    assert message == f"element {d.elements[3].label!r} is {np.linalg.norm(y[j] - y[i]) / L0[3]:.3g} × its initial length"
    y[conn[7, 1]] = y[conn[7, 0]] + 1e-4 * (y[conn[7, 1]] - y[conn[7, 0]])  # element 7 collapsed further
    assert repr(d.elements[7].label) in watch.stretch(y)
    y[5, 0] = np.nan
    assert watch.stretch(y) is not None


def test_stretch_screens_agree():
    """The stretch screen in NumPy (the reference path's) and its compiled twin (the compiled path's) give the same
    verdict on a sound mesh, one element stretched or collapsed past its bound, just inside it, and NaN or inf."""
    from reference.monitor import MAX_STRETCH, BlowUpMonitor, within_stretch
    from reference.outputs import within_stretch_compiled

    d = load_deck(MODELS / "embedded_beam.toml").domain
    d.initialization()
    watch = BlowUpMonitor(d, d.solver.dt)
    conn, low, high = watch.conn, watch.bounds[0], watch.bounds[1]
    x = np.array([n.position for n in d.nodes], dtype=float)
    i, j = conn[3]
    cases = {"sound": x}
    for name, factor in (("stretched", 1.01 * MAX_STRETCH), ("inside", 0.99 * MAX_STRETCH),
                         ("collapsed", 0.99 / MAX_STRETCH), ("barely", 1.01 / MAX_STRETCH)):
        y = x.copy()
        y[j:] += (factor - 1.0) * (x[j] - x[i])  # element 3 scaled by factor, the rest moved rigidly
        cases[name] = y
    for name, value in (("nan", np.nan), ("inf", np.inf)):
        y = x.copy()
        y[j, 1] = value
        cases[name] = y
    verdicts = {name: (within_stretch(y, conn, low, high), bool(within_stretch_compiled(y, conn, low, high)))
                for name, y in cases.items()}
    assert all(a == b for a, b in verdicts.values()), verdicts
    assert {name for name, (a, _) in verdicts.items() if a} == {"sound", "inside", "barely"}


def test_largest_strain_twins_agree():
    """The records' largest axial strain |N| / EA in NumPy (the reference path's) and compiled (the compiled path's):
    the same value and element on finite forces, with ties (the first), NaN and inf forces (skipped), elements not
    watched (1/EA = 0, also against an infinite force), none positive, and no element at all."""
    from reference.outputs import largest_strain, largest_strain_compiled

    rng = np.random.default_rng(3)
    inverse = rng.uniform(1e-9, 1e-7, 9)
    inverse[4] = 0.0
    cases = [rng.normal(0.0, 1e5, (9, 3)) for _ in range(3)] + [np.zeros((9, 3))]
    inverse_tie = inverse.copy()
    inverse_tie[[2, 6]] = inverse.max()
    tie = cases[0].copy()
    tie[2, 0] = 3.0 * np.abs(tie[:, 0]).max()  # element 2 the largest, element 6 its exact equal
    tie[6, 0] = -tie[2, 0]
    assert largest_strain(tie, inverse_tie)[1] == 2  # the first of the two equal ones
    assert tuple(largest_strain_compiled(tie, inverse_tie)) == largest_strain(tie, inverse_tie)
    bad = cases[1].copy()
    bad[[1, 3, 4], 0] = np.nan, np.inf, np.inf
    cases.append(bad)
    for force in cases:
        expected = largest_strain(force, inverse)
        assert tuple(largest_strain_compiled(force, inverse)) == expected
    assert largest_strain(bad, inverse)[1] not in (1, 3, 4)
    assert largest_strain(np.zeros((9, 3)), inverse) == (0.0, 0)
    assert largest_strain(np.zeros((0, 3)), np.zeros(0)) == (0.0, 0) == tuple(largest_strain_compiled(np.zeros((0, 3)),
                                                                                                   np.zeros(0)))
