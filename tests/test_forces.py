"""Force elements (springs, dampers, bushings), loads at points and along beams, formula time functions.

Every check compares with a closed form; tolerances and their reasons are next to each.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.evaluation.force_elements import force_element_forces
from reference.forces import Bushing, PointToPoint, Rotational
from reference.interactions import Expression, FixedCoordinates, LineLoad, NodalLoad, Ramp, SmoothStep
from reference.io.deck import DeckError, load_deck

from conftest import cantilever

SOLVER = """
[solver]
dt = {dt}
t_end = {t_end}
output_every = {every}
"""


def deck(tmp_path, body: str, dt=1e-3, t_end=2.0, every=1, name="d"):
    path = tmp_path / f"{name}.toml"
    path.write_text(f'[meta]\nname = "{name}"\n' + body + SOLVER.format(dt=dt, t_end=t_end, every=every))
    return path


MASS = """
[[rigid_bodies]]
label = "m"
mass = 1.0
inertia = [1.0, 1.0, 1.0]
position = [1.1, 0.0, 0.0]
"""


def crossings(t, x):
    """Upward zero crossings, linearly interpolated."""
    up = np.where((x[:-1] < 0) & (x[1:] >= 0))[0]
    return t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])


def peaks(t, x):
    """Maxima, refined by a parabola through the three samples around each."""
    k = np.where((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]))[0] + 1
    a, b, c = x[k - 1], x[k], x[k + 1]
    return b - 0.125 * (c - a) ** 2 / (a - 2 * b + c)


def test_point_to_point_spring_period_and_log_decrement(tmp_path):
    """m = 1 on k = 100 (rest length 1, stretched by 0.1): T = 2π/10.

    Tolerance 0.1 % (the target); the central difference lengthens the period
    by (ωh)²/24 = 4e-6 at h = 1e-3.  Damped (c = 0.4, ζ = 0.02): the logarithmic
    decrement between successive maxima is 2πζ/√(1−ζ²); within 0.5 % (the
    target; the scheme's damping error is O(ωh) of ζ's effect, 1e-3 relative).
    """
    springs = """
[[springs]]
kind = "point_to_point"
body_i = "m"
point_i = [1.1, 0.0, 0.0]
point_j = [0.0, 0.0, 0.0]
stiffness = 100.0
rest_length = 1.0
damping = {c}
"""
    r = load_deck(deck(tmp_path, MASS + springs.format(c=0.0), t_end=3.0)).solve()
    x = r.position("m")[:, 0] - 1.0
    period = np.mean(np.diff(crossings(r.time, x)))
    assert period == pytest.approx(2 * np.pi / 10, rel=1e-3)
    assert abs(period / (2 * np.pi / 10) - 1) < 2e-5  # measured 4e-6: the scheme's (ωh)²/24
    # undamped: energy kept (oscillation of the discrete energy O((ωh)²) of the total)
    E = r.energy
    total = E["kinetic"] + E["strain"]
    assert np.max(np.abs(total - total[0])) < 1e-4 * total[0]

    r = load_deck(deck(tmp_path, MASS + springs.format(c=0.4), t_end=3.0, name="damped")).solve()
    x = r.position("m")[:, 0] - 1.0
    zeta = 0.4 / (2 * math.sqrt(100.0))
    expected = 2 * np.pi * zeta / math.sqrt(1 - zeta**2)
    measured = np.mean(np.diff(np.log(peaks(r.time, x))))
    assert -measured == pytest.approx(expected, rel=5e-3)
    # dissipated energy = loss of mechanical energy (1e-4 of the initial energy: the scheme's accuracy)
    E = r.energy
    balance = E["kinetic"] + E["strain"] + E["dissipated"]
    assert np.max(np.abs(balance - balance[0])) < 1e-4 * balance[0]


def test_torsional_pendulum_period_and_log_decrement(tmp_path):
    """Disc J = 2 about z on a torsion spring k = 50 to the ground, initial twist rate: T = 2π√(J/k).

    Same tolerances as the translational spring (0.1 % period, 0.5 % decrement).
    The spin passes several radians in the stiff case to exercise the continuous
    angle: a large initial rate (amplitude 3 rad > π) must give the same period
    (a wrapped angle would snap the spring at ±π).
    """
    body = """
[[rigid_bodies]]
label = "disc"
mass = 1.0
inertia = [1.0, 1.0, 2.0]
position = [0.0, 0.0, 0.0]

[[springs]]
kind = "rotational"
body_i = "disc"
axis = [0.0, 0.0, 1.0]
stiffness = 50.0
damping = {c}

