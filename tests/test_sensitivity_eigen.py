"""Eigenvalue sensitivities (reference/sensitivity/eigen.py, issue 40): the cantilever's first frequency and
the Euler column's critical load against central differences and the closed forms."""

import math
from pathlib import Path

import numpy as np
import pytest

from flexmbs.verification.sensitivities import COLUMN, PENDULUM, PENDULUM_PARAMETERS, pendulum, pendulum_omegas
from reference.io.deck_parameters import ParameterError
from reference.io.deck_sensitivities import eigen_sensitivities

CANTILEVER = "models/cantilever_modes.toml"
H = 1e-3
"""Relative step of the central differences of an eigenvalue: the eigenvalues carry round-off of up to about
4e-10 relative (the static equilibrium and the eigen-solver; it changes with the BLAS threads), 4e-10 / 2e-3 =
2e-7; the truncation error, O(H²) times the eigenvalue's curvature in p, measured below 1e-7 (steps of 1e-4 and
1e-3 agree to 1e-7).  Both below the 1e-6 of issue 40."""


def _central(path, name, value, index, step=H):
    """Central difference (relative step ``step``) of the eigenvalues of the deck at ``path``."""
    plus = eigen_sensitivities(path, [], {name: value * (1.0 + step)})[0]
    minus = eigen_sensitivities(path, [], {name: value * (1.0 - step)})[0]
    return (plus[index] - minus[index]) / (2.0 * step * value)


def test_cantilever_first_frequency_sensitivities():
    omega, d = eigen_sensitivities(CANTILEVER, ["sections.rect.EI2", "sections.rect.rhoA"])
    w1 = omega[0]
    assert abs(d[0, 0] - _central(CANTILEVER, "sections.rect.EI2", 1.0, 0)) <= 1e-6 * abs(d[0, 0])
    assert abs(d[1, 0] - _central(CANTILEVER, "sections.rect.rhoA", 1.0, 0)) <= 1e-6 * abs(d[1, 0])
    # Euler-Bernoulli: ω ∝ sqrt(EI/ρA), so dω/dEI = ω/(2EI), dω/dρA = −ω/(2ρA) (EI = ρA = 1).  The Timoshenko
    # beam's shear and rotary inertia take 0.08 % of ω₁ (the deck's notes), so its derivatives differ from
    # those by about as much: measured 1.2e-3 (EI) and 4.6e-4 (ρA) relative.  Bound: 2e-3.
    assert abs(d[0, 0] - w1 / 2.0) <= 2e-3 * w1 / 2.0
    assert abs(d[1, 0] + w1 / 2.0) <= 2e-3 * w1 / 2.0


def test_euler_column_critical_load_sensitivity(tmp_path):
    path = tmp_path / "column.toml"
    path.write_text(COLUMN)
    mu, d = eigen_sensitivities(path, ["sections.col.EI2", "loads[0].force"])
    P = 2.0  # the load at t_end: P_cr = μ P
    dP = P * d[0, 0]
    assert abs(d[0, 0] - _central(path, "sections.col.EI2", 1.0, 0)) <= 1e-6 * abs(d[0, 0])
    # P_cr = π² EI / (4 L²): dP_cr/dEI2 = π²/4 (L = 1) within the mesh error of Beam2's buckling load
    # (second order from above: +4.0e-4 at 32 elements, measured on P_cr itself); bound 1e-3.
    assert abs(dP - math.pi**2 / 4.0) <= 1e-3 * math.pi**2 / 4.0
    assert abs(P * mu[0] - math.pi**2 / 4.0) <= 1e-3 * math.pi**2 / 4.0
    # μ times the load's scale is the critical load, a constant: dμ/ds = −μ (round-off).
    assert abs(d[1, 0] + mu[0]) <= 1e-9 * mu[0]


def test_explicit_and_static_decks_are_refused_for_eigen_sensitivities():
    with pytest.raises(ParameterError, match="not built here"):
        eigen_sensitivities("models/three_bar.toml", ["sections.coupler.EI3"])
    with pytest.raises(ParameterError, match="geometry or mesh"):
        eigen_sensitivities(CANTILEVER, ["beams.0.elements"])


def test_a_repeated_frequency_is_said_in_one_line():
    # A square section (EI2 = EI3, rhoJ2 = rhoJ3, GA2 = GA3) bends alike towards y and z: ω₁ is double.
    square = {"sections.rect.EI3": 1.0, "sections.rect.rhoJ3": 1e-4}
    with pytest.warns(Warning, match=r"mode 1 is repeated .*one branch only") as record:
        eigen_sensitivities(CANTILEVER, ["sections.rect.EI2"], square)
    assert all("\n" not in str(w.message) for w in record)


