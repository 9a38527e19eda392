"""Park's two-stage staggered explicit central difference (paper §3.3).

One step from ``t_n`` to ``t_{n+1}`` (docs/formulation.md §6, "Park's two-stage
staggered step"; the staging is a reconstruction, the originals of Park, Chiou
& Downer 1990 not being at hand):

1. forces at ``t_n``: internal ``S`` (Beam2 kernel, and the force elements of
   :mod:`reference.forces`, their dampers at ``V^{n−½}``), external ``F`` (dead
   and follower loads × time functions, gravity, actuators), damping
   ``−c m v``, ``−c J ω``;
2. **kick** (explicit predictor) of the half-step velocities,
   ``v* = v^{n−½} + h m⁻¹(F − S_u)`` and, in the body frame,
   ``J(ω* − ω^{n−½}) = h (M_b − S_θ − ω̄ × J ω̄)``,
   ``ω̄ = ½(ω^{n−½} + ω*)`` solved by fixed-point sweeps (this midpoint
   gyroscopic term keeps the kinetic energy of a free rigid body; the fully
   explicit one drifts by percents);
2b. **constraint forces** (implicit stage): the joints' Φ, Φ_t and B at t_n,
   the stabilised multipliers λ^n and ``V^{n+½} = V* − h M⁻¹ Bᵀ λ^n``
   (``reference/joints/assembly.py``);
3. **drift**: ``x^{n+1} = x^n + h v^{n+½}`` and the Euler parameters by the
   trapezoidal rule, ``q^{n+1} = q^n ⊗ p(h ω^{n+½})`` (closed-form Cayley
   factor, exactly unit).

Start-up: the first kick uses ``h/2`` (from the initial velocities at ``t_0``).
Integer-step velocities for output are the mean of the two half-step ones.

The step is written once, in the compiled :func:`advance`; :func:`step` is its
one-step, pure-function face for tests and teaching.
"""

from __future__ import annotations

import math


from reference.algorithms.base import Algorithm
from reference.elements.formulation import beam2_assemble_parallel
from reference.forces import force_element_dissipation, force_element_forces
from reference.generated import rotation_maps as rm
from reference.interactions import tf_value
from reference.jit import inlined, kernel, use_threads
from reference.joints.assembly import (
    SINGULAR, assemble_constraints, constraint_impulse, constraint_power, factor_constraints, jacobian_times,
)
from reference.joints.master_slave import master_slave_positions, master_slave_project
from reference.monitor import damping_dissipation, likely_cause
from reference.state import Model, Record, Scratch, State

_cayley_update = inlined(rm.cayley_update)

GYRO_SWEEPS = 4
"""Most fixed-point sweeps of the midpoint gyroscopic term (contraction factor
≈ h|ω|, so four sweeps reach round-off for h|ω| ≲ 1e-3)."""

SWEEP_TOLERANCE = 2.0**-52
"""The sweeps stop early once a sweep changes ω by less than this relative to |ω| (round-off):
a slowly turning node (h|ω| ≲ 1e-8, most nodes of a beam) needs two."""

CONSTRAINED_SWEEPS = 3
"""Extra (kick, projection) passes when there are joints (contraction ≈ h|ω|)."""

OK, DIVERGED, BLOWUP = 0, 1, 3
"""Status codes of :func:`advance`; ``SINGULAR`` (2, from the joint assembly) means
the constraint matrix lost rank (redundant or degenerate joints); ``BLOWUP`` that the
energy balance failed (:attr:`reference.state.Scratch.guard`)."""


