"""Park's staggered step on the reference path: the paper's Fig. 10 ``Solve_at``, one function per stage.

The step of :mod:`reference.algorithms.staggered` (docs/formulation.md §6–§8) written again in plain NumPy
on an :class:`~reference.plain.model.Evaluation`, every node at once.  One step from ``t_n`` to ``t_{n+1}``
of length h, in the paper's order:

1. :func:`forces` — internal ``S`` and external ``F`` (N, 6) at ``t_n`` (the force elements' dampers at
   ``V^{n−½}``);
2. :func:`predict` — the kick (explicit predictor) of the half-step velocities over ``h_k``
   (:func:`kick_length`: h, or h/2 at the first step), ``v* = v + h_k (m⁻¹(F − S_u) − c v)`` and, in the body
   frame, ``J(ω* − ω) = h_k (M_b − S_θ − c J ω − ω̄ × J ω̄)`` with ``ω̄ = ½(ω + ω*)`` by fixed-point sweeps;
3. :func:`constrain` — the constraint stage: the stabilised multipliers (docs/formulation.md §7)
   ``(B M⁻¹ Bᵀ + ε/(h h_k) I) Λ = B V* + Φ_t + Φ/h``, ``λ = Λ/h_k``, and the corrected velocities
   ``V^{n+½} = V* − M⁻¹ Bᵀ Λ`` (the corrected accelerations ``(V^{n+½} − V^{n−½})/h_k``,
   :meth:`Corrected.accelerations`), alternated with the kick at the joints' nodes;
4. the energy bookkeeping, as the compiled step keeps it (``State.clock``: external work W, dissipated D):
   :func:`work_of_loads` into ``t_n``, :func:`damping_loss` of the kick, :func:`power_of_constraints` over
   the kick, and :func:`energy_guard`, the per-step energy balance (:mod:`reference.monitor`);
5. :func:`drift` — ``x^{n+1} = x^n + h v^{n+½}`` and the Euler parameters by the trapezoidal rule,
   ``q^{n+1} = q^n ⊗ p(h ω^{n+½})`` (the generated Cayley factor, normalised).

:func:`solve_step` strings the stages together (and writes the output record at ``t_n``, :func:`record`);
:class:`ReferenceStaggered` is the algorithm that ``[solver] backend = "reference"`` runs in place of
:class:`~reference.algorithms.staggered.StaggeredCentralDifference`: the same ``start``/``advance`` interface,
the same records and status codes.  Where the two paths differ in arithmetic (the order of a sum, the
pivot order of the Cholesky factor) they agree to round-off (tests/test_plain_park.py).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from reference.algorithms.staggered import CONSTRAINED_SWEEPS, GYRO_SWEEPS, StaggeredCentralDifference
from reference.algorithms.staggered_nodes import SWEEP_TOLERANCE
from reference.generated import rotation_maps
from reference.monitor import TOLERANCE as GUARD_TOLERANCE, BlowUpMonitor, likely_cause
from reference.plain.model import Evaluation
from reference.state import GUARD, Record, State
from reference.status import BLOWUP, DIVERGED, OK, SINGULAR, explicit_failure

SINGULAR_PIVOT = 1e-13
"""A pivot of the Cholesky factor of ``B M⁻¹ Bᵀ + ε/(h h_k) I`` at or below this fraction of its largest
diagonal entry means dependent constraint rows (the compiled step's threshold,
:func:`reference.joints.assembly.factor_constraints`)."""

_cayley = getattr(rotation_maps.cayley_update_scalars, "py_func", rotation_maps.cayley_update_scalars)
"""The generated trapezoidal update of the Euler parameters as plain Python (element-wise arithmetic only,
so it takes arrays of all the nodes at once); not numba's dispatcher, which would compile it."""


class Forces(NamedTuple):
    """Stage 1: internal ``S`` and external ``F`` (N, 6) [N, N m] at ``t_n``, strain energy ``U`` [J]."""

    S: np.ndarray
    F: np.ndarray
    U: float


class Velocities(NamedTuple):
    """Half-step velocities, ``v`` (N, 3) inertial [m/s] and ``w`` (N, 3) body frame [rad/s]."""

    v: np.ndarray
    w: np.ndarray