def test_jointed_double_pendulum_mode_sensitivities(tmp_path):
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM.replace("HINGE", "-0.5"))
    names = list(PENDULUM_PARAMETERS)
    omega, d = eigen_sensitivities(path, names)
    nominal = [5.0, 2.0, 1.0, 1.0]
    # the closed form's ω (the deck's 4.520738 and 15.53328 rad/s): the constrained pencil is the 2 x 2 one to
    # round-off (joints' Jacobian and null space exact for bodies on the axis); bound 1e-9 relative
    for k, w in enumerate(pendulum_omegas(*nominal)):
        assert abs(omega[k] - w) <= 1e-9 * w
    for i, name in enumerate(names):
        override, value = PENDULUM_PARAMETERS[name]
        central = [_central(path, override, value, k, 1e-5) for k in range(2)]
        # issue 40: within 1e-6 relative of central differences (the mass moves the pivot's and hinge's
        # multipliers, hence the joints' geometric stiffness: a test that λ(p) is carried).  Relative step
        # 1e-5: rigid bodies leave round-off of 1e-14 in ω (1e-9 in the difference), truncation 1e-10 (the
        # step 1e-3 of the beams leaves up to 6e-7 here, measured)
        for k in range(2):
            assert abs(d[i, k] - central[k]) <= 1e-6 * max(abs(d[i, k]), 1e-3 * omega[k])
    # and the closed form's derivatives (the report's row: central differences of the formula, relative step 1e-5,
    # truncation 1e-10, round-off 1e-11) within 1e-8 relative: measured 3.3e-10
    name, _, error, tolerance, _ = pendulum(tmp_path / "report")[0]
    assert "torsion double pendulum" in name and error <= tolerance == 1e-8


def test_a_parameter_that_moves_the_joints_is_refused(tmp_path):
    from reference.io.deck import load_deck
    from reference.sensitivity.eigen import linearised, mode_sensitivities
    path, moved = tmp_path / "pendulum.toml", tmp_path / "moved.toml"
    path.write_text(PENDULUM.replace("HINGE", "-0.5"))
    moved.write_text(PENDULUM.replace("HINGE", "-0.501"))  # the hinge's point: B changes at the same state
    domain = load_deck(path).domain
    state = domain.initial_conditions()
    base = linearised(domain.initialization(), state)
    other = linearised(load_deck(moved).domain.initialization(), state)
    with pytest.raises(ValueError, match=r"^parameter 'hinge' moves the joints' constraints .*; name a") as info:
        mode_sensitivities(base, [other], [1e-3], 2, ["'hinge'"])
    assert "\n" not in str(info.value)


def test_damped_modes_are_refused_in_one_line(tmp_path):
    # a damper in the pivot's spring: the damped modes' first-order pencil is not symmetric, and the formula
    # then needs the left eigenvectors
    path = tmp_path / "damped.toml"
    path.write_text(PENDULUM.replace("HINGE", "-0.5").replace("stiffness = 5.0", "stiffness = 5.0\ndamping = 0.1"))
    with pytest.raises(ParameterError, match=r"^mode sensitivities of damped or gyroscopic modes .*; take") as e:
        eigen_sensitivities(path, ["springs[0].stiffness"])
    assert "\n" not in str(e.value)


TENSIONED = """
[time_functions.load_factor]
kind = "ramp"
t0 = 0.0
t1 = 1.0

[[loads]]
node = "beam:end"
force = [FORCE, 0.0, 0.0]
time_function = "load_factor"
"""
"""An axial tip tension ramped to FORCE at t = 1, added to the cantilever deck: its modes about the static
equilibrium at t = 1 are stiffened by the tension (a string's share T/(ρA) in ω²)."""


def _tensioned(tmp_path, force: float) -> str:
    text = open(CANTILEVER).read().replace('about = "reference"', 'about = "static"\nt_end = 1.0\nload_steps = 1\n'
                                                                 'tolerance = 1e-12')
    path = tmp_path / f"tensioned_{force!r}.toml"
    path.write_text(text + TENSIONED.replace("FORCE", repr(force)))
    return path


