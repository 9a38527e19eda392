"""The reference path's model evaluation (reference/plain/model.py) against the compiled kernels.

Every quantity an algorithm asks of the model — forces and energies, the implicit residual, the joints'
Φ, B, Φ_t, the tangent stiffness with the constraint Hessian, the damping and mass matrices, the
rotation tangent of generalized-α — is compared with the compiled evaluation
(:class:`reference.algorithms.implicit.NewtonSystem`: ``evaluate`` and the Newton matrix's blocks) on
decks that together hold every load kind (dead and follower forces and moments, forces at arms, time
functions of every kind), every force element (point-to-point with damper and actuator, rotational,
bushing), every joint kind and drive — every gallery deck and a zoo of what the gallery lacks — at the
initial state and at a perturbed state (positions, rotations, velocities, accelerations and multipliers
drawn at random, t > 0).

Tolerance: 1e-12 relative to the largest entry of the compared quantity.  Both paths evaluate the same
generated expressions; they differ only in the order of a few sums (NumPy's ``einsum`` and ``@``
against the kernels' loops) and in the last bit of NumPy's against the C library's ``sin``/``cos``/
``sqrt``, i.e. a few ulps (~1e-16 relative) of the largest term; 1e-12 leaves that a margin of 10⁴
and still catches any wrong term (one wrong entry is O(1) relative).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from reference.algorithms.implicit import NewtonSystem
from reference.domain import Domain
from reference.interactions import Clamp, Constant, Gravity, NodalLoad, PiecewiseLinear, Ramp, Sine, SmoothStep, Step
from reference.io.deck import load_deck
from reference.joints import MasterSlave
from reference.plain.model import Evaluation
from reference.rotation import EulerParameters

from test_beam2 import qexp, qmul
from test_master_slave import SEC, floating

MODELS = Path(__file__).resolve().parent.parent / "models"
RTOL = 1e-12
DECKS = sorted(path.stem for path in MODELS.glob("*.toml"))
"""Every gallery deck (each evaluates in a fraction of a second)."""


def states(domain):
    """``(x, q, v, w, vd, lam, t, psi)``: the initial state at t = 0, and a perturbed one at t = 0.37 s
    (rotations by up to ~0.3 rad, positions by ~1 % of the model's size, random velocities,
    accelerations, multipliers and generalized-α rotations ψ)."""
    model = domain.model
    s = domain.initial_conditions()
    N, m = s.x.shape[0], model.n_constraints
    zero = (s.x, s.q, s.v, s.w, np.zeros((N, 6)), np.zeros(m), 0.0, np.zeros((N, 3)))
    rng = np.random.default_rng(N + 7 * m)
    size = max(float(np.ptp(s.x)), 1.0)
    q = np.array([qmul(qi, qexp(0.3 * rng.normal(size=3))) for qi in s.q])
    moved = (s.x + 0.01 * size * rng.normal(size=(N, 3)), q, rng.normal(size=(N, 3)), rng.normal(size=(N, 3)),
             rng.normal(size=(N, 6)), 10.0 * rng.normal(size=m), 0.37, 0.2 * rng.normal(size=(N, 3)))
    return [zero, moved]


def close(plain, compiled, what):
    """Assert ``plain`` equals ``compiled`` within :data:`RTOL` of the largest entry of ``compiled``."""
    plain, compiled = np.asarray(plain, dtype=float), np.asarray(compiled, dtype=float)
    assert plain.shape == compiled.shape, what
    scale = max(float(np.max(np.abs(compiled), initial=0.0)), 1e-300)
    error = float(np.max(np.abs(plain - compiled), initial=0.0)) / scale
    assert error <= RTOL, f"{what}: relative error {error:.2e}"


def compare(domain):
    """Every quantity of :class:`Evaluation` against the compiled evaluation, at each of :func:`states`
    (the residual dynamic and static: no inertia, the force elements at rest)."""
    model = domain.model
    ev = Evaluation(model)
    free = ev.free.reshape(-1)
    for x, q, v, w, vd, lam, t, psi in states(domain):
        ns = NewtonSystem(model)
        U = ns.evaluate(x, q, v, w, vd, lam, t, True)
        work = ns.work
        angle = np.zeros(model.force_elements.kind.shape[0])
        S, F, U_p, D = ev.forces(x, q, v, w, t, angle.copy())
        close(S, work.S, "S")
        close(F, work.F, "F")
        close([U_p, D], [U, work.fe_out[0]], "U, D")
        r, _, _, phi, B, phi_t, _, _ = ev.residual(x, q, v, w, vd, lam, t, angle.copy())
        close(r, work.r, "residual")
        static = ev.residual(x, q, v, w, vd, lam, t, angle.copy(), dynamic=False)
        U_static = ns.evaluate(x, q, v, w, vd, lam, t, False)
        close(static.r, work.r, "static residual")
        close([static.U, static.D], [U_static, work.fe_out[0]], "static U, D")
        ns.evaluate(x, q, v, w, vd, lam, t, True)  # the Newton matrix's force elements at these velocities
        close(phi, work.PHI, "Φ")
        close(phi_t, work.PHIt, "Φ_t")
        nf = ns.n_free
        newton = ns.matrix(x, q, w, t, lam, 0.0, 0.0, 1.0, ce=0.0).toarray()
        close(B.toarray()[:, free], newton[nf:, :nf], "B")
        K = ev.tangent(x, q, v, w, t, lam, angle.copy()).toarray()
        close(K[np.ix_(free, free)], newton[:nf, :nf], "K")
        newton = ns.matrix(x, q, w, t, lam, 0.0, 0.0, 1.0, ce=0.0, psi=psi).toarray()
        T = ev.rotation_tangent(psi)
        close((ev.tangent(x, q, v, w, t, lam, angle.copy()) @ T).toarray()[np.ix_(free, free)], newton[:nf, :nf],
              "K T(ψ)")
        close((B @ T).toarray()[:, free], newton[nf:, :nf], "B T(ψ)")
        newton = ns.matrix(x, q, w, t, lam, 0.0, 1.0, 0.0, ce=0.0).toarray()
        close(ev.damping_matrix(x, q, v, w).toarray()[np.ix_(free, free)], newton[:nf, :nf], "C")
        newton = ns.matrix(x, q, w, t, lam, 1.0, 0.0, 0.0, ce=0.0).toarray()
        close(ev.mass_matrix().toarray()[np.ix_(free, free)], newton[:nf, :nf], "M")


@pytest.mark.parametrize("deck", DECKS)
def test_the_gallery_decks_evaluate_as_compiled(deck):
    compare(load_deck(MODELS / f"{deck}.toml").domain)


def joint_zoo():
    """Rigid bodies and a beam held by every joint kind and drive the gallery lacks (universal, cylindrical,
    translational, fixed, spherical; rotation and displacement drives in both modes; a prescribed
    displacement), under loads scaled by the time functions it lacks (step, sine, ramp, piecewise linear,
    smooth step), with a dead moment, a follower moment and forces at arms, and gravity."""
    d = Domain("zoo")
    for k in range(7):
        d.add_rigid_body(f"b{k}", 1.0 + k, [1.0, 1.5 + 0.1 * k, 2.0], [float(k), 0.0, 0.0])
    beam = d.add_beam("beam", (7.0, 0.0, 0.0), (9.0, 0.0, 0.0), 4, SEC)
    d.add_joint("spherical", "b0", None, (0.0, 0.0, 0.0))
    d.add_joint("universal", "b1", "b0", (0.5, 0.0, 0.0), axis=(0.0, 1.0, 0.0), reference=(0.0, 0.0, 1.0))
    d.add_joint("cylindrical", "b2", "b1", (1.5, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    d.add_joint("translational", "b3", "b2", (2.5, 0.0, 0.0), axis=(0.0, 0.0, 1.0))
    d.add_joint("fixed", "b4", "b3", (3.5, 0.0, 0.0))
    d.add_joint("revolute", "b5", "b4", (4.5, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    d.add_joint("rotation_drive", "b5", "b4", (4.5, 0.0, 0.0), axis=(0.0, 1.0, 0.0), time_function=Sine(0.3, 2.0, 0.1))
    d.add_joint("rotation_drive", "b6", None, (6.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0), mode="velocity",
                time_function=Ramp(0.0, 1.0, 0.5, 1.5))
    d.add_joint("displacement_drive", "b2", "b1", (1.5, 0.0, 0.0), axis=(1.0, 0.0, 0.0),
                time_function=Step(0.2, 0.0, 0.1))
    d.add_joint("displacement_drive", beam[0], "b6", (7.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), mode="velocity",
                time_function=SmoothStep(0.0, 1.0, 0.0, 0.2))
    d.add_joint("prescribed_displacement", beam[-1], None, (9.0, 0.0, 0.0), axis=(0.0, 1.0, 1.0),
                time_function=PiecewiseLinear([0.0, 0.3, 1.0], [0.0, 0.05, 0.02]))
    d.add_interaction(NodalLoad("b3", [0.0, 1.0, 2.0], moment=True, time_function=Sine(1.0, 3.0)))
    d.add_interaction(NodalLoad("b4", [1.0, 0.0, 2.0], moment=True, follower=True, time_function=Step(0.1, 1.0, 2.0)))
    d.add_interaction(NodalLoad("b5", [3.0, 1.0, 0.0], follower=True, point=(5.0, 0.2, 0.1)))
    d.add_interaction(NodalLoad("b6", [0.0, 2.0, 1.0], point=(6.0, -0.1, 0.3), time_function=Constant(2.0)))
    d.add_interaction(NodalLoad(beam[2], [0.0, 0.0, -3.0], follower=True, time_function=Ramp(0.0, 1.0)))
    d.add_interaction(Gravity([0.0, 0.0, -9.81]))
    return d


def test_every_joint_kind_drive_and_load_evaluates_as_compiled():
    compare(joint_zoo())


def family_beam(family):
    """A clamped beam of ``family`` (skew, three elements) under a follower force, its tip on a spherical joint."""
    d = Domain(family)
    nodes = d.add_beam("b", (0.0, 0.0, 0.0), (1.0, 0.3, 0.1), 3, SEC, element=family)
    d.add_interaction(Clamp(nodes[0]))
    d.add_interaction(NodalLoad(nodes[-1], [0.0, 1.0, 2.0], follower=True))
    d.add_joint("spherical", nodes[-1], None, (1.0, 0.3, 0.1))
    return d


def run_python(source: str, uncompiled: bool) -> str:
    """Run ``source`` in a fresh process (``tests/`` importable) and return its output; with the engine
    uncompiled (``NUMBA_DISABLE_JIT=1``) where ``uncompiled``."""
    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(root / "tests")]))
    if uncompiled:
        env["NUMBA_DISABLE_JIT"] = "1"
    out = subprocess.run([sys.executable, "-c", source], cwd=root, env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


@pytest.mark.parametrize("family", ["beam2_se3", "beam3"])
def test_the_other_element_families_evaluate_as_the_engine(family):
    """:func:`family_beam`: the Evaluation's element forces and tangents (:mod:`reference.plain.elements`) in
    the model's sums, against the engine's evaluation run uncompiled, in a subprocess — a model with another
    family would compile the implicit kernels for its own tuple of family data (minutes, cold; the reason
    tests/test_families.py runs uncompiled too).  The engine's code is the same, interpreted."""
    source = f"from test_plain_model import compare, family_beam; compare(family_beam({family!r})); print('compared')"
    assert run_python(source, uncompiled=True) == "compared"