class Corrected(NamedTuple):
    """Stage 3: the velocities ``V^{n+½}`` after the constraint stage, the multipliers ``lam`` (m,) [N or N m]
    and the rows they came from: ``phi``, ``phi_t`` (m,), ``B`` (m, 6N)."""

    v: np.ndarray
    w: np.ndarray
    lam: np.ndarray
    phi: np.ndarray
    phi_t: np.ndarray
    B: sp.csr_matrix

    def accelerations(self, state: State, hk: float) -> np.ndarray:
        """The corrected accelerations ``(V^{n+½} − V^{n−½})/h_k`` (N, 6): ``[v̇ (inertial) | ω̇ (body)]``."""
        return np.hstack([self.v - state.v, self.w - state.w]) / hk


class SingularConstraints(Exception):
    """The constraint matrix ``B M⁻¹ Bᵀ + ε/(h h_k) I`` lost rank (dependent rows and ε = 0)."""


def kick_length(state: State, h: float) -> float:
    """``h_k``: the kick spans h, but h/2 at the first step (from the initial velocities at ``t_0``)."""
    return h if state.n > 0 else 0.5 * h


def forces(ev: Evaluation, state: State) -> Forces:
    """Stage 1 at ``t_n``: the generalised forces of :meth:`Evaluation.forces` (the rotational springs' angles
    carried on in ``state.angle``)."""
    S, F, U, _ = ev.forces(state.x, state.q, state.v, state.w, state.t, state.angle)
    return Forces(S, F, float(U))


def predict(ev: Evaluation, state: State, f: Forces, hk: float, extra: int = 0, nodes=None, start=None) -> Velocities:
    """Stage 2, the kick over ``h_k`` [s]: ``v* = v + h_k (m⁻¹(F − S_u) − c v)`` (inertial) and the body-frame
    ``ω*`` of ``J(ω* − ω) = h_k (M_b − S_θ − c J ω − ω̄ × J ω̄)``, ``ω̄ = ½(ω + ω*)`` (the midpoint gyroscopic
    term keeps a free body's kinetic energy, docs/formulation.md §6), by :data:`GYRO_SWEEPS` fixed-point
    sweeps from ``ω`` (``extra`` more at a node of no joint), each node stopping once a sweep changes it by
    round-off.  A fixed coordinate keeps zero velocity.

    ``nodes`` (index array) and ``start`` (Velocities): kick only those nodes, one sweep from ``start``'s
    ``ω`` there (the constraint stage's passes, :func:`constrain`); the other nodes keep ``start``'s values.
    """
    m, J = ev.masses
    Jinv, free, c = ev.model.nodes.inertia_inv, ev.model.nodes.free, ev.damping
    ids = np.arange(ev.n_nodes) if nodes is None else nodes
    v0, w0, S, F = state.v[ids], state.w[ids], f.S[ids], f.F[ids]
    v = free[ids, :3] * (v0 + hk * ((F[:, :3] - S[:, :3]) / m[ids, None] - c * v0))
    torque = F[:, 3:] - S[:, 3:] - c * np.einsum("nab,nb->na", J[ids], w0)
    if start is None:
        sweeps = np.where(ev.model.nodes.constrained[ids] > 0, GYRO_SWEEPS, GYRO_SWEEPS + extra)
        w = w0.copy()
    else:
        sweeps, w = np.ones(len(ids), dtype=int), start.w[ids].copy()
    done = np.zeros(len(ids), dtype=bool)
    for sweep in range(int(sweeps.max(initial=0))):
        mid = 0.5 * (w0 + w)
        gyro = cross(mid, np.einsum("nab,nb->na", J[ids], mid))
        new = free[ids, 3:] * (w0 + hk * np.einsum("nab,nb->na", Jinv[ids], torque - gyro))
        active = (sweep < sweeps) & ~done
        done |= active & (sweep > 0) & (np.abs(new - w).sum(axis=1) <= SWEEP_TOLERANCE * np.abs(new).sum(axis=1))
        w[active] = new[active]
    if nodes is None:
        return Velocities(v, w)
    out = Velocities(start.v.copy(), start.w.copy())
    out.v[ids], out.w[ids] = v, w
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``a × b`` of two (K, 3) arrays (``np.cross`` moves axes and checks shapes at every call: its
    overhead dominates on the few rows of a step)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def inverse_mass(ev: Evaluation) -> sp.csr_matrix:
    """``M⁻¹`` (6N, 6N): per node ``I₃/m`` and the inverse body-frame inertia, zero at fixed coordinates."""
    m, _ = ev.masses
    free = ev.model.nodes.free
    blocks = np.zeros((ev.n_nodes, 6, 6))
    blocks[:, 0, 0], blocks[:, 1, 1], blocks[:, 2, 2] = (free[:, :3] / m[:, None]).T
    blocks[:, 3:, 3:] = free[:, 3:, None] * ev.model.nodes.inertia_inv * free[:, None, 3:]
    nodes = np.arange(ev.n_nodes)
    return sp.bsr_matrix((blocks, nodes, np.append(nodes, ev.n_nodes)), shape=(6 * ev.n_nodes,) * 2).tocsr()