def test_modes_about_a_static_equilibrium(tmp_path):
    T = 20.0  # ω₁ grows from 3.51 to 9.14 rad/s
    path = _tensioned(tmp_path, T)
    omega, d = eigen_sensitivities(path, ["sections.rect.EI2", "loads[0].force", "sections.rect.rhoA"])
    unloaded = eigen_sensitivities(CANTILEVER, [])[0]
    assert omega[0] > 1.1 * unloaded[0]  # the tension stiffens: the static path was taken
    # the section entries: central differences of whole runs (relative step 1e-3, as for the reference state:
    # round-off 2e-7 with the 1e-12 Newton tolerance, truncation below 7e-7: measured 1.2e-7 and 6.2e-7); the
    # tension's scale: the same differences of the decks with the force scaled (measured 1.3e-7)
    assert abs(d[0, 0] - _central(path, "sections.rect.EI2", 1.0, 0)) <= 1e-6 * abs(d[0, 0])
    assert abs(d[2, 0] - _central(path, "sections.rect.rhoA", 1.0, 0)) <= 1e-6 * abs(d[2, 0])
    plus, minus = (eigen_sensitivities(_tensioned(tmp_path, T * (1 + s * H)), [])[0][0] for s in (1, -1))
    assert abs(d[1, 0] - (plus - minus) / (2 * H)) <= 1e-6 * abs(d[1, 0])


def _pinned_column(tmp_path) -> Path:
    """The Euler column (16 elements) pinned at its base by a revolute joint (multipliers) instead of clamped,
    its top held laterally, under the axial load and a lateral one at mid-span: the equilibrium bends, and its
    joint reactions carry the loads."""
    text = COLUMN.replace('[[clamps]]\nnode = "column:start"\n', """[[joints]]
kind = "revolute"
label = "pin"
body_i = "column:start"
point = [0.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]

[[fixed]]
node = "column:end"
dofs = ["y", "z"]

[[loads]]
node = "column:8"
force = [0.0, 0.0, 0.5]
time_function = "load_factor"
""")
    path = tmp_path / "pinned_column.toml"
    path.write_text(text.replace("elements = 32", "elements = 16").replace("force = [-2.0, 0.0, 0.0]",
                                                                          "force = [-5.0, 0.0, 0.0]")
                    .replace("load_steps = 1", "load_steps = 4"))
    return path


def test_buckling_sensitivities_of_a_jointed_column(tmp_path):
    path = _pinned_column(tmp_path)
    mu, d = eigen_sensitivities(path, ["sections.col.EI2", "sections.col.EA"])
    # pinned-pinned: P_cr ≈ π² EI/L², the load 5 at t_end: μ ≈ 1.97 less the lateral load's bending
    assert 0.9 < mu[0] < 1.1 * math.pi**2 / 5.0
    # the multipliers' sensitivity (the pin carries the loads) and the tangent's change along the bent
    # equilibrium: central differences (relative step 3e-4) within 1e-6.  Measured 6.5e-8 (EI2) and 1.6e-7 (EA);
    # at the step 1e-3 their truncation leaves 8.7e-7 and 9.4e-7, at 1e-4 μ's round-off 4e-8 and 2.1e-7
    assert abs(d[0, 0] - _central(path, "sections.col.EI2", 1.0, 0, 3e-4)) <= 1e-6 * abs(d[0, 0])
    assert abs(d[1, 0] - _central(path, "sections.col.EA", 1e5, 0, 3e-4)) <= 1e-6 * abs(d[1, 0])


def test_buckling_formula_with_a_moving_null_space():
    # (K0(p) + μ Kg(p)) φ = 0 on the null space of B(p), all smooth in p: the formula's −2 νᵀ dB φ term against
    # central differences of the reduced eigenproblem itself (dense, step 1e-6: measured 3.3e-10; without the
    # term 0.81 off)
    import numpy as np
    import scipy.linalg as sla

    from reference.sensitivity.eigen import buckling_sensitivities

    rng = np.random.default_rng(7)
    n, m = 8, 2
    R0, R1, G0, G1 = (rng.standard_normal((n, n)) for _ in range(4))
    B0, B1 = rng.standard_normal((m, n)), rng.standard_normal((m, n))
    K0 = lambda p: R0 @ R0.T + n * np.eye(n) + p * (R1 + R1.T)  # noqa: E731
    Kg = lambda p: -(G0 @ G0.T + np.eye(n)) + p * (G1 + G1.T) / 10  # noqa: E731
    B = lambda p: B0 + p * B1  # noqa: E731

    def lowest(p):
        Z = sla.null_space(B(p))
        inverse = sla.eigh(-Z.T @ Kg(p) @ Z, Z.T @ K0(p) @ Z, eigvals_only=True)
        return 1.0 / inverse.max()

    p, h = 0.3, 1e-6
    mu, d = buckling_sensitivities(K0(p), K0(p) + Kg(p), [R1 + R1.T], [R1 + R1.T + (G1 + G1.T) / 10], 1,
                                   (B(p), [B1]))
    assert abs(mu[0] - lowest(p)) <= 1e-12 * mu[0]
    central = (lowest(p + h) - lowest(p - h)) / (2 * h)
    assert abs(d[0, 0] - central) <= 1e-7 * abs(central)
    without = buckling_sensitivities(K0(p), K0(p) + Kg(p), [R1 + R1.T], [R1 + R1.T + (G1 + G1.T) / 10], 1,
                                     (B(p), [0 * B1]))[1]
    assert abs(without[0, 0] - central) > 1e-3 * abs(central)  # the term matters here


