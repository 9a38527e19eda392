"""The linearised analyses' answers and diagnoses in the user's cases of issue 38: buckling under a constant
load (items 6, 19), modes about a reference state that is not an equilibrium or moves (item 18), Campbell and
modes labels of round-off damping (item 9), an exact zero pivot in compiled code (item 16), and the user
errors found only once the configuration is known (item 22)."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from flexmbs.campbell import Campbell
from flexmbs.cli import main
from reference.algorithms import SolverSettings
from reference.domain import Domain
from reference.elements import Section
from reference.interactions import Gravity, NodalLoad, Ramp
from reference.io.deck import DeckError, load_deck
from reference.io.results import load_results
from reference.modal import UNSTABLE_DAMPING
from reference.errors import SolverDiverged
from reference.validation import ModelWarning

from conftest import cantilever
from test_modes import BASE, SLENDER

MODELS = Path(__file__).resolve().parent.parent / "models"


def deck(extra: str, solver: str, elements: int = 4) -> str:
    """test_modes.py's clamped beam of length 1 along x (EI = 1, EA = GA = 1e4) with ``extra`` tables and the
    ``[solver]`` lines ``solver``."""
    return BASE.replace("elements = 4", f"elements = {elements}").replace("[solver]\n", extra + "[solver]\n") + solver


LOAD = """
[[loads]]
node = "b:end"
force = [-1.0, 0.0, 0.0]
frame = "inertial"
"""
BUCKLING = """algorithm = "buckling"
modes = 2
t_end = 1.0
load_steps = 1
"""


def constant_load_column(n: int, ramp: bool = False) -> Domain:
    d, nodes = cantilever(n, SLENDER)
    ramped = {"time_function": Ramp(0.0, 1.0, 0.0, 1.0)} if ramp else {}
    d.add_interaction(NodalLoad(nodes[-1], (-1.0, 0.0, 0.0), **ramped))
    d.solver = SolverSettings(algorithm="buckling", modes=2, t_end=1.0, load_steps=1, dt=1.0)
    return d


def test_a_constant_load_is_the_reference_load_of_buckling(tmp_path, capsys):
    """Item 6 (and 19, its round-off factors): a clamped column under a constant unit dead load, written as a
    user writes it (no time function), buckles at the Euler load π² EI/(4 L²): within Beam2's mesh error, too
    high by (kh)²/6 = 1.6e-3 at 16 elements (k = π/2L; test_modes.py measures it at second order), checked to
    5 % of that error; and equal to the same column under a load ramped from 0 at t = 0 (the increment), to
    1e-9 (the two ways reach the same two equilibria to the Newton tolerance, 1e-10)."""
    r = constant_load_column(16).solve()
    mu = r.data("buckling/load_factor")
    assert str(np.asarray(r.data("buckling/reference"))) == "loads"
    assert mu[0] / (np.pi**2 / 4) - 1 == pytest.approx((np.pi / 2 / 16) ** 2 / 6, rel=0.05)
    ramped = constant_load_column(16, ramp=True).solve()
    assert str(np.asarray(ramped.data("buckling/reference"))) == "increment"
    assert mu == pytest.approx(ramped.data("buckling/load_factor"), rel=1e-9)
    # the deck the user wrote: the table says which loads the factor multiplies; the same factor as with the
    # load ramped from 0 (1e-9, as above)
    path = tmp_path / "column.toml"
    path.write_text(deck(LOAD, BUCKLING), encoding="utf-8")
    assert main(["modes", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 0
    out = capsys.readouterr().out
    assert "load factor 1: the loads at t = 1 (the whole loads: they do not change from t = 0); 2 positive " \
           "factors found" in out, out
    ramp = '[time_functions.ramp]\nkind = "ramp"\nt0 = 0.0\nt1 = 1.0\n'
    path.write_text(deck(LOAD + 'time_function = "ramp"\n' + ramp, BUCKLING), encoding="utf-8")
    expected = load_deck(path).domain.solve().data("buckling/load_factor")
    assert load_results(tmp_path / "out" / "results.h5").data("buckling/load_factor") == pytest.approx(expected,
                                                                                                      rel=1e-9)


def test_buckling_with_nothing_to_load_the_structure_is_refused(tmp_path, capsys):
    """Item 6: no load at all is the reader's one line (exit 2); loads that are zero at t = 0 and at t_end
    (a time function that is zero there) a one-line run-time refusal with its status, not a table of round-off
    or of no factors."""
    path = tmp_path / "bare.toml"
    path.write_text(deck("", BUCKLING), encoding="utf-8")
    with pytest.raises(DeckError) as info:
        load_deck(path)
    text = str(info.value)
    assert "\n" not in text and "solver.algorithm: 'buckling' cannot run this model: the model has no load, gravity, " \
                                "actuator or drive" in text, text
    path = tmp_path / "zero.toml"
    pulse = '[time_functions.pulse]\nkind = "piecewise_linear"\ntimes = [0.0, 0.5, 1.0]\nvalues = [0.0, 1.0, 0.0]\n'
    path.write_text(deck(LOAD + 'time_function = "pulse"\n' + pulse, BUCKLING), encoding="utf-8")
    assert main(["modes", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]  # not the progress bar
    assert len(err) == 1 and "nothing loads the structure" in err[0] and "ValueError" not in err[0], err
    status = load_results(tmp_path / "out" / "results.h5").status
    assert status.startswith("failed: buckling refused: no load at t_end"), status


def test_more_modes_than_independent_coordinates_stops_before_the_static_path(tmp_path, capsys):
    """Item 22: a cantilever of 2 elements (12 free coordinates) pinned at its tip by a spherical joint (3
    constraints: 9 independent coordinates) asked for 10 modes about the static equilibrium of a 50-step path:
    one line, found at t = 0 before any load step (the status's time), not a ValueError after the path."""
    text = deck(LOAD + '[[joints]]\nkind = "spherical"\nbody_i = "b:end"\npoint = [1.0, 0.0, 0.0]\n',
                'algorithm = "modes"\nmodes = 10\nabout = "static"\nt_end = 1.0\nload_steps = 50\n', elements=2)
    path = tmp_path / "deck.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["modes", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "10 modes asked of a model with 9 independent coordinates (12 free less 3 independent " \
                             "constraints) at t = 0; ask at most 9" in err[0] and "ValueError" not in err[0], err
    r = load_results(tmp_path / "out" / "results.h5")
    assert r.status.startswith("failed: modes refused: 10 modes asked") and r.time[-1] == 0.0


def test_buckling_about_a_reference_state_that_is_not_stable_is_a_one_line_refusal():
    """Item 22: a column already at 1.5 times its Euler load at t = 0 (a constant load), with a small load
    increment to t_end: its reference tangent is indefinite, which the buckling analysis cannot take; one line
    that names the causes and the fixes, and a status, instead of "the run failed: ValueError"."""
    d, nodes = cantilever(4, SLENDER)
    d.add_interaction(NodalLoad(nodes[-1], (-1.5 * np.pi**2 / 4, 0.0, 0.0)))
    d.add_interaction(NodalLoad(nodes[-1], (-0.1, 0.0, 0.0), time_function=Ramp(0.0, 1.0, 0.0, 1.0)))
    d.solver = SolverSettings(algorithm="buckling", modes=1, t_end=1.0, load_steps=1, dt=1.0)
    with pytest.warns(ModelWarning, match="the equilibrium at load factor 0 is unstable"):
        with pytest.raises(SolverDiverged) as info:
            d.solve()
    text = str(info.value)
    assert "\n" not in text and "not positive definite: a mechanism, an unconstrained body, or loads at t = 0 " \
                               "already beyond a buckling load" in text, text
    assert d.last_run["status"].startswith("failed: buckling refused: the tangent of the reference state")


def test_modes_about_a_reference_that_is_no_equilibrium_or_moves_warn_in_one_line():
    """Item 18: a cantilever under twice its buckling load, a horizontal pendulum under gravity and a spinning
    free beam each give one warning saying what the modes leave out; the hanging pendulum, an equilibrium of
    gravity at rest, gives none."""
    d, nodes = cantilever(4, SLENDER)
    d.add_interaction(NodalLoad(nodes[-1], (-2 * np.pi**2 / 4, 0.0, 0.0)))
    d.solver = SolverSettings(algorithm="modes", modes=2)
    with pytest.warns(ModelWarning, match=r"not an equilibrium of the loads at t = 0 .* about = \"static\"") as seen:
        d.solve()
    assert len(seen) == 1 and "\n" not in str(seen[0].message)

    bar = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01, rhoJ3=0.01)
    for direction, warned in (((1.0, 0.0, 0.0), True), ((0.0, 0.0, -1.0), False)):
        d = Domain("pendulum")
        rod = d.add_rigid_bar("rod", (0, 0, 0), direction, bar)
        d.add_joint("revolute", rod, None, (0, 0, 0), axis=(0, 1, 0))
        d.add_interaction(Gravity((0.0, 0.0, -9.81)))
        d.solver = SolverSettings(algorithm="modes", modes=1)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            d.solve()
        lines = [str(w.message) for w in seen if issubclass(w.category, ModelWarning)]
        assert len(lines) == int(warned) and all("not an equilibrium of the loads" in s for s in lines), lines


