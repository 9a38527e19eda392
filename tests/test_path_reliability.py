"""Equilibrium paths that went silently wrong, and their diagnoses (issue 38, items 4, 7, 8, 17, 20–22, 24):
a driven crank solved in one load step at the wrong root of its drive equation, displacement control across a
snap-back, load control across a limit point, an arc length with no load to scale, a branch switch at a double
bifurcation or at none, and the lines that say why a path ended or failed."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import reference.algorithms.path_checks as path_checks
import reference.algorithms.static as static
from reference.algorithms import SolverSettings
from reference.domain import Domain
from reference.elements import Section
from reference.errors import SolverDiverged
from reference.interactions import Clamp, NodalLoad, Ramp
from reference.io.deck import DeckError, load_deck
from reference.validation import ModelWarning
from conftest import LEE_FRAME_BEAM2
from test_arc_length import truss, truss_limit
from test_prescribed_displacement import DECK

MODELS = Path(__file__).resolve().parents[1] / "models"
ROD = 2.0 * np.sqrt(2.0)
"""The slider-crank's rod length [m] (crank 1, the slider on the x axis at t = 0)."""
COLUMN = Section(EA=1e7, GA2=1e7, GA3=1e7, GJ=0.8, EI2=1.0, EI3=4.0, rhoA=1.0, rhoJ1=2e-6, rhoJ2=1e-8, rhoJ3=4e-8)
"""Lesson 11's Euler column (notebooks/11_equilibrium_paths.py): P_cr = π² EI2 / 4 for length 1."""


def solve(d, **kw):
    """``(results or the SolverDiverged, the ModelWarning lines)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = d.solve(**kw)
        except SolverDiverged as exc:
            result = exc
    return result, [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]


def slider_crank(angle: float, steps: int) -> Domain:
    """A flexible slider-crank (crank and rod of two Beam2 elements each, a rigid slider on a translational
    joint along x), its crank turned by a rotation drive from 0 to ``angle`` [rad] over the load factor 0…1 in
    ``steps`` static load steps; no load."""
    sec = Section(EA=1e6, GA2=1e6, GA3=1e6, GJ=1e3, EI2=1e3, EI3=1e3, rhoA=1.0, rhoJ1=2e-3, rhoJ2=1e-3, rhoJ3=1e-3)
    d = Domain("flexible slider-crank")
    crank = d.add_beam("crank", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 2, sec, axis2=(1.0, 0.0, 0.0))
    rod = d.add_beam("rod", (0.0, 1.0, 0.0), (ROD, 0.0, 0.0), 2, sec, axis2=(0.0, 0.0, 1.0))
    slider = d.add_rigid_body("slider", 1.0, (0.01, 0.01, 0.01), (ROD, 0.0, 0.0))
    z = (0.0, 0.0, 1.0)
    d.add_joint("revolute", crank[0], None, (0.0, 0.0, 0.0), axis=z, label="O")
    d.add_joint("rotation_drive", crank[0], None, (0.0, 0.0, 0.0), axis=z, time_function=Ramp(0.0, 1.0, 0.0, angle),
                label="drive")
    d.add_joint("revolute", rod[0], crank[-1], (0.0, 1.0, 0.0), axis=z, label="A")
    d.add_joint("spherical", slider, rod[-1], (ROD, 0.0, 0.0), label="B")
    d.add_joint("translational", slider, None, (ROD, 0.0, 0.0), axis=(1.0, 0.0, 0.0), label="slide")
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=steps, dt=1.0 / steps)
    return d


def crank_angle(r) -> float:
    """The crank's angle from +y about z [rad], in (−π, π]."""
    tip = r.position("crank:end")[-1]
    return float(np.arctan2(-tip[0], tip[1]))


def test_driven_crank_in_one_load_step_ends_at_its_angle(monkeypatch):
    """Item 4: the crank driven to θ = 148.5 rad in a single static load step ends at θ mod 2π (to 1e-8 rad:
    the crank carries no load and Newton's tolerance is 1e-10), not π away at the drive equation's other
    root sin(θ − θ(t)) = 0 (0.845 rad: the equilibrium accepted before, reproduced here with the check off);
    the step is refused there and cut until the drive turns by less than π/2 per step."""
    target = (148.5 + np.pi) % (2.0 * np.pi) - np.pi
    r, lines = solve(slider_crank(148.5, 1))
    assert r.status == "completed" and not lines
    print(f"crank at {crank_angle(r):.12f} rad, θ(t) mod 2π = {target:.12f}")
    assert abs(crank_angle(r) - target) < 1e-8
    monkeypatch.setattr(path_checks, "drive_alignment", lambda *args: [])
    wrong, _ = solve(slider_crank(148.5, 1))
    assert abs(abs(crank_angle(wrong) - target) - np.pi) < 1e-8  # the silent answer this test guards against