[[initial_velocities]]
node = "disc"
angular_velocity = [0.0, 0.0, {w0}]
"""
    omega = 5.0
    w0 = 3.0 * omega  # amplitude 3 rad
    r = load_deck(deck(tmp_path, body.format(c=0.0, w0=w0), t_end=3.0)).solve()
    wz = r.angular_velocity("disc")[:, 2]
    period = np.mean(np.diff(crossings(r.time, wz)))
    assert period == pytest.approx(2 * np.pi / omega, rel=1e-3)
    E = r.energy
    assert np.max(E["strain"]) == pytest.approx(0.5 * 2.0 * w0**2, rel=1e-3)  # ½kθ_max² = ½Jω0², θ_max = 3 > π

    c = 0.4
    r = load_deck(deck(tmp_path, body.format(c=c, w0=1.0), t_end=3.0, name="damped")).solve()
    wz = r.angular_velocity("disc")[:, 2]
    zeta = c / (2 * math.sqrt(50.0 * 2.0))
    expected = 2 * np.pi * zeta / math.sqrt(1 - zeta**2)
    measured = -np.mean(np.diff(np.log(peaks(r.time, wz))))
    assert measured == pytest.approx(expected, rel=5e-3)


def test_bushing_static_deflection_is_k_inverse_F(tmp_path):
    """Constant force and moment on a body held by a damped bushing: d = K⁻¹F, θ = K⁻¹M.

    Loads small (d ~ 1e-5, θ ~ 1e-3) so that the coupling of the frame rotation
    with the force directions and the small-rotation measure stay below 1e-6
    relative; relaxed to rest (damping near critical, residual < 1e-9).
    Tolerance 1e-5 relative.  The frame is tilted (axis and reference not along
    the coordinate axes) so K⁻¹ acts in the bushing frame.
    """
    axis = np.array([1.0, 1.0, 1.0]) / math.sqrt(3)
    ref = np.array([1.0, -1.0, 0.0])
    from reference.joints.joint import joint_frame

    U = joint_frame(axis, ref)
    k = np.array([100.0, 200.0, 300.0, 10.0, 20.0, 30.0])
    c = 2.0 * np.sqrt(k * np.array([1, 1, 1, 1, 1, 1.0]))
    F = np.array([1e-3, 2e-3, -3e-3])
    M = np.array([0.01, -0.02, 0.03])
    body = f"""
[[rigid_bodies]]
label = "b"
mass = 1.0
inertia = [1.0, 1.0, 1.0]
position = [0.5, 0.0, 0.0]

[[springs]]
kind = "bushing"
body_i = "b"
point = [0.5, 0.0, 0.0]
axis = {axis.tolist()}
reference = {ref.tolist()}
stiffness = {k.tolist()}
damping = {c.tolist()}

[[loads]]
node = "b"
force = {F.tolist()}