def test_the_damper_dissipation_at_equal_velocities_is_the_dampers_power():
    """``Σ c (B_e V⁻)·(B_e V̄)`` with ``V⁺ = V⁻`` is ``Σ c (B_e V)²``, the power D of
    :meth:`Evaluation.forces` (itself compared with the compiled one above); with ``V⁺ = −V⁻`` it
    vanishes.  Round-off: 1e-12."""
    domain = load_deck(MODELS / "force_elements_crosscheck.toml").domain
    ev = Evaluation(domain.model)
    assert np.any(domain.model.force_elements.c > 0.0)
    x, q, v, w, _, _, t, _ = states(domain)[1]
    _, _, _, D = ev.forces(x, q, v, w, t, np.zeros(domain.model.force_elements.kind.shape[0]))
    assert D > 0.0
    assert abs(ev.damper_dissipation(x, q, v, w, v, w) - D) <= RTOL * D
    assert abs(ev.damper_dissipation(x, q, v, w, -v, -w)) <= RTOL * D


@pytest.mark.parametrize("kind", ["spherical", "revolute"])
def test_master_slave_projection_and_positions(kind):
    """The floating hub with a beam on a master/slave joint (tests/test_master_slave.py), at a perturbed state.

    Velocities: after :meth:`Evaluation.master_slave_project` the slave moves with the master
    (``v_s = v_m + ω_m × (A_m p'_m)`` inertial; revolute: ``ω_s − A_sᵀ A_m ω_m`` along the slave's axis
    ``a'_s``), the change is M-orthogonal to the allowed motions (the pair's momentum is kept: linear
    momentum ``m_m v_m + m_s v_s`` equal before and after) and a second projection changes nothing.
    Positions: after :meth:`Evaluation.master_slave_positions` ``x_s = x_m + A_m p'_m`` and, revolute, the
    axes agree, ``A_s a'_s = A_m a'_m``.  Round-off of O(1) quantities: 1e-12."""
    domain = floating(MasterSlave(), kind)
    model = domain.model
    ev = Evaluation(model)
    ms = model.master_slave
    assert ms.master.shape[0] == 1
    m, s, par = ms.master[0], ms.slave[0], ms.par[0]
    x, q, v, w, *_ = states(domain)[1]
    x, q, v, w = x.copy(), q.copy(), v.copy(), w.copy()
    mass = model.nodes.mass
    momentum = mass[m] * v[m] + mass[s] * v[s]
    ev.master_slave_project(q, v, w)
    A_m, A_s = EulerParameters(q[m]).matrix(), EulerParameters(q[s]).matrix()
    assert np.max(np.abs(v[s] - (v[m] + np.cross(A_m @ w[m], A_m @ par[0:3])))) <= RTOL * np.max(np.abs(v))
    if kind == "revolute":
        relative = w[s] - A_s.T @ A_m @ w[m]
        assert np.linalg.norm(np.cross(relative, par[6:9])) <= RTOL * np.max(np.abs(w))
    assert np.max(np.abs(mass[m] * v[m] + mass[s] * v[s] - momentum)) <= RTOL * np.max(np.abs(momentum))
    again = v.copy(), w.copy()
    ev.master_slave_project(q, *again)
    assert np.max(np.abs(again[0] - v)) <= RTOL * np.max(np.abs(v))
    assert np.max(np.abs(again[1] - w)) <= RTOL * np.max(np.abs(w))
    ev.master_slave_positions(x, q)
    A_m, A_s = EulerParameters(q[m]).matrix(), EulerParameters(q[s]).matrix()
    assert np.max(np.abs(x[s] - x[m] - A_m @ par[0:3])) <= RTOL * np.max(np.abs(x))
    assert abs(np.linalg.norm(q[s]) - 1.0) <= RTOL
    if kind == "revolute":
        assert np.max(np.abs(A_s @ par[6:9] - A_m @ par[3:6])) <= RTOL