def constrain(ev: Evaluation, state: State, f: Forces, kick: Velocities, h: float, hk: float) -> Corrected:
    """Stage 3, the constraint forces at ``t_n``: the multipliers and the corrected half-step velocities.

    ``W = B M⁻¹ Bᵀ + ε/(h h_k) I`` is factored once (dense Cholesky; :class:`SingularConstraints` when a pivot
    falls to :data:`SINGULAR_PIVOT` of its largest diagonal entry); ``Λ = W⁻¹(B V* + Φ_t + Φ/h)``,
    ``V^{n+½} = V* − M⁻¹ Bᵀ Λ``, ``λ = Λ/h_k`` (docs/formulation.md §7).  The stage changes ω at the
    joints' nodes, so the kick is redone there with the midpoint gyroscopic term at the constrained ω
    and constrained again, :data:`CONSTRAINED_SWEEPS` times (the pair solved together); master/slave joints
    project the velocities in each pass (:meth:`Evaluation.master_slave_project`).
    """
    m, N = ev.n_constraints, ev.n_nodes
    phi, B, phi_t = ev.constraints(state.x, state.q, state.t) if m else (np.zeros(0), sp.csr_matrix((0, 6 * N)),
                                                                        np.zeros(0))
    if m == 0 and ev.model.master_slave.master.shape[0] == 0:
        return Corrected(kick.v, kick.w, np.zeros(0), phi, phi_t, B)
    BM = B @ inverse_mass(ev)
    BMt = BM.T.tocsr()
    if m:
        W = (BM @ B.T).toarray() + np.diag(ev.eps / (h * hk))
        try:
            L = np.linalg.cholesky(W)
        except np.linalg.LinAlgError:
            raise SingularConstraints from None
        if np.diag(L).min() ** 2 <= SINGULAR_PIVOT * np.diag(W).max():
            raise SingularConstraints
    V, lam = kick, np.zeros(m)
    for sweep in range(1 + CONSTRAINED_SWEEPS):
        if sweep > 0:
            V = predict(ev, state, f, hk, nodes=ev.model.nodes.constrained_ids, start=V)
        if m:
            flat = np.hstack([V.v, V.w]).ravel()
            impulse = scipy.linalg.cho_solve((L, True), B @ flat + phi_t + phi / h)
            flat = (flat - BMt @ impulse).reshape(N, 6)
            V, lam = Velocities(flat[:, :3].copy(), flat[:, 3:].copy()), impulse / hk
        ev.master_slave_project(state.q, V.v, V.w)
    return Corrected(V.v, V.w, lam, phi, phi_t, B)


def work_of_loads(state: State, F: np.ndarray, h: float) -> float:
    """The external forces' work over ``[t_{n−1}, t_n]`` [J], trapezoidal in F at ``V^{n−½}``:
    ``h Σ ½(F^{n−1} + F^n)·V^{n−½}`` (``state.f_prev`` is F^{n−1}); 0 at the first step."""
    if state.n == 0:
        return 0.0
    return h * float(np.sum(0.5 * (state.f_prev + F) * np.hstack([state.v, state.w])))