[[loads]]
node = "b"
moment = {M.tolist()}
"""
    r = load_deck(deck(tmp_path, body, t_end=12.0, every=12000)).solve()
    d = r.position("b")[-1] - np.array([0.5, 0.0, 0.0])
    # the frame turns with the body (θ ~ 1e-3): K⁻¹ acts in the rotated frame A U
    from reference.rotation import EulerParameters

    AU = EulerParameters(r.rotation("b")[-1]).matrix() @ U
    expected_d = AU @ ((AU.T @ F) / k[:3])
    assert np.allclose(d, expected_d, rtol=0, atol=1e-5 * np.linalg.norm(expected_d))
    q = r.rotation("b")[-1]
    theta = 2.0 * q[1:] / q[0]  # Gibbs vector ≈ rotation vector to O(θ³)
    expected_theta = U @ ((U.T @ M) / k[3:])
    assert np.allclose(theta, expected_theta, rtol=0, atol=1e-3 * np.linalg.norm(expected_theta))


def test_free_mass_pushed_by_an_expression(tmp_path):
    """x'' = sin²(3t) from rest: x(2) = t²/4 + (cos 6t − 1)/72 within 1e-5 (the target;
    the central difference's error is O(h²) ≈ 1e-7 here)."""
    body = MASS.replace("[1.1, 0.0, 0.0]", "[0.0, 0.0, 0.0]") + """
[time_functions.push]
kind = "expression"
expr = "sin(3*t)**2"

[[loads]]
node = "m"
force = [1.0, 0.0, 0.0]
time_function = "push"
"""
    r = load_deck(deck(tmp_path, body, t_end=2.0, every=100)).solve()
    t = 2.0
    exact = t**2 / 4 + (math.cos(6 * t) - 1) / 72
    assert abs(r.position("m")[-1, 0] - exact) < 1e-5
    # the work of the load is the kinetic energy (trapezoidal work: second order)
    assert r.energy["external_work"][-1] == pytest.approx(r.energy["kinetic"][-1], rel=1e-4)


def test_expression_derivative_and_integral_are_the_symbolic_ones():
    """Value, derivative and integral of a formula against their closed forms (1e-13: round-off)."""
    tf = Expression("sin(3*t)**2 + exp(-t)*t", with_integral=True)
    for t in (0.0, 0.3, 1.7, 4.0):
        assert tf(t) == pytest.approx(math.sin(3 * t) ** 2 + math.exp(-t) * t, abs=1e-13)
        assert tf.derivative(t) == pytest.approx(3 * math.sin(6 * t) + math.exp(-t) * (1 - t), abs=1e-13)
        integral = t / 2 - math.sin(6 * t) / 12 + 1 - math.exp(-t) * (t + 1)
        assert tf.integral(t) == pytest.approx(integral, abs=1e-13)


def _spin_up_body(tf, mode="position"):
    d = Domain()
    disc = d.add_rigid_body("disc", 1.0, [1.0, 1.0, 2.0], [0.0, 0.0, 0.0])
    d.add_joint("revolute", disc, None, [0.0, 0.0, 0.0], axis=[0.0, 0.0, 1.0])
    d.add_joint("rotation_drive", disc, None, [0.0, 0.0, 0.0], axis=[0.0, 0.0, 1.0], time_function=tf, mode=mode)
    d.solver = SolverSettings(dt=1e-3, t_end=1.0, output_every=10)
    return d


SPIN = "3*(t**2/(2*0.5) + 0.5/(4*pi**2)*(cos(2*pi*t/0.5) - 1))"


def test_rotation_drive_follows_an_expression_with_the_symbolic_derivative():
    """θ(t) = Ω[t²/(2T) + (T/4π²)(cos(2πt/T) − 1)], Ω = 3, T = 0.5, prescribed in position mode.

    The joint's velocity constraint is B V + Φ_t = 0 with Φ_t from the derived
    θ'(t): the body's angular velocity must equal θ'(t) = Ω[t/T − sin(2πt/T)/(2π)]
    to the integrator's accuracy (mid-step velocities against the integer-step
    derivative: O(h²) ≈ 1e-5 relative; tolerance 1e-4 of Ω).  With the value
    program in place of the derivative (a wrong Φ_t) the same check fails
    (error 3.5e-3 of Ω, the position stabilisation pulling back; the check
    demands > 1e-3) — the check sees the derivative.
    """
    Omega, T = 3.0, 0.5
    tf = Expression(SPIN)
    r = _spin_up_body(tf).solve()
    t = r.time
    rate = Omega * (t / T - np.sin(2 * np.pi * t / T) / (2 * np.pi))
    wz = r.angular_velocity("disc")[:, 2]
    assert np.max(np.abs(wz - rate)) < 1e-4 * Omega
    q = r.rotation("disc")
    angle = np.unwrap(2 * np.arctan2(q[:, 3], q[:, 0]))
    theta = Omega * (t**2 / (2 * T) + T / (4 * np.pi**2) * (np.cos(2 * np.pi * t / T) - 1))
    assert np.max(np.abs(angle - theta)) < 1e-5

    class WrongDerivative(Expression):
        def parameters(self):
            p = super().parameters()
            nv, nd = int(p[0]), int(p[1])
            bad = np.concatenate([[nv, nv, p[2], p[3]], p[4:4 + 2 * nv], p[4:4 + 2 * nv]])
            return bad

    r = _spin_up_body(WrongDerivative(SPIN)).solve()
    wz = r.angular_velocity("disc")[:, 2]
    assert np.max(np.abs(wz - rate)) > 1e-3 * Omega


def test_velocity_mode_drive_integrates_an_expression():
    """θ' = 2 + sin(4t) prescribed in velocity mode: θ = 2t + (1 − cos 4t)/4 (1e-5: O(h²))."""
    r = _spin_up_body(Expression("2 + sin(4*t)", with_integral=True), mode="velocity").solve()
    t = r.time
    q = r.rotation("disc")
    angle = np.unwrap(2 * np.arctan2(q[:, 3], q[:, 0]))
    assert np.max(np.abs(angle - (2 * t + (1 - np.cos(4 * t)) / 4))) < 1e-5


def test_piecewise_linear_bisection_and_prefix_sums_match_the_linear_search():
    """Value, derivative and integral of a 601-point table against numpy's interp and trapezoids (1e-12)."""
    from reference.interactions import PiecewiseLinear

    tt = np.linspace(0.5, 6.5, 601)
    vv = np.sin(tt) + 0.1 * tt
    f = PiecewiseLinear(list(tt), list(vv))
    for t in (0.0, 0.5, 0.51234, 3.3, 6.5, 7.0):
        assert f(t) == pytest.approx(np.interp(t, tt, vv), abs=1e-12)
        grid = np.sort(np.concatenate([[0.0, t], tt[tt < t]]))
        assert f.integral(t) == pytest.approx(np.trapezoid(np.interp(grid, tt, vv), grid), abs=1e-11)
    k = 123
    assert f.derivative(0.5 * (tt[k] + tt[k + 1])) == pytest.approx((vv[k + 1] - vv[k]) / (tt[k + 1] - tt[k]))


def test_cantilever_under_uniform_line_load():
    """Tip deflection w L⁴/(8 EI) + w L²/(2 GA) (Timoshenko), damped dynamics to rest.

    Tolerance 0.5 % (the target): the one-point linear element's bending error
    at n = 20 is O(1/n²) ≈ 0.1 %, the shear term is 3 % of the total (without it
    the check fails), geometric nonlinearity at δ/L ≈ 1e-4 is negligible.
    """
    L, EI, GA, w = 1.0, 1.0, 10.0, 1e-3
    sec = Section(EA=1e3, GA2=GA, GA3=GA, GJ=1.0, EI2=EI, EI3=EI, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)
    d, nodes = cantilever(20, sec, L)
    d.add_interaction(LineLoad(nodes, np.array([0.0, 0.0, w]), time_function=SmoothStep(0.0, 1.0, 0.0, 1.0)))
    d.solver = SolverSettings(dt=1e-3, t_end=12.0, damping=7.0, output_every=1000)
    r = d.solve()
    tip = r.position(nodes[-1].label)[-1, 2]
    expected = w * L**4 / (8 * EI) + w * L**2 / (2 * GA)
    assert tip == pytest.approx(expected, rel=5e-3)
    assert tip != pytest.approx(w * L**4 / (8 * EI), rel=5e-3)


def test_force_at_a_body_point_adds_its_moment():
    """A dead force F at a point r of a free body: v̇ = F/m and J ω̇ = r × F at t = 0 (exact, first step)."""
    d = Domain()
    b = d.add_rigid_body("b", 2.0, [1.0, 2.0, 3.0], [1.0, 0.0, 0.0])
    d.add_interaction(NodalLoad(b, np.array([0.0, 3.0, 0.0]), point=np.array([1.5, 0.0, 0.2])))
    d.solver = SolverSettings(dt=1e-4, t_end=1e-4)
    r = d.solve()
    h = 1e-4
    r_arm = np.array([0.5, 0.0, 0.2])
    # first kick is h/2 from rest: v^{1/2} = (h/2) F/m; recorded velocity at t_1 is the mean with v^{3/2}
    state = d.state
    assert state.v[0] == pytest.approx(0.5 * h * np.array([0.0, 1.5, 0.0]), rel=1e-9)
    moment = np.cross(r_arm, [0.0, 3.0, 0.0])
    assert state.w[0] == pytest.approx(0.5 * h * moment / np.array([1.0, 2.0, 3.0]), rel=1e-6, abs=1e-12)
    assert r.time[-1] == pytest.approx(h)


@pytest.mark.parametrize("algorithm, dt", [("staggered_central_difference", 2e-4), ("generalized_alpha", 1e-3)])
def test_energy_balance_with_springs_dampers_and_actuator(algorithm, dt):
    """Two bodies on a spring-damper, a torsion spring-damper and a bushing to the ground, driven by an
    actuator force and a load: T + U − W + D stays constant to 1e-4 of the work done (both schemes are
    second order: the residual is O((ωh)²) of the exchanged energy; generalized-α with ρ∞ = 1, which has
    no numerical dissipation)."""
    from reference.interactions import Sine

    d = Domain()
    a = d.add_rigid_body("a", 1.0, [0.2, 0.3, 0.4], [0.0, 0.0, 0.0])
    b = d.add_rigid_body("b", 2.0, [0.5, 0.4, 0.3], [1.0, 0.2, 0.0])
    d.add_force_element(PointToPoint(a, [0.1, 0.1, 0.0], b, [0.9, 0.3, 0.1], stiffness=50.0, damping=0.5,
                                     rest_length=0.7, force_function=Sine(2.0, 3.0)))
    d.add_force_element(Rotational(a, None, axis=[0.0, 1.0, 1.0], stiffness=5.0, damping=0.05))
    d.add_force_element(Bushing(b, a, point=[0.5, 0.1, 0.0], axis=[0.0, 0.0, 1.0], reference=None,
                                stiffness=[80, 60, 40, 3, 4, 5],
                                damping=[0.2, 0.2, 0.2, 0.01, 0.01, 0.01]))
    d.add_interaction(NodalLoad(b, np.array([0.0, 0.0, 1.0]), time_function=Sine(1.0, 5.0), point=[1.2, 0.2, 0.0]))
    d.solver = SolverSettings(dt=dt, t_end=3.0, output_every=int(round(0.01 / dt)), algorithm=algorithm,
                              rho_inf=1.0)
    r = d.solve()
    E = r.energy
    balance = E["kinetic"] + E["strain"] - E["external_work"] + E["dissipated"]
    work = np.max(np.abs(E["external_work"]))
    print(f"{algorithm}: energy balance {np.max(np.abs(balance - balance[0])) / work:.2e} of the work")
    assert work > 0.1 and E["dissipated"][-1] > 0.01
    assert np.max(np.abs(balance - balance[0])) < 1e-4 * work


def test_force_element_forces_are_the_energy_gradient():
    """Finite differences of the spring energy against the kernel's forces (virtual translations and
    body-frame rotations; 1e-6 relative: central differences with step 1e-6)."""
    from reference.generated import rotation_maps as rm

    d = Domain()
    a = d.add_rigid_body("a", 1.0, [0.2, 0.3, 0.4], [0.0, 0.0, 0.0])
    b = d.add_rigid_body("b", 2.0, [0.5, 0.4, 0.3], [1.0, 0.2, 0.0])
    d.add_force_element(PointToPoint(a, [0.1, 0.1, 0.0], b, [0.9, 0.3, 0.1], stiffness=50.0, rest_length=0.5))
    d.add_force_element(Rotational(a, b, axis=[0.0, 1.0, 1.0], stiffness=5.0, rest_angle=0.3))
    d.add_force_element(Bushing(b, a, point=[0.5, 0.1, 0.0], axis=[0.0, 0.0, 1.0], reference=None,
                                stiffness=[80, 60, 40, 3, 4, 5]))
    model = d.initialization()
    rng = np.random.default_rng(1)
    x = np.array([n.position for n in d.nodes]) + 0.05 * rng.standard_normal((2, 3))
    q = np.array([n.rotation for n in d.nodes]) + 0.1 * rng.standard_normal((2, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    zero = np.zeros((2, 3))

    def energy(x, q):
        F = np.zeros((2, 6))
        return force_element_forces(model.force_elements, model.time_functions, x, q, zero, zero, 0.0, np.zeros(3),
                                    F, F, np.zeros(10), np.zeros(120))

    F = np.zeros((2, 6))
    force_element_forces(model.force_elements, model.time_functions, x, q, zero, zero, 0.0, np.zeros(3), F, F,
                         np.zeros(10), np.zeros(120))
    eps = 1e-6
    for n in range(2):
        for a_ in range(6):
            pair = []
            for s in (eps, -eps):
                xp, qp = x.copy(), q.copy()
                if a_ < 3:
                    xp[n, a_] += s
                else:
                    dth = np.zeros(3)
                    dth[a_ - 3] = s
                    out = np.array(rm.cayley_update_scalars(*q[n], *dth, 1.0))
                    qp[n] = out / np.linalg.norm(out)
                pair.append(energy(xp, qp)[0])
            assert -(pair[0] - pair[1]) / (2 * eps) == pytest.approx(F[n, a_], rel=1e-6, abs=1e-8)


@pytest.mark.parametrize("change, message", [
    ('stiffness = -5.0', "must not be negative"),
    ('point_i = [0.0, 0.0, 0.0]', "give rest_length > 0"),
    ('body_i = "nobody"', "no node 'nobody'"),
])
def test_bad_springs_are_refused_with_one_line(tmp_path, change, message):
    body = MASS + """
[[springs]]
kind = "point_to_point"
body_i = "m"
point_i = [1.1, 0.0, 0.0]
stiffness = 100.0
"""
    key = change.split(" = ")[0]
    body = "\n".join(change if line.startswith(key + " =") else line for line in body.splitlines())
    with pytest.raises(DeckError) as exc:
        load_deck(deck(tmp_path, body))
    text = str(exc.value)
    assert message in text and "\n" not in text and text.startswith(str(tmp_path))


def test_zero_axis_of_a_torsion_spring_is_refused(tmp_path):
    body = MASS + """
[[springs]]
kind = "rotational"
body_i = "m"
axis = [0.0, 0.0, 0.0]
stiffness = 1.0
"""
    with pytest.raises(DeckError, match="springs\\[0\\]: force element 'rotational:0': the axis is the zero vector"):
        load_deck(deck(tmp_path, body))


@pytest.mark.parametrize("expr, message", [
    ("sin(3*t", "does not parse"),
    ("sin(3*x)", "unknown name 'x'"),
    ("__import__('os').system('true')", "unknown name '__import__'"),
    ("t.real", "not allowed"),
])
def test_bad_expressions_are_refused_with_one_line(tmp_path, expr, message):
    body = MASS + f"""
[time_functions.f]
kind = "expression"
expr = "{expr}"
"""
    with pytest.raises(DeckError) as exc:
        load_deck(deck(tmp_path, body))
    text = str(exc.value)
    assert message in text and "time_functions.f.expr" in text and "\n" not in text


def test_velocity_drive_with_an_expression_without_closed_form_integral_is_refused(tmp_path):
    body = MASS + """
[time_functions.f]
kind = "expression"
expr = "exp(t**2)"

[[joints]]
kind = "revolute"
body_i = "m"
point = [1.1, 0.0, 0.0]

[[joints]]
kind = "rotation_drive"
body_i = "m"
point = [1.1, 0.0, 0.0]
time_function = "f"
mode = "velocity"
"""
    with pytest.raises(DeckError, match="no closed-form integral"):
        load_deck(deck(tmp_path, body))


def test_over_stiff_spring_is_caught_by_the_step_check(tmp_path):
    """k = 1e8 on m = 1: ω = 1e4, critical step 2e-4 < dt = 1e-3 → refused, with a dt suggestion."""
    body = MASS + """
[[springs]]
kind = "point_to_point"
body_i = "m"
point_i = [1.1, 0.0, 0.0]
stiffness = 1e8
"""
    with pytest.raises(DeckError, match="critical time step 0.0002"):
        load_deck(deck(tmp_path, body))



def _tangent_check(kind):
    """Max differences |K − K_fd|/max|K| and |C − C_fd|/max|C| of one element kind."""
    from reference.evaluation.force_elements import force_element_tangent
    from reference.generated import rotation_maps as rm

    d = Domain()
    a = d.add_rigid_body("a", 1.0, [0.2, 0.3, 0.4], [0.0, 0.0, 0.0])
    b = d.add_rigid_body("b", 2.0, [0.5, 0.4, 0.3], [1.0, 0.2, 0.0])
    element = {"point_to_point": PointToPoint(a, [0.1, 0.1, 0.0], b, [0.9, 0.3, 0.1], stiffness=50.0, damping=3.0,
                                              rest_length=0.5),
               "rotational": Rotational(a, b, axis=[0.0, 1.0, 1.0], stiffness=5.0, damping=0.7, rest_angle=0.3),
               "bushing": Bushing(b, a, point=[0.5, 0.1, 0.0], axis=[0.0, 0.0, 1.0], reference=None,
                                  stiffness=[80, 60, 40, 3, 4, 5],
                                  damping=[1, 2, 3, 0.1, 0.2, 0.3])}[kind]
    d.add_force_element(element)
    model = d.initialization()
    rng = np.random.default_rng(7)
    x = np.array([n.position for n in d.nodes]) + 0.05 * rng.standard_normal((2, 3))
    q = np.array([n.rotation for n in d.nodes]) + 0.2 * rng.standard_normal((2, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    v, w = rng.standard_normal((2, 3)), rng.standard_normal((2, 3))

    def force(x, q, v, w):
        F = np.zeros((2, 6))
        force_element_forces(model.force_elements, model.time_functions, x, q, v, w, 0.0, np.zeros(1), F, F,
                             np.zeros(6), np.zeros(72))
        return F.reshape(12)

    K, C = np.zeros((12, 12)), np.zeros((12, 12))
    force_element_tangent(model, x, q, v, w, np.zeros(1), 0, K, C, np.zeros(6), np.zeros(72), np.zeros(864))
    eps = 1e-6
    K_fd, C_fd = np.zeros((12, 12)), np.zeros((12, 12))
    for c in range(12):
        n, comp = divmod(c, 6)
        pair, pair_v = [], []
        for s in (eps, -eps):
            xp, qp, vp, wp = x.copy(), q.copy(), v.copy(), w.copy()
            if comp < 3:
                xp[n, comp] += s
                vp[n, comp] += s
            else:
                dth = np.zeros(3)
                dth[comp - 3] = s
                out = np.array(rm.cayley_update_scalars(*q[n], *dth, 1.0))
                qp[n] = out / np.linalg.norm(out)
                wp[n, comp - 3] += s
            pair.append(force(xp, qp, v, w))
            pair_v.append(force(x, q, vp, wp))
        K_fd[:, c] = -(pair[0] - pair[1]) / (2 * eps)
        C_fd[:, c] = -(pair_v[0] - pair_v[1]) / (2 * eps)
    # the element's columns are [body_i | body_j]; the differences are in node order
    order = np.concatenate([6 * element.body_i.id + np.arange(6), 6 * element.body_j.id + np.arange(6)])
    K_fd, C_fd = K_fd[np.ix_(order, order)], C_fd[np.ix_(order, order)]
    return np.max(np.abs(K - K_fd)) / np.max(np.abs(K)), np.max(np.abs(C - C_fd)) / np.max(np.abs(C))



def test_force_element_tangent_matches_finite_differences():
    """The derived tangent (for implicit algorithms) against central differences of the force:
    stiffness along body-frame increments and damping along velocities, at a random stretched
    and moving configuration, for the three kinds.  1e-6 relative to the largest entry: differences
    with step 1e-6.  Run without compilation (NUMBA_DISABLE_JIT=1, a subprocess): compiling the large
    generated tangent kernels takes a minute and only implicit algorithms need them compiled."""
    import json
    import os
    import subprocess
    import sys

    code = ("import sys; sys.path.insert(0, 'tests'); from test_forces import _tangent_check; "
            "import json; print(json.dumps([[float(e) for e in _tangent_check(k)] "
            "for k in ('point_to_point', 'rotational', 'bushing')]))")
    root = Path(__file__).resolve().parent.parent
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "NUMBA_DISABLE_JIT": "1", "PYTHONPATH": str(root)})
    assert out.returncode == 0, out.stderr[-2000:]
    errors = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(errors) == 3
    for k_err, c_err in errors:
        assert k_err < 1e-6 and c_err < 1e-6, errors


MODELS = Path(__file__).resolve().parent.parent / "models"


@pytest.mark.parametrize("algorithm", ["deck", "generalized_alpha"])
def test_every_force_element_and_load_kind_agrees_with_exudyn(tmp_path, algorithm):
    """models/force_elements_crosscheck.toml through the cross-check harness: all three deck
    tolerances hold (reasons in the deck; measured 1.5e-4 m, 1.9e-4 m and 4.5e-9 m) — with the deck's
    explicit scheme, and with generalized-α at 5× its step (ρ∞ = 1; Exudyn's generalized-α at the same
    step; measured 1.5e-4 m, 2.0e-4 m and 1.1e-9 m)."""
    from crosscheck.harness import run

    path = MODELS / "force_elements_crosscheck.toml"
    if algorithm != "deck":
        text = path.read_text().replace("dt = 2e-4\n", f'dt = 1e-3\nalgorithm = "{algorithm}"\nrho_inf = 1.0\n')
        assert f'algorithm = "{algorithm}"' in text and "output_every = 50" in text
        path = tmp_path / "force_elements_ga.toml"
        path.write_text(text.replace("output_every = 50", "output_every = 10"))
    cmp = run(path, tmp_path)
    assert {v.observable for v in cmp["verdicts"]} == {"position:box", "position:b:end", "position:probe"}
    assert all(v.passed for v in cmp["verdicts"]), [(v.observable, v.max_difference) for v in cmp["verdicts"]]


@pytest.mark.parametrize("algorithm", ["deck", "generalized_alpha"])
def test_torsion_double_pendulum_model_meets_its_checks(algorithm):
    """models/torsion_double_pendulum.toml against its [checks]: first period and mode shape from the
    linearised 2 × 2 eigenproblem, energy conservation (tolerances and reasons in the deck) — with the
    deck's explicit scheme and with generalized-α at 5× its step (ρ∞ = 1: no numerical dissipation;
    period error (ω1 h)²/12 ≈ 2e-5), torsion springs inside revolute joints."""
    import scipy.linalg

    deck = load_deck(MODELS / "torsion_double_pendulum.toml")
    domain, checks = deck.domain, deck.checks
    m, l, g, k1, k2 = 1.0, 0.5, 9.81, 5.0, 2.0
    M = np.array([[4 / 3 * m * l**2, m * l**2 / 2], [m * l**2 / 2, m * l**2 / 3]])
    K = np.array([[1.5 * m * g * l + k1 + k2, -k2], [-k2, 0.5 * m * g * l + k2]])
    w2, modes = scipy.linalg.eigh(K, M)
    T1, shape = 2 * np.pi / np.sqrt(w2[0]), modes[1, 0] / modes[0, 0]
    assert T1 == pytest.approx(1.389858, rel=1e-6) and shape == pytest.approx(1.656586, rel=1e-6)
    if algorithm != "deck":
        domain.solver.algorithm, domain.solver.rho_inf = algorithm, 1.0
        domain.solver.dt, domain.solver.output_every = 5e-3, 2
    r = domain.solve()
    th = [2 * np.arctan2(r.rotation(b)[:, 2], r.rotation(b)[:, 0]) for b in ("upper", "lower")]
    period = np.mean(np.diff(crossings(r.time, th[0])))
    E = r.energy
    balance = E["kinetic"] + E["strain"] - E["external_work"]
    print(f"{algorithm}: period {period / T1 - 1:.2e}, shape {th[1].max() / th[0].max() / shape - 1:.2e}, "
          f"energy {np.max(np.abs(balance - balance[0])) / E['kinetic'].max():.2e}")
    assert abs(period / T1 - 1) < checks["first_period"]["tolerance"]
    assert abs(th[1].max() / th[0].max() / shape - 1) < checks["mode_shape"]["tolerance"]
    assert np.max(np.abs(balance - balance[0])) / E["kinetic"].max() < checks["energy"]["tolerance"]


def _spring_mass(algorithm, **solver):
    """m = 1 at (1.1, 0, 0) on a spring to the origin (k = 100, rest length 1); returns (domain, body)."""
    d = Domain()
    body = d.add_rigid_body("m", 1.0, [1.0, 1.0, 1.0], [1.1, 0.0, 0.0])
    d.add_force_element(PointToPoint(body, [1.1, 0.0, 0.0], None, [0.0, 0.0, 0.0], stiffness=100.0,
                                     damping=solver.pop("damping", 0.0), rest_length=1.0))
    d.solver.algorithm = algorithm
    for key, value in solver.items():
        setattr(d.solver, key, value)
    return d, body


def _solve_with_newton_histories(d):
    """Solve ``d``; returns the results and the Newton residual norms of every load step, read from the
    static algorithm's run state (``Domain.last_run["solver"].history``) after each output."""
    histories = []
    r = d.solve(progress=lambda fraction, t: histories.append(list(d.last_run["solver"].history)))
    return r, histories


def _quadratic(hist):
    """Newton residuals r_{i+1}/r_0 ≤ 10 (r_i/r_0)² above round-off (1e-11 r_0)."""
    r0 = hist[0]
    return all(b <= 10.0 * a * a / r0 for a, b in zip(hist, hist[1:]) if b > 1e-11 * r0)


def test_static_bushing_deflection_is_k_inverse_F():
    """Static algorithm, a bushing in a tilted frame (axis (1,1,1)/√3) with six different stiffnesses.
    Under a force: the displacement is A U K⁻¹ (A U)ᵀ F to 1e-10 (the translational measure is linear in
    d; Newton stops at a residual of 1e-10 of the load).  Under a force and a moment: the rotation vector
    is K⁻¹M in the same frame to 1e-3 (the bushing's rotation measure ½ vee(R − Rᵀ) is the rotation
    vector to first order; θ ≈ 1e-3) and the strain energy equals the work of the loads (ramped over the
    one load step, trapezoidal) to 1e-3.  Newton converges quadratically (derived tangent)."""
    from reference.joints.joint import joint_frame
    from reference.rotation import EulerParameters

    axis, ref = np.array([1.0, 1.0, 1.0]) / math.sqrt(3), np.array([1.0, -1.0, 0.0])
    U = joint_frame(axis, ref)
    k = np.array([100.0, 200.0, 300.0, 10.0, 20.0, 30.0])
    F, M = np.array([1e-3, 2e-3, -3e-3]), np.array([0.01, -0.02, 0.03])
    for with_moment in (False, True):
        d = Domain()
        b = d.add_rigid_body("b", 1.0, [1.0, 1.0, 1.0], [0.5, 0.0, 0.0])
        d.add_force_element(Bushing(b, None, point=[0.5, 0.0, 0.0], axis=axis, reference=ref, stiffness=k,
                                    damping=np.zeros(6)))
        d.add_interaction(NodalLoad(b, F, time_function=_ramp()))
        if with_moment:
            d.add_interaction(NodalLoad(b, M, moment=True, time_function=_ramp()))
        else:
            d.add_interaction(FixedCoordinates(b, (3, 4, 5)))
        d.solver.algorithm, d.solver.load_steps, d.solver.t_end, d.solver.dt = "static", 1, 1.0, 1.0
        r, history = _solve_with_newton_histories(d)
        assert r.status == "completed"
        q = r.rotation("b")[-1]
        AU = EulerParameters(q).matrix() @ U
        d_err = np.linalg.norm(r.position("b")[-1] - [0.5, 0.0, 0.0] - AU @ ((AU.T @ F) / k[:3]))
        d_err /= np.linalg.norm(F / k[:3])
        print(f"bushing (moment: {with_moment}): |d − K⁻¹F|/|K⁻¹F| = {d_err:.2e}, Newton {history}")
        assert history and all(_quadratic(h) for h in history)
        if not with_moment:
            assert d_err < 1e-10
            continue
        t_err = np.linalg.norm(2 * q[1:] / q[0] - AU @ ((AU.T @ M) / k[3:])) / np.linalg.norm(M / k[3:])
        print(f"|θ − K⁻¹M|/|K⁻¹M| = {t_err:.2e}")
        assert t_err < 1e-3
        assert r.energy["strain"][-1] == pytest.approx(r.energy["external_work"][-1], rel=1e-3)


def test_static_point_to_point_spring_under_a_load_and_quadratic_newton():
    """A point-to-point spring (k = 100, rest length 1) from the origin to a mass whose rotations are fixed,
    under F = (5, 0, 0) N and (0, 5, 0) N ramped in 5 load steps: the spring turns by 45° with the load
    and stretches to ℓ = 1 + |F|/k, x = ℓ F/|F| (closed form; Newton's tolerance 1e-10).  Newton's
    residuals fall quadratically at every load step (the derived tangent includes the geometric stiffness
    N/ℓ across the line)."""
    d, body = _spring_mass("static", load_steps=5, t_end=1.0, dt=0.2)
    F = np.array([5.0, 5.0, 0.0])
    d.add_interaction(NodalLoad(body, np.array([5.0, 0.0, 0.0])))
    d.add_interaction(NodalLoad(body, np.array([0.0, 5.0, 0.0]), time_function=_ramp()))
    d.add_interaction(FixedCoordinates(body, (3, 4, 5)))
    r, history = _solve_with_newton_histories(d)
    assert r.status == "completed"
    x = r.position("m")[-1]
    exact = (1.0 + np.linalg.norm(F) / 100.0) * F / np.linalg.norm(F)
    for step, hist in enumerate(history):
        print(f"load step {step}: residuals", " ".join(f"{v:.2e}" for v in hist))
    print(f"|x − ℓF/|F|| = {np.linalg.norm(x - exact):.2e} m")
    assert np.linalg.norm(x - exact) < 1e-10
    assert len(history) == 5 and all(_quadratic(h) for h in history)
    assert max(len(h) for h in history) <= 7


def _ramp():
    return Ramp(0.0, 1.0, 0.0, 1.0)


def test_generalized_alpha_spring_period_and_log_decrement():
    """Generalized-α on m = 1, k = 100 (rest length 1, stretched 0.1): period 2π/10 within 1e-3 at h = 1e-2
    (ωh = 0.1; the scheme's period error is O((ωh)²)); with ρ∞ = 1 and c = 1 N s/m (ζ = 0.05) the
    logarithmic decrement 2πζ/√(1 − ζ²) within 0.5 %, and the energy balance T + U + D − W (dampers booked
    in the dissipated energy by the trapezoidal rule on their power) constant to 1e-4 of the initial energy
    at h = 1.25e-3, its error second order in h (ratio 4 ± 0.4 when h halves)."""
    d, _ = _spring_mass("generalized_alpha", dt=1e-2, t_end=2.0)
    r = d.solve()
    period = np.mean(np.diff(crossings(r.time, r.position("m")[:, 0] - 1.0)))
    print(f"period error (ρ∞ = 0.8, h = 1e-2): {period / (2 * np.pi / 10) - 1:.2e}")
    assert abs(period / (2 * np.pi / 10) - 1) < 1e-3
    zeta = 0.05
    drifts = []
    for h in (2.5e-3, 1.25e-3):
        d, _ = _spring_mass("generalized_alpha", dt=h, t_end=3.0, rho_inf=1.0, damping=2 * zeta * 10.0)
        r = d.solve()
        E = r.energy
        balance = E["kinetic"] + E["strain"] + E["dissipated"] - E["external_work"]
        drifts.append(np.max(np.abs(balance - balance[0])) / balance[0])
    p = peaks(r.time, r.position("m")[:, 0] - 1.0)
    measured = np.mean(np.log(p[:-1] / p[1:]))
    analytic = 2 * np.pi * zeta / math.sqrt(1 - zeta**2)
    print(f"log decrement {measured:.6f} vs {analytic:.6f} ({measured / analytic - 1:.2e}); "
          f"energy drift {drifts[0]:.2e} (h = 2.5e-3), {drifts[1]:.2e} (h = 1.25e-3)")
    assert len(p) >= 4 and abs(measured / analytic - 1) < 5e-3
    assert E["dissipated"][-1] > 0.9 * balance[0]
    assert drifts[1] < 1e-4 and 3.6 < drifts[0] / drifts[1] < 4.4


def test_generalized_alpha_torsional_pendulum_beyond_pi():
    """A disc (J = 2) on a torsion spring to the ground (k = 50: ω = 5 rad/s) started at 20 rad/s swings
    through ±4 rad, past ±π: the continuous angle keeps the spring's energy ½kφ² (a wrapped angle would
    jump to the other branch).  Generalized-α (ρ∞ = 1, h = 2e-3): period 2π/5 within 1e-4 (O((ωh)²)),
    amplitude 4 rad within 1e-3, energy T + U conserved to 1e-6 (trapezoidal rule on a linear oscillator).
    Damped (ζ = 0.05): the logarithmic decrement 2πζ/√(1 − ζ²) within 0.5 % and T + U + D constant to
    1e-4 (O((ωh)²) = 1e-4 of the dissipated energy)."""
    d = Domain()
    disc = d.add_rigid_body("disc", 1.0, [1.0, 1.0, 2.0], [0.0, 0.0, 0.0])
    disc.angular_velocity = np.array([0.0, 0.0, 20.0])
    d.add_force_element(Rotational(disc, None, axis=[0.0, 0.0, 1.0], stiffness=50.0))
    d.solver.algorithm, d.solver.dt, d.solver.t_end, d.solver.rho_inf = "generalized_alpha", 2e-3, 2.6, 1.0
    r = d.solve()
    wz = r.angular_velocity("disc")[:, 2]
    period = np.mean(np.diff(crossings(r.time, wz)))
    E = r.energy
    amplitude = math.sqrt(2 * E["strain"].max() / 50.0)
    total = E["kinetic"] + E["strain"]
    drift = np.max(np.abs(total - total[0])) / total[0]
    print(f"torsion period error {period / (2 * np.pi / 5) - 1:.2e}, amplitude {amplitude:.6f} rad, drift {drift:.1e}")
    assert abs(period / (2 * np.pi / 5) - 1) < 1e-4
    assert abs(amplitude - 4.0) < 1e-3 and drift < 1e-6
    zeta = 0.05
    d.force_elements[0].damping = 2 * zeta * math.sqrt(50.0 * 2.0)
    d.solver.t_end = 6.0
    r = d.solve()
    p = peaks(r.time, r.angular_velocity("disc")[:, 2])
    measured = np.mean(np.log(p[:-1] / p[1:]))
    analytic = 2 * np.pi * zeta / math.sqrt(1 - zeta**2)
    E = r.energy
    balance = E["kinetic"] + E["strain"] + E["dissipated"]
    print(f"torsion log decrement {measured:.6f} vs {analytic:.6f} ({measured / analytic - 1:.2e}), "
          f"energy balance {np.max(np.abs(balance - balance[0])) / balance[0]:.1e}")
    assert len(p) >= 4 and abs(measured / analytic - 1) < 5e-3
    assert np.max(np.abs(balance - balance[0])) < 1e-4 * balance[0]
