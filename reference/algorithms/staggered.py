"""Park's two-stage staggered explicit central difference (paper §3.3).

One step from ``t_n`` to ``t_{n+1}`` (docs/formulation.md §6, "Park's two-stage
staggered step"; the staging is a reconstruction, the originals of Park, Chiou
& Downer 1990 not being at hand):

1. forces at ``t_n``: internal ``S`` (Beam2 kernel), external ``F`` (dead and
   follower loads × time functions, gravity), damping ``−c m v``, ``−c J ω``;
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
from reference.elements.formulation import beam2_assemble
from reference.generated import rotation_maps as rm
from reference.interactions import tf_value
from reference.jit import kernel
from reference.joints.assembly import (
    SINGULAR, assemble_constraints, constraint_impulse, constraint_power, factor_constraints,
)
from reference.joints.master_slave import master_slave_positions, master_slave_project
from reference.state import Model, Record, Scratch, State

GYRO_SWEEPS = 4
"""Fixed-point sweeps of the midpoint gyroscopic term (contraction factor
≈ h|ω|, so four sweeps reach round-off for h|ω| ≲ 1e-3)."""

CONSTRAINED_SWEEPS = 3
"""Extra (kick, projection) passes when there are joints (contraction ≈ h|ω|)."""

OK, DIVERGED = 0, 1
"""Status codes of :func:`advance`; ``SINGULAR`` (2, from the joint assembly) means
the constraint matrix lost rank (redundant or degenerate joints)."""


@kernel
def external_forces(model, x, q, t, F, A):
    """External generalised forces at time t into ``F`` (N,6): inertial force, body moment."""
    F[:, :] = 0.0
    g = model.gravity
    for i in range(F.shape[0]):
        for k in range(3):
            F[i, k] = model.mass[i] * g[k]
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


@kernel
def _kick(model, v, w, S, F, hk, v_new, w_new, sweeps, from_guess):
    """Explicit predictor of the half-step velocities (stage 2), fixed coordinates kept at rest.

    The midpoint gyroscopic term is solved by ``sweeps`` fixed-point sweeps
    starting from ``w`` or, if ``from_guess``, from the current ``w_new`` (the
    constrained velocities of the previous pass, see :func:`advance`).
    """
    c = model.damping
    for i in range(v.shape[0]):
        m = model.mass[i]
        for k in range(3):
            v_new[i, k] = model.free[i, k] * (v[i, k] + hk * ((F[i, k] - S[i, k]) / m - c * v[i, k]))
        J = model.inertia[i]
        Jinv = model.inertia_inv[i]
        w0, w1, w2 = w[i, 0], w[i, 1], w[i, 2]
        r0, r1, r2 = F[i, 3] - S[i, 3], F[i, 4] - S[i, 4], F[i, 5] - S[i, 5]
        # damping moment −c J ω at the old half step
        r0 -= c * (J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2)
        r1 -= c * (J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2)
        r2 -= c * (J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2)
        n0, n1, n2 = w0, w1, w2
        if from_guess:
            n0, n1, n2 = w_new[i, 0], w_new[i, 1], w_new[i, 2]
        for _ in range(sweeps):
            b0, b1, b2 = 0.5 * (w0 + n0), 0.5 * (w1 + n1), 0.5 * (w2 + n2)
            j0 = J[0, 0] * b0 + J[0, 1] * b1 + J[0, 2] * b2
            j1 = J[1, 0] * b0 + J[1, 1] * b1 + J[1, 2] * b2
            j2 = J[2, 0] * b0 + J[2, 1] * b1 + J[2, 2] * b2
            g0 = r0 - (b1 * j2 - b2 * j1)
            g1 = r1 - (b2 * j0 - b0 * j2)
            g2 = r2 - (b0 * j1 - b1 * j0)
            n0 = model.free[i, 3] * (w0 + hk * (Jinv[0, 0] * g0 + Jinv[0, 1] * g1 + Jinv[0, 2] * g2))
            n1 = model.free[i, 4] * (w1 + hk * (Jinv[1, 0] * g0 + Jinv[1, 1] * g1 + Jinv[1, 2] * g2))
            n2 = model.free[i, 5] * (w2 + hk * (Jinv[2, 0] * g0 + Jinv[2, 1] * g1 + Jinv[2, 2] * g2))
        w_new[i, 0], w_new[i, 1], w_new[i, 2] = n0, n1, n2


@kernel
def _kinetic(model, v, w):
    T = 0.0
    for i in range(v.shape[0]):
        J = model.inertia[i]
        T += 0.5 * model.mass[i] * (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
        for a in range(3):
            for b in range(3):
                T += 0.5 * w[i, a] * J[a, b] * w[i, b]
    return T


@kernel
def advance(model, state, h, n_steps, record, rec, scratch):
    """Advance ``state`` in place by ``n_steps`` steps of size ``h``.

    If ``record`` is true, the output record at the starting time ``t_n`` is
    written into ``rec`` (its integer-step velocities need the first kick).
    ``n_steps = 0`` with ``record`` only writes the record.  Returns ``OK``,
    ``DIVERGED`` (non-finite state: the state is left at the last finite step)
    or ``SINGULAR`` (the constraint matrix lost rank).
    """
    x, q, v, w, f_prev, clock = state
    S, F, v_new, w_new, s_el = scratch.S, scratch.F, scratch.v_new, scratch.w_new, scratch.s_el
    q_tmp, A = scratch.q_tmp, scratch.A
    PHI, PHIt, Bg, BM, W, lam = scratch.PHI, scratch.PHIt, scratch.Bg, scratch.BM, scratch.W, scratch.lam
    N = x.shape[0]
    n_rows = PHI.shape[0]
    n_ms = model.ms_master.shape[0]
    c = model.damping
    for k in range(max(n_steps, 1)):
        t, n = clock[0], clock[1]
        U = beam2_assemble(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff, S, s_el)
        external_forces(model, x, q, t, F, A)
        if n > 0:
            # trapezoidal work of the external forces over the last increment h V^{n-1/2},
            # and the energy dissipated by the damping forces evaluated at V^{n-1/2}
            dW = 0.0
            dD = 0.0
            for i in range(N):
                J = model.inertia[i]
                for a in range(3):
                    dW += 0.5 * (f_prev[i, a] + F[i, a]) * v[i, a] + 0.5 * (f_prev[i, 3 + a] + F[i, 3 + a]) * w[i, a]
                    dD += model.mass[i] * v[i, a] * v[i, a] * model.free[i, a]
                    for b in range(3):
                        dD += w[i, a] * J[a, b] * w[i, b] * model.free[i, 3 + a]
            clock[2] += h * dW
            clock[3] += h * c * dD
        hk = h if n > 0 else 0.5 * h
        _kick(model, v, w, S, F, hk, v_new, w_new, GYRO_SWEEPS, False)
        if n_rows > 0:
            assemble_constraints(model, x, q, t, PHI, PHIt, Bg, scratch.jphi, scratch.jB, scratch.jphit,
                                 scratch.prim_phi, scratch.prim_B)
            if factor_constraints(model, Bg, BM, W, h, hk) != OK:
                return SINGULAR
        if n_rows > 0 or n_ms > 0:
            # The constraint stage changes ω^{n+½}: redo the predictor with the midpoint
            # gyroscopic term at the constrained velocity and constrain again (same factor),
            # so that the pair (kick, constraint) is solved together (otherwise the gyroscopic
            # term of a constrained spinning body is only first-order accurate).  With both
            # multiplier and master/slave joints the passes also alternate the two projections.
            for sweep in range(1 + CONSTRAINED_SWEEPS):
                if sweep > 0:
                    _kick(model, v, w, S, F, hk, v_new, w_new, 1, True)
                if n_rows > 0:
                    constraint_impulse(model, Bg, BM, W, PHI, PHIt, v_new, w_new, h, hk, lam)
                if n_ms > 0:
                    master_slave_project(model, q, v_new, w_new, scratch.T, scratch.A_m, scratch.A_s, scratch.MT,
                                         scratch.TMT, scratch.rhs)
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
            rec.energy[3] = clock[3]
            rec.constraint[0] = 0.0
            rec.constraint[1] = 0.0
            for r in range(n_rows):
                res = PHIt[r]
                for i in range(N):
                    for a in range(3):
                        res += Bg[r, 6 * i + a] * rec.v[i, a] + Bg[r, 6 * i + 3 + a] * rec.w[i, a]
                rec.constraint[0] += PHI[r] ** 2
                rec.constraint[1] += res**2
                rec.lam[r] = lam[r]
            rec.constraint[0] = math.sqrt(rec.constraint[0])
            rec.constraint[1] = math.sqrt(rec.constraint[1])
        if n_steps == 0:
            break
        if n_rows > 0:
            # work of the constraint forces (the driving motions) over [t_{n−½}, t_{n+½}]
            clock[2] += hk * constraint_power(model, Bg, lam, v, w, v_new, w_new)
        for i in range(N):
            for a in range(3):
                if not math.isfinite(v_new[i, a]) or not math.isfinite(w_new[i, a]):
                    return DIVERGED
        for i in range(N):
            for a in range(3):
                v[i, a] = v_new[i, a]
                w[i, a] = w_new[i, a]
                x[i, a] += h * v_new[i, a]
            rm.cayley_update(q[i], w_new[i], h, q_tmp)
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
        return (f"diverged after t = {t_last:.6g}",
                f"the solution became non-finite after t = {t_last:.6g}; results up to that time are kept. "
                f"Reduce dt below the critical estimate {domain.critical_time_step():.3g} or check the loads.")

    def advance(self, model: Model, state: State, n_steps: int, record: Record | None, scratch: Scratch) -> int:
        rec = record if record is not None else Record.empty(state.x.shape[0], model.n_constraints)
        return advance(model, state, self.dt, int(n_steps), record is not None, rec, scratch)


def step(model: Model, state: State, h: float) -> State:
    """One staggered step as a pure function: returns the state at ``t_{n+1}``."""
    new = state.copy()
    status = advance(model, new, h, 1, False, Record.empty(new.x.shape[0], model.n_constraints),
                     Scratch.for_model(model))
    if status != OK:
        raise FloatingPointError(f"the step failed with status {status}")
    return new