def test_modes_about_a_spinning_reference_warn(tmp_path):
    """Item 18: spin initial velocities are not a steady rotation: one warning that points to about = "rotation"."""
    path = tmp_path / "deck.toml"
    path.write_text(deck('[[initial_velocities]]\nnode = "b:end"\nangular_velocity = [6.0, 0.0, 0.0]\n',
                         'algorithm = "modes"\nmodes = 2\n'), encoding="utf-8")
    with pytest.warns(ModelWarning, match=r"it moves \(initial velocities up to 6\).*about = \"rotation\""):
        load_deck(path).domain.solve()


def test_round_off_damping_is_not_unstable_in_the_gallerys_rotating_cantilever():
    """Item 9: the gallery's spinning cantilever (gyroscopic, no damping) has imaginary roots; the solver leaves
    real parts of round-off on them, which must not be labelled unstable (threshold UNSTABLE_DAMPING relative
    to the root), and the Campbell line says so without contradicting itself."""
    r = load_deck(MODELS / "rotating_cantilever.toml").domain.solve()
    zeta = r.data("modes/damping_ratio")
    assert np.all(np.abs(zeta) < UNSTABLE_DAMPING), zeta
    assert list(r.data("modes/kind")) == ["elastic"] * 4
    table = Campbell(np.array([0.0, 6.0]), np.array([[1.0, 2.0], [1.1, 2.1]]), np.array([[1e-12, -1e-12], [0.0, -2e-12]]),
                     np.array([["elastic"] * 2] * 2), None).table()
    assert table[-1] == ("largest |damping ratio| 2e-12 (below 1e-06: undamped, imaginary roots); unstable modes "
                         "(damping ratio below -1e-06): 0")


def test_an_exact_zero_pivot_is_a_singular_matrix_in_compiled_code(tmp_path, capsys):
    """Item 16: the gallery's Andrews squeezer solved by the static algorithm meets an exact zero pivot at
    t = 0 (a mechanism without stiffness, the loads at rest): the compiled run says what the plain-Python one
    says, the Newton matrix became singular, not ZeroDivisionError."""
    text = (MODELS / "andrews_squeezer.toml").read_text(encoding="utf-8")
    solver = re.search(r"\[solver\]\n(?:[^\[\n].*\n)*", text).group(0)
    path = tmp_path / "andrews_static.toml"
    path.write_text(text.replace(solver, '[solver]\nalgorithm = "static"\nt_end = 0.03\nload_steps = 1\n'),
                    encoding="utf-8")
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--no-vtk"]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "the Newton matrix became singular at load factor 0" in err[0], err
    assert load_results(tmp_path / "out" / "results.h5").status == "singular tangent at load factor 0"