@inlined
def external_forces(model, x, q, t, F, A):
    """External generalised forces at time t into ``F`` (N,6): inertial force, body moment.

    A force applied at a body-fixed point (``model.load_arm`` ≠ 0) adds its
    moment ``arm × force`` (body frame) about the node.
    """
    g0, g1, g2 = model.gravity[0], model.gravity[1], model.gravity[2]
    mass = model.mass
    for i in range(F.shape[0]):
        F[i, 0], F[i, 1], F[i, 2] = mass[i] * g0, mass[i] * g1, mass[i] * g2
        F[i, 3], F[i, 4], F[i, 5] = 0.0, 0.0, 0.0
    for l in range(model.load_node.shape[0]):
        i = model.load_node[l]
        j = model.load_tf[l]
        f = tf_value(model.tf_kind[j], model.tf_par[j], t)
        code = model.load_code[l]
        vec = model.load_vec[l]
        if code == 0:
            for k in range(3):
                F[i, k] += f * vec[k]
        elif code == 3:
            for k in range(3):
                F[i, 3 + k] += f * vec[k]
        else:
            rm.rotation_matrix(q[i], A)
            if code == 1:  # follower force: inertial = A f_body
                for k in range(3):
                    F[i, k] += f * (A[3 * k] * vec[0] + A[3 * k + 1] * vec[1] + A[3 * k + 2] * vec[2])
            else:  # dead moment: body = A^T M
                for k in range(3):
                    F[i, 3 + k] += f * (A[k] * vec[0] + A[3 + k] * vec[1] + A[6 + k] * vec[2])
        arm = model.load_arm[l]
        if code <= 1 and (arm[0] != 0.0 or arm[1] != 0.0 or arm[2] != 0.0):
            if code == 0:  # body components of the dead force
                rm.rotation_matrix(q[i], A)
                b0 = f * (A[0] * vec[0] + A[3] * vec[1] + A[6] * vec[2])
                b1 = f * (A[1] * vec[0] + A[4] * vec[1] + A[7] * vec[2])
                b2 = f * (A[2] * vec[0] + A[5] * vec[1] + A[8] * vec[2])
            else:
                b0, b1, b2 = f * vec[0], f * vec[1], f * vec[2]
            F[i, 3] += arm[1] * b2 - arm[2] * b1
            F[i, 4] += arm[2] * b0 - arm[0] * b2
            F[i, 5] += arm[0] * b1 - arm[1] * b0


