"""Park's two-stage staggered explicit central difference (paper §3.3).

One step from ``t_n`` to ``t_{n+1}`` (docs/formulation.md §6, "Park's two-stage
staggered step"; the staging is a reconstruction, the originals of Park, Chiou
& Downer 1990 not being at hand):

1. forces at ``t_n`` (:func:`reference.evaluation.forces.generalized_forces`):
   internal ``S`` (every element family, and the force elements of
   :mod:`reference.forces`, their dampers at ``V^{n−½}``), external ``F`` (dead
   and follower loads × time functions, gravity, actuators); damping
   ``−c m v``, ``−c J ω`` in the kick;
2. **kick** (explicit predictor) of the half-step velocities,
   ``v* = v^{n−½} + h m⁻¹(F − S_u)`` and, in the body frame,
   ``J(ω* − ω^{n−½}) = h (M_b − S_θ − ω̄ × J ω̄)``,
   ``ω̄ = ½(ω^{n−½} + ω*)`` solved by fixed-point sweeps (this midpoint
   gyroscopic term keeps the kinetic energy of a free rigid body; the fully
   explicit one drifts by percents);
2b. **constraint forces** (implicit stage, :func:`reference.algorithms.constraint_stage.constrain`): the joints'
   Φ, Φ_t and B at t_n, the stabilised multipliers λ^n and ``V^{n+½} = V* − h M⁻¹ Bᵀ λ^n``
   (``reference/joints/assembly.py``), each joint formulation's own projection;
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
from typing import NamedTuple

import numpy as np

from reference.algorithms.base import Algorithm, CallBudget
from reference.algorithms.constraint_stage import CONSTRAINED_SWEEPS, constrain
from reference.algorithms.staggered_nodes import SUMS, drift_nodes, kick_nodes, node_sums
from reference.evaluation.force_elements import force_element_dissipation
from reference.evaluation.forces import model_forces
from reference.jit import boundary, inlined, kernel, named, use_threads
from reference.joints.assembly import constraint_power, jacobian_times
from reference.joints.master_slave import master_slave_positions
from reference.monitor import TOLERANCE as GUARD_TOLERANCE, BlowUpMonitor, likely_cause
from reference.parallel import n_chunks
from reference.state import Model, Record, Scratch, State
from reference.status import BLOWUP, DIVERGED, OK, SINGULAR, explicit_failure

GYRO_SWEEPS = 4
"""Most fixed-point sweeps of the midpoint gyroscopic term (contraction factor
≈ h|ω|, so four sweeps reach round-off for h|ω| ≲ 1e-3)."""


@inlined
def _kinetic(model, v, w):
    T = 0.0
    mass, J = model.nodes.mass, model.nodes.inertia
    for i in range(v.shape[0]):
        T += 0.5 * mass[i] * (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
        for a in range(3):
            for b in range(3):
                T += 0.5 * w[i, a] * J[i, a, b] * w[i, b]
    return T


@inlined
def _balance(T, P_old, P_new, h, P_drive, mean, U, clock, guard):
    """The energy-balance guard of one step (:mod:`reference.monitor`): ``True`` when
    ``E − E₀ − W + D > tolerance × S + h (|F·V⁻| + |F·V⁺| + |P_drive|)`` (energy gained
    that no force put in; energy lost, e.g. to the constraint stabilisation, is no blow-up)
    and ``E − E₀ > tolerance × S`` (the energy itself has grown).  E is the kinetic
    energy ``T`` at the integer-step velocities plus the strain energy ``U``; W and D come from
    the ``clock`` record; S is the largest ``|E₀| + |W| + |D|`` so far; the last term, a step of the
    external power ``F`` at the half-step velocities V⁻ (``P_old``) and V⁺ (``P_new``) and of the
    constraint forces' power ``P_drive``, covers the half-step lag or lead of the work behind or
    ahead of E (the sums: :func:`~reference.algorithms.staggered_nodes.node_sums`).
    ``guard`` the :data:`reference.state.GUARD` record."""
    E = T + U
    if not mean:  # the first step: E₀ only
        guard["E0"] = E
        guard["scale"] = max(guard["scale"], abs(E))  # S starts at the round-off floor (monitor.energy_floor)
        return False
    guard["scale"] = max(guard["scale"], abs(guard["E0"]) + abs(clock["work"]) + abs(clock["dissipated"]))
    r = E - guard["E0"] - clock["work"] + clock["dissipated"]
    guard["residual"], guard["energy"] = r, E
    # the energy itself must have grown too: negative work at round-off level on a held model
    # (W ≈ −1e-20, E = 0) is no blow-up
    allowed = guard["tolerance"] * guard["scale"]
    return r > allowed + h * (abs(P_old) + abs(P_new) + abs(P_drive)) and E - guard["E0"] > allowed


@kernel
def _record(model, scratch, rec, state, first, U, dD_fe):
    """The output record at ``t_n``: integer-step velocities (the mean of the two half-step ones of ``state``
    and ``scratch``, the initial ones at the ``first`` step), energies (``U`` the strain energy [J], ``dD_fe``
    the energy the kick dissipates [J]) and constraint residuals, multipliers."""
    x, q, v, w, clock = state.x, state.q, state.v, state.w, state.clock[0]
    v_new, w_new, n_rows = scratch.v_new, scratch.w_new, scratch.PHI.shape[0]
    N = x.shape[0]
    for i in range(N):
        for a in range(3):
            rec.x[i, a] = x[i, a]
            rec.v[i, a] = v[i, a] if first else 0.5 * (v[i, a] + v_new[i, a])
            rec.w[i, a] = w[i, a] if first else 0.5 * (w[i, a] + w_new[i, a])
        for a in range(4):
            rec.q[i, a] = q[i, a]
    rec.energy[0] = _kinetic(model, rec.v, rec.w)
    rec.energy[1] = U
    rec.energy[2] = clock["work"]
    rec.energy[3] = clock["dissipated"] + (0.0 if first else 0.5 * dD_fe)
    rec.constraint[0] = 0.0
    rec.constraint[1] = 0.0
    PHI, PHIt, lam, work = scratch.PHI, scratch.PHIt, scratch.lam, scratch.work
    if n_rows > 0:
        jacobian_times(model, scratch.Bj, rec.v, rec.w, work)
    for r in range(n_rows):
        res = PHIt[r] + work[r]
        rec.constraint[0] += PHI[r] ** 2
        rec.constraint[1] += res**2
        rec.lam[r] = lam[r]
    rec.constraint[0] = math.sqrt(rec.constraint[0])
    rec.constraint[1] = math.sqrt(rec.constraint[1])


@kernel
def advance(model, state, h, n_steps, record, rec, scratch):
    """Advance ``state`` in place by ``n_steps`` steps of size ``h``: forces, kick, constrain, drift.

    If ``record`` is true, the output record at the starting time ``t_n`` is
    written into ``rec`` (its integer-step velocities need the first kick).
    ``n_steps = 0`` with ``record`` only writes the record.  Returns ``OK``,
    ``DIVERGED`` (non-finite state, checked before the energy guard: the state is left at the last finite step),
    ``SINGULAR`` (the constraint matrix lost rank) or ``BLOWUP`` (the energy guard).  ``model``, ``state``,
    ``rec`` and ``scratch`` are the named tuples or their :func:`reference.jit.boundary` copies, which a call
    from Python unboxes faster (:class:`ExplicitRun` keeps them).
    """
    model, state, rec, scratch = named(model, Model), named(state, State), named(rec, Record), named(scratch, Scratch)
    x, q, v, w, f_prev = state.x, state.q, state.v, state.w, state.f_prev
    clock, guard = state.clock[0], scratch.guard[0]
    S, F, v_new, w_new, G = scratch.S, scratch.F, scratch.v_new, scratch.w_new, scratch.G
    n_fe = model.force_elements.kind.shape[0]
    n_rows = scratch.PHI.shape[0]
    n_ms = model.master_slave.master.shape[0]
    part, sums, q_tmp = np.empty((n_chunks(x.shape[0]), SUMS)), np.empty(SUMS), scratch.q_tmp
    for k in range(max(n_steps, 1)):
        t, n = clock["t"], clock["n"]
        # dampers of the force elements at V^{n−½}
        U, _ = model_forces(model.nodes.mass, model.gravity, model.loads, model.time_functions, model.elements,
                            model.force_elements, scratch.elements, x, q, v, w, t, S, F, G, state.angle,
                            scratch.A, scratch.prim_phi, scratch.prim_B)
        hk = h if n > 0 else 0.5 * h
        # a node outside every joint keeps its predicted velocity through the constrained passes
        # below, which would only add gyroscopic sweeps to it: it gets all of them at once
        kick_nodes(model.nodes, model.damping, v, w, S, F, hk, v_new, w_new, GYRO_SWEEPS,
                   CONSTRAINED_SWEEPS if n_rows > 0 or n_ms > 0 else 0)
        if (n_rows > 0 or n_ms > 0) and constrain(model, scratch, state, t, h, hk) != OK:
            return SINGULAR
        c = model.damping
        node_sums(model.nodes, v, w, v_new, w_new, F, f_prev, c != 0.0, guard["tolerance"] > 0.0, n > 0, part, sums)
        if n > 0:  # the trapezoidal work of the external forces over the increment into t_n
            clock["work"] += h * sums[0]
        # energy removed by the damping (mass-proportional and the force elements' dampers) in this
        # kick: force at V^{n−½} times the mean velocity; t_n (integer-step velocities) gets half
        dD_fe = hk * c * sums[1] if c != 0.0 else 0.0
        if n_fe > 0:
            dD_fe += hk * force_element_dissipation(model, x, q, v, w, v_new, w_new, scratch.prim_phi,
                                                    scratch.prim_B)
        if record and k == 0:
            _record(model, scratch, rec, state, n == 0, U, dD_fe)
        if n_steps == 0:
            break
        if not math.isfinite(sums[5]):  # a new velocity is not finite: the state stays at the last finite step
            return DIVERGED
        P_drive = 0.0
        if n_rows > 0:
            # work of the constraint forces (the driving motions) over [t_{n−½}, t_{n+½}]
            P_drive = constraint_power(model, scratch.Bj, scratch.lam, v, w, v_new, w_new)
            clock["work"] += hk * P_drive
        clock["dissipated"] += 0.5 * dD_fe
        if guard["tolerance"] > 0.0 and _balance(sums[2], sums[3], sums[4], h, P_drive, n > 0, U, clock, guard):
            return BLOWUP
        clock["dissipated"] += 0.5 * dD_fe
        drift_nodes(x, q, v, w, v_new, w_new, f_prev, F, h)
        if n_ms > 0:
            master_slave_positions(model, x, q, scratch.A_m, scratch.A_s, q_tmp, scratch.r4)
        clock["n"] = n + 1
        clock["t"] = (n + 1) * h
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

    def start(self, model, state, critical_step=math.inf, guard=None) -> "ExplicitRun":
        """The run state: the step's work arrays (:class:`~reference.state.Scratch`) with the per-step
        energy guard on when ``guard`` (the energy scale's round-off floor [J],
        :func:`reference.monitor.energy_floor`) is given, and the critical step for the messages."""
        scratch = Scratch.for_model(model)
        if guard is not None:
            scratch.guard[0]["scale"], scratch.guard[0]["tolerance"] = guard, GUARD_TOLERANCE
        spare = Record.empty(state.x.shape[0], model.n_constraints)
        return ExplicitRun(scratch, float(critical_step), CallBudget(), spare, [])

    def failure(self, code, state, run):
        status, message = explicit_failure(code, state.t, likely_cause(self.dt, run.critical_step))
        return status, message + BlowUpMonitor.guard_report(run.scratch.guard[0], state.work)

    def advance(self, model: Model, state: State, run: "ExplicitRun", n_steps: int, record: Record | None) -> int:
        """``n_steps`` steps in compiled calls of at most ``run.budget`` steps (each returns to Python within a
        fraction of a second: a signal stops the run between two); the same steps as one call, bit for bit."""
        plain_model, plain_state, rec, scratch = run.arguments(model, state, record)
        use_threads(nodes=state.x.shape[0])
        left, write = int(n_steps), record is not None
        while True:
            size = min(left, run.budget.start())
            code = advance(plain_model, plain_state, self.dt, size, write, rec, scratch)
            run.budget.took(size)
            left -= size
            if code != OK or left <= 0:
                return code
            write = False


class ExplicitRun(NamedTuple):
    """The staggered scheme's run state: its work arrays and energy guard, the Domain's critical
    step estimate [s] (for the message of a blow-up), the steps a compiled call may take, the record a call
    without output writes into (``spare``) and the step kernel's last arguments (``plain``,
    :meth:`arguments`)."""

    scratch: Scratch
    critical_step: float
    budget: CallBudget
    spare: Record
    plain: list

    def arguments(self, model: Model, state: State, record: Record | None) -> tuple:
        """``(model, state, record, scratch)`` as the step kernel takes them, :func:`reference.jit.boundary`
        copies of the same arrays, made again only for another model, state or record (``record`` None: the
        spare one)."""
        record = self.spare if record is None else record
        known = self.plain
        if not (known and known[0] is model and known[1] is state and known[2] is record):
            known[:] = [model, state, record,
                        (boundary(model), boundary(state), boundary(record), boundary(self.scratch))]
        return known[3]

    @property
    def energy(self) -> float:
        """Kinetic + strain energy at the last guarded step [J]."""
        return float(self.scratch.guard[0]["energy"])


def step(model: Model, state: State, h: float) -> State:
    """One staggered step as a pure function: returns the state at ``t_{n+1}``."""
    new = state.copy()
    use_threads(nodes=new.x.shape[0])
    status = advance(boundary(model), boundary(new), h, 1, False,
                     boundary(Record.empty(new.x.shape[0], model.n_constraints)), boundary(Scratch.for_model(model)))
    if status != OK:
        raise FloatingPointError(f"the step failed with status {status}")
    return new