def damping_loss(ev: Evaluation, state: State, new: Corrected, hk: float) -> float:
    """The energy [J] the damping removes in this kick: its force at ``V^{n−½}`` times the mean velocity
    ``½(V^{n−½} + V^{n+½})``, over h_k, for the mass-proportional damping (free coordinates) and the force
    elements' dampers (:meth:`Evaluation.damper_dissipation`)."""
    loss = 0.0
    if ev.damping != 0.0:
        m, J = ev.masses
        free = ev.model.nodes.free
        v_mean, w_mean = 0.5 * (state.v + new.v), 0.5 * (state.w + new.w)
        loss = hk * ev.damping * float(np.sum(m[:, None] * state.v * v_mean * free[:, :3])
                                       + np.sum(state.w * np.einsum("nab,nb->na", J, w_mean) * free[:, 3:]))
    if ev.model.force_elements.kind.shape[0] > 0:
        loss += hk * ev.damper_dissipation(state.x, state.q, state.v, state.w, new.v, new.w)
    return loss


def power_of_constraints(state: State, new: Corrected) -> float:
    """The constraint forces' power over the kick [W] (the driving motions'; times h_k their work):
    ``−λᵀ B V̄``, ``V̄ = ½(V^{n−½} + V^{n+½})``."""
    if not new.lam.size:
        return 0.0
    mean = 0.5 * np.hstack([state.v + new.v, state.w + new.w]).ravel()
    return -float(new.lam @ (new.B @ mean))


def kinetic(ev: Evaluation, v: np.ndarray, w: np.ndarray) -> float:
    """``T = Σ ½ m v·v + ½ ω·J ω`` [J]."""
    m, J = ev.masses
    return float(0.5 * np.sum(m[:, None] * v * v) + 0.5 * np.sum(w * np.einsum("nab,nb->na", J, w)))


def energy_guard(ev: Evaluation, state: State, f: Forces, new: Corrected, h: float, drive: float,
                 guard: np.ndarray) -> bool:
    """The per-step energy balance (:func:`reference.algorithms.staggered._balance`, :mod:`reference.monitor`):
    True (a blow-up) when ``E − E₀ − W + D`` exceeds the tolerance × the largest ``|E₀| + |W| + |D|`` so far
    plus one step of the external and constraint powers, and E itself has grown.  E is the kinetic energy at
    the integer-step velocities plus U; ``drive`` the constraint forces' power [W];
    ``guard`` the :data:`reference.state.GUARD` record array (1,) (tolerance 0: off)."""
    g, clock = guard[0], state.clock[0]
    if g["tolerance"] == 0.0:
        return False
    V_old = np.hstack([state.v, state.w])
    if state.n == 0:  # the first step fixes E₀
        g["E0"] = kinetic(ev, state.v, state.w) + f.U
        g["scale"] = max(g["scale"], abs(g["E0"]))
        return False
    E = kinetic(ev, 0.5 * (state.v + new.v), 0.5 * (state.w + new.w)) + f.U
    work, dissipated = clock["work"], clock["dissipated"]
    g["scale"] = max(g["scale"], abs(g["E0"]) + abs(work) + abs(dissipated))
    g["residual"], g["energy"] = E - g["E0"] - work + dissipated, E
    lag = h * (abs(np.sum(f.F * V_old)) + abs(np.sum(f.F * np.hstack([new.v, new.w]))) + abs(drive))
    return g["residual"] > g["tolerance"] * g["scale"] + lag and E - g["E0"] > g["tolerance"] * g["scale"]


def drift(ev: Evaluation, state: State, new: Corrected, F: np.ndarray, h: float) -> None:
    """Stage 5, in place: ``x^{n+1} = x^n + h v^{n+½}``, ``q^{n+1} = q^n ⊗ p(h ω^{n+½})`` (the generated
    trapezoidal Cayley factor, normalised), the half-step velocities kept, F kept for the next step's work,
    master/slave positions set, and the clock moved to ``t_{n+1}``."""
    state.x[:] += h * new.v
    q = np.array(_cayley(*state.q.T, *new.w.T, h)).T
    state.q[:] = q / np.linalg.norm(q, axis=1)[:, None]
    state.v[:], state.w[:], state.f_prev[:] = new.v, new.w, F
    ev.master_slave_positions(state.x, state.q)
    n = state.n
    state.clock[0]["n"], state.clock[0]["t"] = n + 1, (n + 1) * h