@inlined
def _kick(model, v, w, S, F, hk, v_new, w_new, sweeps, from_guess, extra_free_sweeps, only_constrained):
    """Explicit predictor of the half-step velocities (stage 2), fixed coordinates kept at rest.

    The midpoint gyroscopic term is solved by ``sweeps`` fixed-point sweeps
    starting from ``w`` or, if ``from_guess``, from the current ``w_new`` (the
    constrained velocities of the previous pass, see :func:`advance`); nodes of
    no joint get ``extra_free_sweeps`` more.  ``only_constrained``: visit only
    the nodes of joints (``model.constrained_nodes``).
    """
    # the model's arrays bound once: a field read inside the loop costs two atomic reference-count
    # updates per iteration (numba), and a row view (J[i]) as many
    c, J, Jinv, free, mass = model.damping, model.inertia, model.inertia_inv, model.free, model.mass
    constrained_nodes, node_constrained = model.constrained_nodes, model.node_constrained
    count = constrained_nodes.shape[0] if only_constrained else v.shape[0]
    for p in range(count):
        i = constrained_nodes[p] if only_constrained else p
        n_sweeps = sweeps if node_constrained[i] else sweeps + extra_free_sweeps
        m_inv = 1.0 / mass[i]
        for k in range(3):
            v_new[i, k] = free[i, k] * (v[i, k] + hk * ((F[i, k] - S[i, k]) * m_inv - c * v[i, k]))
        w0, w1, w2 = w[i, 0], w[i, 1], w[i, 2]
        r0, r1, r2 = F[i, 3] - S[i, 3], F[i, 4] - S[i, 4], F[i, 5] - S[i, 5]
        if c != 0.0:  # damping moment −c J ω at the old half step
            r0 -= c * (J[i, 0, 0] * w0 + J[i, 0, 1] * w1 + J[i, 0, 2] * w2)
            r1 -= c * (J[i, 1, 0] * w0 + J[i, 1, 1] * w1 + J[i, 1, 2] * w2)
            r2 -= c * (J[i, 2, 0] * w0 + J[i, 2, 1] * w1 + J[i, 2, 2] * w2)
        n0, n1, n2 = w0, w1, w2
        if from_guess:
            n0, n1, n2 = w_new[i, 0], w_new[i, 1], w_new[i, 2]
        # a principal-axes inertia (every node of a straight beam) needs a third of the products
        diagonal = J[i, 0, 1] == 0.0 and J[i, 0, 2] == 0.0 and J[i, 1, 2] == 0.0 and J[i, 1, 0] == 0.0 and \
            J[i, 2, 0] == 0.0 and J[i, 2, 1] == 0.0 and Jinv[i, 0, 1] == 0.0 and Jinv[i, 0, 2] == 0.0 and \
            Jinv[i, 1, 2] == 0.0 and Jinv[i, 1, 0] == 0.0 and Jinv[i, 2, 0] == 0.0 and Jinv[i, 2, 1] == 0.0
        for sweep in range(n_sweeps):
            b0, b1, b2 = 0.5 * (w0 + n0), 0.5 * (w1 + n1), 0.5 * (w2 + n2)
            if diagonal:
                j0, j1, j2 = J[i, 0, 0] * b0, J[i, 1, 1] * b1, J[i, 2, 2] * b2
            else:
                j0 = J[i, 0, 0] * b0 + J[i, 0, 1] * b1 + J[i, 0, 2] * b2
                j1 = J[i, 1, 0] * b0 + J[i, 1, 1] * b1 + J[i, 1, 2] * b2
                j2 = J[i, 2, 0] * b0 + J[i, 2, 1] * b1 + J[i, 2, 2] * b2
            g0 = r0 - (b1 * j2 - b2 * j1)
            g1 = r1 - (b2 * j0 - b0 * j2)
            g2 = r2 - (b0 * j1 - b1 * j0)
            if diagonal:
                m0 = free[i, 3] * (w0 + hk * (Jinv[i, 0, 0] * g0))
                m1 = free[i, 4] * (w1 + hk * (Jinv[i, 1, 1] * g1))
                m2 = free[i, 5] * (w2 + hk * (Jinv[i, 2, 2] * g2))
            else:
                m0 = free[i, 3] * (w0 + hk * (Jinv[i, 0, 0] * g0 + Jinv[i, 0, 1] * g1 + Jinv[i, 0, 2] * g2))
                m1 = free[i, 4] * (w1 + hk * (Jinv[i, 1, 0] * g0 + Jinv[i, 1, 1] * g1 + Jinv[i, 1, 2] * g2))
                m2 = free[i, 5] * (w2 + hk * (Jinv[i, 2, 0] * g0 + Jinv[i, 2, 1] * g1 + Jinv[i, 2, 2] * g2))
            # converged to round-off: a further sweep would change nothing
            done = sweep > 0 and abs(m0 - n0) + abs(m1 - n1) + abs(m2 - n2) <= \
                SWEEP_TOLERANCE * (abs(m0) + abs(m1) + abs(m2))
            n0, n1, n2 = m0, m1, m2
            if done:
                break
        w_new[i, 0], w_new[i, 1], w_new[i, 2] = n0, n1, n2