def lesson_truss(**solver) -> Domain:
    """Lesson 11's von Mises truss: the apex load P_max × the load factor (the limit point at load factor 1)."""
    d = truss(load=False, **solver)
    d.add_interaction(NodalLoad(d.node("left:1"), (0.0, 0.0, -truss_limit()),
                                time_function=Ramp(0.0, 10.0, 0.0, 10.0)))
    return d


def test_load_control_across_a_limit_point_says_so():
    """Item 8: lesson 11's truss loaded in steps of 0.15 to 1.5 × its limit load by the static algorithm with
    Newton's default 25 iterations converges beyond the limit point on the mirrored, stable branch (the apex
    jumps from h > 0 to h < −H; the stability count sees no change).  The step's displacement per unit load
    exceeds RATIO times the last's, the interval is traced by arc length, and one line says that a limit
    point was passed, where, and what to use; /stability records it (kind "limit point", its load factor
    within 1e-3 of the closed form: a parabola through the three traced points about the maximum, arcs of an
    eighth of the step's chord; measured 3e-5)."""
    r, lines = solve(lesson_truss(algorithm="static", t_end=1.5, load_steps=10, dt=0.15))
    apex = r.position("left:1")[:, 2]
    assert r.status == "completed" and apex[-1] < -0.1 < 0.0 < apex[6]
    assert len(lines) == 1 and "passed a limit point at load factor" in lines[0] and "arc_length" in lines[0], lines
    print(lines[0])
    assert list(r.data("stability/critical_kind")) == ["limit point"]
    assert r.data("stability/critical_load_factor")[0] == pytest.approx(1.0, abs=1e-3)


def test_an_imperfect_column_just_past_its_critical_load_is_not_a_limit_point(monkeypatch):
    """Item 8's trap: lesson 11's column (8 elements) with a sideways tip force of 1e-3 P loaded in steps of 0.05
    to 1.2 P_cr: its deflection grows 11-fold from the step before P_cr to the step after (the ratio test
    fires, the interval is traced), but the path rises through P_cr (a stable symmetric bifurcation made
    smooth): no line, no /stability event."""
    traced = []
    trace = static.limit_point_trace
    monkeypatch.setattr(static, "limit_point_trace", lambda *args: traced.append(args[-2:]) or trace(*args))
    d = Domain("column")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 8, COLUMN)
    d.add_interaction(Clamp(nodes[0]))
    p_cr = np.pi**2 / 4.0
    d.add_interaction(NodalLoad(nodes[-1], (-p_cr, 0.0, 1e-3 * p_cr), time_function=Ramp(0.0, 10.0, 0.0, 10.0)))
    d.solver = SolverSettings(algorithm="static", t_end=1.2, load_steps=24, dt=0.05)
    r, lines = solve(d)
    print("traced", traced)
    assert r.status == "completed" and traced and not lines
    assert not len(r.data("stability/critical_load_factor"))
    assert np.all(np.diff(r.position("beam:end")[:, 2]) > 0.0)


def lee_pushed(steps: int) -> Domain:
    """Lee's frame (models/lee_frame.toml) without its load, the load point pushed down 80 by a
    [[prescribed_displacements]] over the load factor 0…1 in ``steps`` static load steps."""
    text = (MODELS / "lee_frame.toml").read_text()
    text = text[:text.index("[[loads]]")] + f"""
[time_functions.push]
kind = "ramp"
t0 = 0.0
t1 = 1.0
v0 = 0.0
v1 = 80.0

[[prescribed_displacements]]
label = "push"
node = "load"
direction = [0.0, 0.0, -1.0]
time_function = "push"

[solver]
algorithm = "static"
t_end = 1.0
load_steps = {steps}
"""
    return text