NO_DISPATCHER = """
import sys
import numpy as np
import numba
from test_plain_model import MODELS, joint_zoo, states
from reference.io.deck import load_deck
from reference.plain.model import Evaluation


def signatures():
    found = {}
    for name, module in list(sys.modules.items()):
        if name.startswith("reference"):
            for attribute, value in vars(module).items():
                if isinstance(value, numba.core.dispatcher.Dispatcher):
                    found[(name, attribute)] = len(value.signatures)
    return found


domains = [load_deck(MODELS / "force_elements_crosscheck.toml").domain, joint_zoo()]
cases = [(Evaluation(d.model), states(d)[1]) for d in domains]
before = signatures()
for ev, (x, q, v, w, vd, lam, t, psi) in cases:
    angle = np.zeros(ev.model.force_elements.kind.shape[0])
    ev.residual(x, q, v, w, vd, lam, t, angle)
    ev.tangent(x, q, v, w, t, lam, angle) @ ev.rotation_tangent(psi)
    ev.damping_matrix(x, q, v, w), ev.mass_matrix(), ev.damper_dissipation(x, q, v, w, v, w)
    ev.master_slave_project(q, v, w), ev.master_slave_positions(x, q)
after = signatures()
print([key for key in after if after[key] != before.get(key, 0)])
"""