def test_modes_about_a_static_equilibrium_of_a_jointed_column(tmp_path):
    path = _pinned_column(tmp_path)
    path.write_text(path.read_text().replace('algorithm = "buckling"', 'algorithm = "modes"\nabout = "static"'))
    omega, d = eigen_sensitivities(path, ["sections.col.EI2", "sections.col.rhoA"])
    # the bent, loaded equilibrium (axial load at half its critical value): the multipliers' sensitivity, the
    # tangent's change along the equilibrium and the null space's; central differences (relative step 3e-4, as
    # for buckling above: measured 2e-9 and 1.3e-8) within 1e-6
    for i, name in enumerate(("sections.col.EI2", "sections.col.rhoA")):
        assert abs(d[i, 0] - _central(path, name, 1.0, 0, 3e-4)) <= 1e-6 * abs(d[i, 0]), name


def test_a_jointed_model_with_zero_and_repeated_modes(tmp_path):
    # the pendulum without springs on spherical joints: each bar spins freely about its axis (two zero modes:
    # derivative 0, no warning) and swings alike in two planes (each frequency double: one line each)
    text = PENDULUM.replace("HINGE", "-0.5")
    text = text[: text.index("[[springs]]")] + text[text.index("[gravity]"):]
    planar, spherical = tmp_path / "planar.toml", tmp_path / "spherical.toml"
    planar.write_text(text)
    spherical.write_text(text.replace('kind = "revolute"', 'kind = "spherical"').replace("modes = 2", "modes = 6"))
    with pytest.warns(Warning, match=r"mode [3-6] is repeated .*one branch only") as record:
        omega, d = eigen_sensitivities(spherical, ["rigid_bodies.lower.mass"])
    messages = [str(w.message) for w in record]
    assert len(messages) == 4 and all("\n" not in m and "nan" not in m for m in messages)
    assert omega[0] == omega[1] == 0.0 and d[0, 0] == d[0, 1] == 0.0
    # the mass keeps the symmetry, so both branches move as the planar pendulum's modes (revolute joints)
    w_planar, d_planar = eigen_sensitivities(planar, ["rigid_bodies.lower.mass"])
    assert np.allclose(omega[2::2], w_planar, rtol=1e-9) and np.allclose(omega[3::2], w_planar, rtol=1e-9)
    assert np.allclose(d[0, 2::2], d_planar[0], rtol=1e-7) and np.allclose(d[0, 3::2], d_planar[0], rtol=1e-7)


@pytest.mark.parametrize("index", [0, 2])
def test_an_overridden_parameter_is_differentiated_at_its_overridden_value(tmp_path, index):
    """A run whose deck value is overridden (as a sweep does) differentiates at the overridden value, not at the
    written one: a spring's stiffness and a body's mass set by override, against the closed form's derivative
    there (central difference of the formula, relative step 1e-5: truncation 1e-10)."""
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM.replace("HINGE", "-0.5"))
    name = list(PENDULUM_PARAMETERS)[index]
    override, _ = PENDULUM_PARAMETERS[name]
    nominal = [5.0, 2.0, 1.0, 1.0]
    nominal[index] = 3.0
    omega, d = eigen_sensitivities(path, [name], {override: 3.0})
    plus, minus = list(nominal), list(nominal)
    plus[index] *= 1.0 + 1e-5
    minus[index] *= 1.0 - 1e-5
    closed = (pendulum_omegas(*plus) - pendulum_omegas(*minus)) / (2e-5 * 3.0)
    # the written value's derivative differs by tens of percent (0.187 against 0.133 for the first spring), so a
    # derivative taken at the written value fails this bound by far; 1e-7 relative covers the formula's truncation
    # and the constrained pencil's round-off (1e-9, test above)
    assert np.allclose(d[0, :2], closed, rtol=1e-7, atol=0.0)