def test_lee_frame_pushed_past_the_snap_back_stops_there(tmp_path):
    """Item 7: Lee's frame pushed down by static steps converged past the snap-back with its reaction jumping
    from P L²/EI ≈ +12 to ≈ −9 in one step, `completed` (the issue's 160 steps; with this engine's Newton the
    160-step run stops at the snap-back instead, and 40, 100 and 120 steps jump: +14.84 to −9.11 at 40).  Now
    the step whose reaction falls by more than JUMP (half) of its largest magnitude is refused and cut; the
    cuts cannot pass the snap-back, so the run stops there with a line that names the jump and sends to the
    arc length; the kept path has no jump.  The 160-step run's message no longer recommends the
    [[prescribed_displacements]] the deck already has."""
    from reference.io.results import load_results

    for steps in (40, 160):
        deck = tmp_path / f"lee_pushed_{steps}.toml"
        deck.write_text(lee_pushed(steps))
        d = load_deck(deck, overrides=LEE_FRAME_BEAM2).domain  # the mesh the jumps above were measured on
        r, lines = solve(d, results_path=tmp_path / f"results_{steps}.h5")
        assert isinstance(r, SolverDiverged), r.status
        message = str(r)
        print(steps, "steps:", message)
        assert "arc_length" in message and "prescribed_displacements" not in message
        kept = load_results(tmp_path / f"results_{steps}.h5")
        reaction = kept.data("joints/prescribed_reaction", kept.joint_index("push"))
        peak = np.max(np.abs(reaction))
        assert peak * 120.0**2 / 1440.0 > 18.0  # through the first limit point (P L²/EI = 18.5)
        assert np.all(-np.diff(reaction) * np.sign(reaction[:-1]) <= path_checks.JUMP * peak)
        if steps == 40:
            assert "jumps from" in message and kept.status.startswith("step refused at load factor")


def test_lee_frame_under_displacement_control_stops_at_the_snap_back():
    """Item 7, the arc-length run under ``control = "position.z:load"`` (steps of 0.01 × the size): it used to
    jump the snap-back, from load factor 1.296 to −0.918, and report a limit point at −0.933 that it never
    traced; now the point whose load factor falls by more
    than JUMP of its largest magnitude is refused, the step cut, and the run stops at the snap-back with a line
    naming it and the fix (the jump's, or the corrector's failure at the turning point); no critical point is
    reported beyond the traced path."""
    d = load_deck(MODELS / "lee_frame.toml", overrides=LEE_FRAME_BEAM2).domain  # the mesh the jump was measured on
    d.solver.control = (d.node("load").id, 2, "position.z:load")
    d.solver.arc_length = 0.01
    r, lines = solve(d)
    print(r)
    assert isinstance(r, SolverDiverged) and "snap-back" in str(r) and "remove `control`" in str(r).lower()
    # the first limit point (P L²/EI = 18.56) only: no "stability regained" at a load factor never traced
    assert len(lines) == 1 and "stability lost" in lines[0] and "(critical load factor 1.85" in lines[0], lines


def test_arc_length_with_nothing_to_scale(tmp_path):
    """Item 17: an arc length with no load (or only a prescribed displacement) ran 15 identical points to
    λ = 5.1; now it stops at once with the reason in one line and the fix."""
    for d in (truss(load=False, algorithm="arc_length", arc_length=0.1, max_points=15, max_load_factor=5.0),
              lesson_truss(algorithm="arc_length", arc_length=0.1, max_points=15, max_load_factor=5.0, t_end=0.0)):
        r, _ = solve(d)
        assert isinstance(r, SolverDiverged) and "they are zero" in str(r) and "\n" not in str(r)
        assert d.last_run["status"] == "failed: no load to scale"
    deck = tmp_path / "pushed.toml"
    deck.write_text(DECK.replace('solver = { algorithm = "static", t_end = 1.0, load_steps = 3 }',
                                 'solver = { algorithm = "arc_length", arc_length = 0.1, max_points = 15, '
                                 'max_load_factor = 5.0 }'))
    d = load_deck(deck).domain
    r, _ = solve(d)
    assert isinstance(r, SolverDiverged) and "prescribed displacement alone, use algorithm = \"static\"" in str(r)


def test_branch_switch_at_a_double_bifurcation_and_at_none():
    """Item 20: a column with equal bending stiffnesses (EI2 = EI3) bifurcates into two modes at once; the switch
    would follow an arbitrary one of them.  One line says so, and the path goes on along the primary branch
    (two negative eigenvalues past P_cr).  A path without a bifurcation (the truss's limit points) says that
    nothing was switched."""
    d = Domain("round column")
    equal = Section(EA=1e7, GA2=1e7, GA3=1e7, GJ=0.8, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-6, rhoJ2=1e-8, rhoJ3=1e-8)
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 4, equal)
    d.add_interaction(Clamp(nodes[0]))
    d.add_interaction(NodalLoad(nodes[-1], (-np.pi**2 / 4.0, 0.0, 0.0)))
    d.solver = SolverSettings(algorithm="arc_length", arc_length=0.1, max_points=6, max_load_factor=1.5,
                              branch_switch=True)
    r, lines = solve(d)
    assert r.status == "completed", r
    assert any("2 critical modes at once" in line for line in lines), lines
    assert list(r.data("path/critical_kind")) == ["bifurcation"] and r.data("path/negative_eigenvalues")[-1] == 2
    assert np.all(r.position("beam:end")[:, 1:] == 0.0)  # the primary branch: straight
    r, lines = solve(truss(algorithm="arc_length", arc_length=0.05, max_points=5, max_load_factor=5.0,
                           branch_switch=True))
    assert r.status == "completed" and lines == [f"branch_switch = true, but the path met no bifurcation up to "
                                                 f"load factor {r.data('path/load_factor')[-1]:.6g}: nothing was "
                                                 "switched (the path is the primary one)"]