def test_the_evaluation_calls_no_numba_dispatcher():
    """The reference path runs the generated code as plain Python: evaluating everything on two models
    gives no numba dispatcher of the engine a new signature (none is compiled, nor loaded from the cache).
    In a fresh process, so that what other tests compiled does not hide a call."""
    assert run_python(NO_DISPATCHER, uncompiled=False) == "[]"


def test_the_rotational_springs_angle_continues_through_half_turns_as_compiled():
    """torsion_double_pendulum's first rotational spring (body 0 to the ground) turned about its axis by
    0.7 rad per evaluation through 2.5 turns: each evaluation continues the angle from the last (not the
    wrapped atan2 in (−π, π]), as the compiled evaluation does with its work array; the angles and the
    spring energy ½ k φ² agree with the compiled ones to round-off (1e-12 relative), and the angle reaches
    about 2.5 × 2π."""
    domain = load_deck(MODELS / "torsion_double_pendulum.toml").domain
    model = domain.model
    s = domain.initial_conditions()
    ev, ns = Evaluation(model), NewtonSystem(model)
    axis = model.force_elements.par[0, 6:15].reshape(3, 3)[:, 2]  # u3 of the spring's frame on body 0
    q, angle = s.q.copy(), np.zeros(model.force_elements.kind.shape[0])
    N, m = s.x.shape[0], model.n_constraints
    for _ in range(23):
        q[0] = qmul(q[0], qexp(0.7 * axis))
        U = ns.evaluate(s.x, q, s.v, s.w, np.zeros((N, 6)), np.zeros(m), 0.0, True)
        _, _, U_plain, _ = ev.forces(s.x, q, s.v, s.w, 0.0, angle)
        close(angle, ns.work.angle, "angles")
        close(U_plain, U, "U")
    assert abs(abs(angle[0]) - 23 * 0.7) <= 1e-9