@inlined
def _kinetic(model, v, w):
    T = 0.0
    mass, J = model.mass, model.inertia
    for i in range(v.shape[0]):
        T += 0.5 * mass[i] * (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
        for a in range(3):
            for b in range(3):
                T += 0.5 * w[i, a] * J[i, a, b] * w[i, b]
    return T


@inlined
def _balance(model, v, w, v_new, w_new, F, h, P_drive, mean, U, clock, guard):
    """The energy-balance guard of one step (:mod:`reference.monitor`): ``True`` when
    ``E − E₀ − W + D > tolerance × S + h (|F·V⁻| + |F·V⁺| + |P_drive|)`` (energy gained
    that no force put in; energy lost, e.g. to the constraint stabilisation, is no blow-up)
    and ``E − E₀ > tolerance × S`` (the energy itself has grown).  E is the kinetic
    energy at the integer-step velocities plus the strain energy ``U``; W and D come from
    ``clock``; S is the largest ``|E₀| + |W| + |D|`` so far; the last term, a step of the
    external power ``F`` at the half-step velocities V⁻ (``v``, ``w``) and V⁺ (``v_new``,
    ``w_new``) and of the constraint forces' power ``P_drive``, covers the half-step lag or
    lead of the work behind or ahead of E.
    ``guard`` = [E₀, S, tolerance, residual, E]."""
    c = 0.5 if mean else 1.0
    d = 0.5 if mean else 0.0
    mass, J = model.mass, model.inertia
    T = 0.0
    P_old = 0.0
    P_new = 0.0
    for i in range(v.shape[0]):
        for a in range(3):
            va = c * v[i, a] + d * v_new[i, a]
            T += 0.5 * mass[i] * va * va
            P_old += F[i, a] * v[i, a] + F[i, 3 + a] * w[i, a]
            P_new += F[i, a] * v_new[i, a] + F[i, 3 + a] * w_new[i, a]
            wa = c * w[i, a] + d * w_new[i, a]
            for b in range(3):
                T += 0.5 * wa * J[i, a, b] * (c * w[i, b] + d * w_new[i, b])
    E = T + U
    if not mean:  # the first step: E₀ only
        guard[0] = E
        guard[1] = max(guard[1], abs(E))  # S starts at the round-off floor (monitor.energy_floor)
        return False
    guard[1] = max(guard[1], abs(guard[0]) + abs(clock[2]) + abs(clock[3]))
    r = E - guard[0] - clock[2] + clock[3]
    guard[3], guard[4] = r, E
    # the energy itself must have grown too: negative work at round-off level on a held model
    # (W ≈ −1e-20, E = 0) is no blow-up
    return r > guard[2] * guard[1] + h * (abs(P_old) + abs(P_new) + abs(P_drive)) and E - guard[0] > guard[2] * guard[1]


@kernel
def advance(model, state, h, n_steps, record, rec, scratch):
    """Advance ``state`` in place by ``n_steps`` steps of size ``h``.

    If ``record`` is true, the output record at the starting time ``t_n`` is
    written into ``rec`` (its integer-step velocities need the first kick).
    ``n_steps = 0`` with ``record`` only writes the record.  Returns ``OK``,
    ``DIVERGED`` (non-finite state: the state is left at the last finite step)
    or ``SINGULAR`` (the constraint matrix lost rank).
    """
    x, q, v, w, f_prev, clock = state.x, state.q, state.v, state.w, state.f_prev, state.clock
    S, F, v_new, w_new = scratch.S, scratch.F, scratch.v_new, scratch.w_new
    G = scratch.G
    n_fe = model.fe_kind.shape[0]
    q_tmp, A = scratch.q_tmp, scratch.A
    PHI, PHIt, Bj, BMj, Lx, lam = scratch.PHI, scratch.PHIt, scratch.Bj, scratch.BMj, scratch.Lx, scratch.lam
    work = scratch.work
    N = x.shape[0]
    n_rows = PHI.shape[0]
    n_ms = model.ms_master.shape[0]
    c = model.damping
    for k in range(max(n_steps, 1)):
        t, n = clock[0], clock[1]
        U = beam2_assemble_parallel(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff,
                                    S, scratch.W_el)
        external_forces(model, x, q, t, F, A)
        if n_fe > 0:
            # springs and dampers act like internal forces (S −= their force; energy in U), their
            # actuators like external loads (into F, work counted below); dampers use V^{n−½}
            G[:, :] = 0.0
            U_fe, _ = force_element_forces(model, x, q, v, w, t, state.angle, G, F, scratch.prim_phi,
                                              scratch.prim_B)
            U += U_fe
            for i in range(N):
                for a in range(6):
                    S[i, a] -= G[i, a]
        if n > 0:
            # trapezoidal work of the external forces over the last increment h V^{n-1/2},
            # and the energy dissipated by the damping forces evaluated at V^{n-1/2}
            dW = 0.0
            for i in range(N):
                for a in range(3):
                    dW += 0.5 * (f_prev[i, a] + F[i, a]) * v[i, a] + 0.5 * (f_prev[i, 3 + a] + F[i, 3 + a]) * w[i, a]
            clock[2] += h * dW
        hk = h if n > 0 else 0.5 * h
        # a node outside every joint keeps its predicted velocity through the constrained passes
        # below, which would only add gyroscopic sweeps to it: it gets all of them at once
        _kick(model, v, w, S, F, hk, v_new, w_new, GYRO_SWEEPS, False,
              CONSTRAINED_SWEEPS if n_rows > 0 or n_ms > 0 else 0, False)
        if n_rows > 0:
            assemble_constraints(model, x, q, t, PHI, PHIt, Bj, scratch.prim_phi, scratch.prim_B)
            if factor_constraints(model, Bj, BMj, Lx, work, h, hk) != OK:
                return SINGULAR
        if n_rows > 0 or n_ms > 0:
            # The constraint stage changes ω^{n+½}: redo the predictor with the midpoint
            # gyroscopic term at the constrained velocity and constrain again (same factor),
            # so that the pair (kick, constraint) is solved together (otherwise the gyroscopic
            # term of a constrained spinning body is only first-order accurate).  With both
            # multiplier and master/slave joints the passes also alternate the two projections.
            for sweep in range(1 + CONSTRAINED_SWEEPS):
                if sweep > 0:
                    _kick(model, v, w, S, F, hk, v_new, w_new, 1, True, 0, True)
                if n_rows > 0:
                    constraint_impulse(model, Bj, BMj, Lx, work, PHI, PHIt, v_new, w_new, h, hk, lam)
                if n_ms > 0:
                    master_slave_project(model, q, v_new, w_new, scratch.T, scratch.A_m, scratch.A_s, scratch.MT,
                                         scratch.TMT, scratch.rhs)
        # energy removed by the damping (mass-proportional and the force elements' dampers) in this
        # kick: force at V^{n−½} times the mean velocity; t_n (integer-step velocities) gets half
        dD_fe = hk * c * damping_dissipation(model, v, w, v_new, w_new) if c != 0.0 else 0.0
        if n_fe > 0:
            dD_fe += hk * force_element_dissipation(model, x, q, v, w, v_new, w_new, scratch.prim_phi,
                                                    scratch.prim_B)
        if record and k == 0:
            for i in range(N):
                for a in range(3):
                    rec.x[i, a] = x[i, a]
                    rec.v[i, a] = 0.5 * (v[i, a] + v_new[i, a]) if n > 0 else v[i, a]
                    rec.w[i, a] = 0.5 * (w[i, a] + w_new[i, a]) if n > 0 else w[i, a]
                for a in range(4):
                    rec.q[i, a] = q[i, a]
            rec.energy[0] = _kinetic(model, rec.v, rec.w)
            rec.energy[1] = U
            rec.energy[2] = clock[2]
            rec.energy[3] = clock[3] + (0.5 * dD_fe if n > 0 else 0.0)
            rec.constraint[0] = 0.0
            rec.constraint[1] = 0.0
            if n_rows > 0:
                jacobian_times(model, Bj, rec.v, rec.w, work)
            for r in range(n_rows):
                res = PHIt[r] + work[r]
                rec.constraint[0] += PHI[r] ** 2
                rec.constraint[1] += res**2
                rec.lam[r] = lam[r]
            rec.constraint[0] = math.sqrt(rec.constraint[0])
            rec.constraint[1] = math.sqrt(rec.constraint[1])
        if n_steps == 0:
            break
        P_drive = 0.0
        if n_rows > 0:
            # work of the constraint forces (the driving motions) over [t_{n−½}, t_{n+½}]
            P_drive = constraint_power(model, Bj, lam, v, w, v_new, w_new)
            clock[2] += hk * P_drive
        clock[3] += 0.5 * dD_fe
        if scratch.guard[2] > 0.0 and _balance(model, v, w, v_new, w_new, F, h, P_drive, n > 0, U, clock,
                                               scratch.guard):
            return BLOWUP
        clock[3] += 0.5 * dD_fe
        total = 0.0  # non-finite if any velocity is (or overflows: diverged too)
        for i in range(N):
            for a in range(3):
                total += v_new[i, a] + w_new[i, a]
        if not math.isfinite(total):
            return DIVERGED
        for i in range(N):
            for a in range(3):
                v[i, a] = v_new[i, a]
                w[i, a] = w_new[i, a]
                x[i, a] += h * v_new[i, a]
            _cayley_update(q[i], w_new[i], h, q_tmp)
            nrm = math.sqrt(q_tmp[0] ** 2 + q_tmp[1] ** 2 + q_tmp[2] ** 2 + q_tmp[3] ** 2)
            for a in range(4):
                q[i, a] = q_tmp[a] / nrm
            for a in range(6):
                f_prev[i, a] = F[i, a]
        if n_ms > 0:
            master_slave_positions(model, x, q, scratch.A_m, scratch.A_s, q_tmp, scratch.r4)
        clock[1] = n + 1
        clock[0] = (n + 1) * h
    return OK


class StaggeredCentralDifference(Algorithm):
    """Park's staggered explicit central difference with trapezoidal Euler parameters.

    Parameters
    ----------
    dt : float
        Time step h [s]; must stay below the critical step of the mesh.
    """

    name = "staggered_central_difference"
    explicit = True
    deck_required = ("dt", "t_end")
    deck_optional = ("damping", "output_every", "consistent_initial_velocities", "max_steps", "allow_unsafe_dt")

    @staticmethod
    def refusal(model):
        return None

    def __init__(self, dt: float):
        if not dt > 0.0:
            raise ValueError(f"time step must be positive, got {dt!r}")
        self.dt = float(dt)

    @classmethod
    def from_settings(cls, settings, dt=None):
        return cls(dt or settings.dt)

    def failure(self, code, t_last, domain):
        if code == SINGULAR:
            return (f"singular constraints after t = {t_last:.6g}",
                    f"the constraint matrix became singular after t = {t_last:.6g} "
                    "(redundant or degenerate joints); results up to that time are kept. "
                    "Regularise the joints (epsilon > 0) or remove the redundancy.")
        what = "the energy balance failed" if code == BLOWUP else "the solution became non-finite"
        return (f"diverged after t = {t_last:.6g}",
                f"{what} after t = {t_last:.6g}: {likely_cause(self.dt, domain.critical_time_step())}; "
                "results up to then kept")

    def advance(self, model: Model, state: State, n_steps: int, record: Record | None, scratch: Scratch) -> int:
        rec = record if record is not None else Record.empty(state.x.shape[0], model.n_constraints)
        use_threads()
        return advance(model, state, self.dt, int(n_steps), record is not None, rec, scratch)


def step(model: Model, state: State, h: float) -> State:
    """One staggered step as a pure function: returns the state at ``t_{n+1}``."""
    new = state.copy()
    use_threads()
    status = advance(model, new, h, 1, False, Record.empty(new.x.shape[0], model.n_constraints),
                     Scratch.for_model(model))
    if status != OK:
        raise FloatingPointError(f"the step failed with status {status}")
    return new