def test_why_a_path_ended_and_the_fixes_it_gives(tmp_path):
    """Items 21, 22: control of a coordinate the load does not move is diagnosed as such (not a mechanism);
    control of a fixed coordinate is the deck reader's one-line error naming ``solver.control``; the summary
    line says why a path ended; a stopped path's status counts in load factors, not t."""
    d = truss(algorithm="arc_length", arc_length=0.005, max_points=5, max_load_factor=5.0)
    d.solver.control = (d.node("left:1").id, 0, "position.x:left:1")  # the symmetric truss's apex: x stays 0
    r, _ = solve(d)
    assert isinstance(r, SolverDiverged) and "the load does not move the controlled coordinate" in str(r)
    assert "mechanism" not in str(r)
    deck = tmp_path / "arc.toml"
    text = (MODELS / "lee_frame.toml").read_text()
    deck.write_text(text.replace("max_load_factor = 4.0", "max_load_factor = 4.0\ncontrol = \"position.y:column:start\""))
    with pytest.raises(DeckError, match="solver.control: 'position.y:column:start' is a fixed coordinate") as err:
        load_deck(deck)
    assert "\n" not in str(err.value)
    d = truss(algorithm="arc_length", arc_length=0.05, max_points=5, max_load_factor=5.0)
    r, _ = solve(d)
    line = d.algorithm().summary(d.last_run["solver"])
    assert line == f"path ended: max_points = 5 points reached at load factor {r.data('path/load_factor')[-1]:.6g}"
    d = truss(algorithm="arc_length", arc_length=0.05, max_points=40, max_load_factor=0.3)
    d.solve()
    assert d.algorithm().summary(d.last_run["solver"]).startswith("path ended: |load factor| ")
    assert d.last_run["where"].startswith("load factor ")


def test_redundant_prescribed_displacement_is_not_told_to_take_epsilon():
    """Item 21: a prescribed displacement that repeats a constraint was told "epsilon > 0 on push", a key it does
    not have; the fix now names what can be done."""
    d = truss(load=False, algorithm="static", t_end=1.0, load_steps=2, dt=0.5)
    d.add_joint("prescribed_displacement", "left:1", None, (0.0, 0.0, 0.1), axis=(0.0, 1.0, 0.0),
                time_function=Ramp(0.0, 1.0, 0.0, 0.0), label="push")
    with pytest.raises(ValueError, match="remove the prescribed displacement push") as err:
        d.initialization()
    assert "epsilon > 0 on push" not in str(err.value)


def test_a_drive_rate_infinite_at_the_start_is_not_a_silent_completion(tmp_path):
    """Item 24: a prescribed displacement s = 0.05 t^(1/3) has an infinite rate at t = 0: the record's velocity
    violation norm is not finite there.  The run is `completed` no more without a word: its status and one
    warning line say where and why."""
    deck = tmp_path / "cube_root.toml"
    deck.write_text(DECK.replace('time_functions.push = { kind = "ramp", t0 = 0.0, t1 = 1.0, v1 = 0.3 }',
                                 'time_functions.push = { kind = "expression", expr = "0.05*t**(1/3)" }'))
    d = load_deck(deck).domain
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = d.solve(results_path=tmp_path / "results.h5")
    lines = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert not np.all(np.isfinite(r.data("constraints/velocity_violation_norm")))
    assert r.status == "completed with a non-finite constraint violation norm at load factor 0"
    assert len(lines) == 1 and "not finite at load factor 0" in lines[0]


def test_a_linearised_analysis_is_not_blamed_on_a_drive_at_t_infinite():
    """Item 21: a failed steady-rotation search (a linearised analysis, whose step is infinite) was blamed on
    "the drive 'slider' … is not finite at t = inf": the failed run's diagnosis looked at its drives at the
    last time plus the step.  A time that is not finite is no time of the run: the check passes it over, and
    still names a drive that is not finite at a finite time."""
    import math

    from reference.interactions import Sine
    from reference.monitor import nonfinite_load

    d = slider_crank(1.0, 1)
    d.joints[1].time_function = Sine(amplitude=1.0, omega=2.0)
    assert not math.isfinite(d.joints[1].time_function(math.inf))  # sin(∞): what the old check reported
    assert nonfinite_load(d, (0.0, math.inf)) == ""
    d.joints[1].time_function = Sine(amplitude=math.inf)
    assert nonfinite_load(d, (0.0, math.inf)).startswith("the drive 'drive' is not finite at t = 0")