def record(ev: Evaluation, rec: Record, state: State, new: Corrected, U: float, loss: float) -> None:
    """The output record at ``t_n`` (:class:`~reference.state.Record`): the integer-step velocities (the mean
    of the two half-step ones; the initial ones at the first step), energies, constraint residuals
    ``‖Φ‖``, ``‖B V + Φ_t‖`` and the multipliers; ``loss`` the damping's loss of this kick (half of it
    belongs before ``t_n``)."""
    first = state.n == 0
    rec.x[:], rec.q[:] = state.x, state.q
    rec.v[:] = state.v if first else 0.5 * (state.v + new.v)
    rec.w[:] = state.w if first else 0.5 * (state.w + new.w)
    clock = state.clock[0]
    rec.energy[:] = (kinetic(ev, rec.v, rec.w), U, clock["work"], clock["dissipated"] + (0.0 if first else 0.5 * loss))
    rate = new.phi_t + new.B @ np.hstack([rec.v, rec.w]).ravel()
    rec.constraint[:] = (np.linalg.norm(new.phi), np.linalg.norm(rate))
    rec.lam[:] = new.lam


def solve_step(ev: Evaluation, state: State, h: float, guard: np.ndarray, rec: Record | None = None,
               take: bool = True) -> int:
    """One step of Park's algorithm in place on ``state``, stage after stage; returns a status code of
    :mod:`reference.status`.  ``rec``: write the output record at ``t_n`` into it; ``take`` false: only the
    record (the stages up to it, no drift)."""
    f = forces(ev, state)
    hk = kick_length(state, h)
    joints = ev.n_constraints > 0 or ev.model.master_slave.master.shape[0] > 0
    kick = predict(ev, state, f, hk, extra=CONSTRAINED_SWEEPS if joints else 0)
    try:
        new = constrain(ev, state, f, kick, h, hk)
    except SingularConstraints:
        return SINGULAR
    state.clock[0]["work"] += work_of_loads(state, f.F, h)
    loss = damping_loss(ev, state, new, hk)
    if rec is not None:
        record(ev, rec, state, new, f.U, loss)
    if not take:
        return OK
    if not (np.all(np.isfinite(new.v)) and np.all(np.isfinite(new.w))):
        return DIVERGED  # the state stays at the last finite step
    drive = power_of_constraints(state, new)
    state.clock[0]["work"] += hk * drive
    state.clock[0]["dissipated"] += 0.5 * loss
    if energy_guard(ev, state, f, new, h, drive, guard):
        return BLOWUP
    state.clock[0]["dissipated"] += 0.5 * loss
    drift(ev, state, new, f.F, h)
    return OK


class ReferenceRun(NamedTuple):
    """The reference step's run state: the model's :class:`Evaluation`, the energy guard (a
    :data:`reference.state.GUARD` record array (1,)) and the Domain's critical step [s] (for a blow-up's message)."""

    evaluation: Evaluation
    guard: np.ndarray
    critical_step: float

    @property
    def energy(self) -> float:
        """Kinetic + strain energy at the last guarded step [J]."""
        return float(self.guard[0]["energy"])


class ReferenceStaggered(StaggeredCentralDifference):
    """Park's staggered central difference on the reference path (``backend = "reference"``): the compiled
    algorithm's settings, deck keys and messages, its step taken by :func:`solve_step`."""

    backend = "reference"

    def start(self, model, state, critical_step=math.inf, guard=None) -> ReferenceRun:
        """The run state; the per-step energy guard is on when ``guard`` (the energy scale's round-off floor
        [J], :func:`reference.monitor.energy_floor`) is given."""
        record = np.zeros(1, GUARD)
        if guard is not None:
            record[0]["scale"], record[0]["tolerance"] = guard, GUARD_TOLERANCE
        return ReferenceRun(Evaluation(model), record, float(critical_step))

    def failure(self, code, state, run):
        status, message = explicit_failure(code, state.t, likely_cause(self.dt, run.critical_step))
        return status, message + BlowUpMonitor.guard_report(run.guard[0], state.work)

    def advance(self, model, state, run: ReferenceRun, n_steps: int, record: Record | None) -> int:
        """``n_steps`` steps of :func:`solve_step`, the record at the starting time into ``record`` if given
        (``n_steps = 0``: the record only)."""
        for k in range(max(int(n_steps), 1)):
            code = solve_step(run.evaluation, state, self.dt, run.guard, record if k == 0 else None, n_steps > 0)
            if code != OK:
                return code
        return OK
