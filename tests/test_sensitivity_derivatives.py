"""∂r/∂p by kind (reference/sensitivity/derivatives.py, issue 40): the generated ∂S/∂c, the loads' own vectors
and the masses' changes agree with the residual of the model with the parameter moved (exact by affinity: the
oracle) on every element family and every parameter kind, at a bent, moving state."""

import numpy as np
import pytest

from reference.io.deck_parameters import resolve_all
from reference.io.deck_sensitivities import model_at, parameter_kinds
from reference.plain.newton import Newton, compose
from reference.sensitivity.derivatives import LoadScale, Mass, ParameterDerivatives, ResidualDerivatives, Spring, \
    Stiffness

ROLLUP = "models/embedded_beam_static.toml"
SECTION = ["EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ1", "rhoJ2", "rhoJ3"]
PENDULUM = "models/torsion_double_pendulum.toml"


def _state(domain, model, seed: int):
    """A bent, turned, moving state of the nodes: the initial positions moved by 1 % of the span, rotations by up
    to 0.3 rad, velocities, accelerations and (joints) multipliers of order one."""
    rng = np.random.default_rng(seed)
    start = domain.initial_conditions()
    x0, q0 = np.asarray(start.x, float), np.asarray(start.q, float)
    N = x0.shape[0]
    span = max(float(np.ptp(x0)), 1.0)
    x = x0 + 0.01 * span * rng.standard_normal((N, 3))
    q = compose(q0, 0.3 * rng.uniform(-1.0, 1.0, (N, 3)))
    return (x, q, rng.standard_normal((N, 3)), rng.standard_normal((N, 3)), rng.standard_normal((N, 6)),
            rng.standard_normal(model.n_constraints))


def _compare(path, names, overrides, algorithms, dynamic):
    """Largest difference of each parameter's ∂r/∂p, ∂Φ/∂p by kind from the oracle's, relative to the oracle's
    largest entry; and the kinds."""
    domain, params, kinds = parameter_kinds(path, names, overrides, algorithms)
    base = model_at(params[0], path, overrides, params[0].value)
    steps = [max(abs(p.value), 1.0) for p in params]
    oracle = ResidualDerivatives(Newton(base), [model_at(p, path, overrides, p.value + d)
                                                for p, d in zip(params, steps)], steps)
    by_kind = ParameterDerivatives(Newton(base), kinds)
    x, q, v, w, vd, lam = _state(domain, base, 7)
    expected = oracle(x, q, v, w, vd, lam, 0.7, dynamic)
    got = by_kind(x, q, v, w, vd, lam, 0.7, dynamic)
    errors = []
    for (er, ep), (gr, gp) in zip(expected, got):
        scale = max(float(np.max(np.abs(er))), float(np.max(np.abs(ep), initial=0.0)), 1e-300)
        errors.append(max(float(np.max(np.abs(gr - er))), float(np.max(np.abs(gp - ep), initial=0.0))) / scale)
    return errors, kinds, expected


@pytest.mark.parametrize("family", ["beam2", "beam2_se3", "beam3"])
@pytest.mark.parametrize("dynamic", [False, True])
def test_every_section_entry_and_the_load_scale_agree_with_the_moved_model(tmp_path, family, dynamic):
    # The roll-up with gravity (so that the densities enter a static residual too) on each family: the generated
    # ∂S/∂c for the six stiffnesses, the load's own vector for its scale, the masses' change for the four
    # densities.  The oracle differences r(p + Δ) − r(p) with Δ = max(|p|, 1) lose nothing but the rounding of r
    # (1e-16 of it): 1e-12 of the derivative's largest entry (measured at most 4.3e-14, beam3).
    path = tmp_path / "rollup.toml"
    path.write_text(open(ROLLUP).read() + "\n[gravity]\ng = [0.0, 0.0, -9.81]\n")
    names = ["loads[0].moment"] + [f"sections.rollup.{k}" for k in SECTION]
    errors, kinds, expected = _compare(path, names, {"beams.0.element": family}, ("static",), dynamic)
    assert [type(k) for k in kinds] == [LoadScale] + [Stiffness] * 6 + [Mass] * 4
    moving = names if dynamic else names[:8]  # static: gravity has no moment, the rotary densities drop out
    assert all(np.max(np.abs(r)) > 0 for (r, _), n in zip(expected, names) if n in moving)
    assert max(errors) <= 1e-12, dict(zip(names, errors))


@pytest.mark.parametrize("dynamic", [False, True])
def test_rigid_body_masses_and_springs_agree_with_the_moved_model_with_joints(dynamic):
    # Rigid bodies' masses (gravity, inertia), an inertia tensor's scale (static: nothing; dynamic: J ω̇ + ω × J ω)
    # and rotational springs' stiffnesses (each spring alone with its stiffness' change, no damper) on a jointed
    # model, at a turned state with the joints' multipliers.
    names = ["rigid_bodies.upper.mass", "rigid_bodies.lower.mass", "springs[0].stiffness", "springs[1].stiffness",
             "rigid_bodies.lower.inertia"]
    errors, kinds, expected = _compare(PENDULUM, names, {}, ("staggered_central_difference",), dynamic)
    assert [type(k) for k in kinds] == [Mass, Mass, Spring, Spring, Mass]
    assert all(np.max(np.abs(r)) > 0 for r, _ in (expected if dynamic else expected[:4]))
    assert max(errors) <= 1e-12, dict(zip(names, errors))


def test_section_members_are_the_section_elements_only(tmp_path):
    # Two beams on two sections: a stiffness of one moves the residual only at that beam's nodes.
    path = tmp_path / "two.toml"
    text = open(ROLLUP).read().replace('end = [10.0, 0.0, 0.0]\nelements = 12', 'end = [5.0, 0.0, 0.0]\nelements = 6')
    text += ('\n[sections.other]\nEA = 8.0\nGA2 = 8.0\nGA3 = 8.0\nGJ = 200.0\nEI2 = 200.0\nEI3 = 200.0\n'
             'rhoA = 1e-6\nrhoJ1 = 1e-5\nrhoJ2 = 1e-5\nrhoJ3 = 1e-5\n'
             '[[beams]]\nlabel = "second"\nstart_node = "beam:end"\nend = [10.0, 0.0, 0.0]\nelements = 6\n'
             'section = "other"\naxis2 = [0.0, 1.0, 0.0]\n')
    path.write_text(text.replace('node = "beam:end"\nmoment', 'node = "second:end"\nmoment'))
    names = ["sections.rollup.EI2", "sections.other.EI2"]
    errors, kinds, expected = _compare(path, names, {}, ("static",), False)
    assert max(errors) <= 1e-12
    first = np.flatnonzero(np.any(expected[0][0] != 0.0, axis=1))
    second = np.flatnonzero(np.any(expected[1][0] != 0.0, axis=1))
    assert first.max() <= 6 and second.min() >= 6  # nodes 0…6 are the first beam's, 6…12 the second's


def test_parameters_resolve_as_before():
    # The kinds do not change the names: the roll-up's parameters resolve to the deck's values.
    params = resolve_all(ROLLUP, ["sections.rollup.EI2", "loads[0].moment"])
    assert [p.value for p in params] == [100.0, 1.0]
