"""Park's staggered central difference for a model with reduced bodies (reference path, issue 39).

The stages of :mod:`reference.plain.park` on the generalised coordinates of
:class:`~reference.reduced.coupling.CoupledModel` (the other nodes' six each, a body's ``[r, θ, η]``):

1. forces at ``t_n``: the stripped model's nodal ``F − S`` (gravity, loads, springs, the other elements) as
   generalised forces ``Tᵀ (F − S)``;
2. the kick over ``h_k``: ``M (V* − V^{n−½}) = h_k (Tᵀ(F − S) − g(V̄))``, ``V̄ = ½ (V^{n−½} + V*)``, with ``M``
   the generalised mass (a 6 × 6 block per node, the body's ``M_b(p, η)``) and ``g`` the gyroscopic, quadratic-
   velocity and modal forces (:meth:`~reference.reduced.coupling.CoupledModel.inertial`) at the mean velocity
   (fixed-point sweeps, the midpoint rule that keeps a free body's kinetic energy);
3. the constraint stage on the chain-ruled rows ``B T``: ``(B T M⁻¹ Tᵀ Bᵀ + ε/(h h_k)) Λ = B T V* + Φ_t + Φ/h``,
   ``V^{n+½} = V* − M⁻¹ Tᵀ Bᵀ Λ`` (docs/formulation.md §7), the kick and the projection repeated together
   (:data:`SWEEPS`) since ``g`` depends on the corrected velocities;
4. the drift: the other nodes as :func:`reference.plain.park.drift`, each body ``r += h ṙ``,
   ``p ← p ⊗ cay(h ω)``, ``η += h η̇`` (a vector space: no rotation update), then the reduced nodes placed.

Energies are recorded as in Park's step (kinetic ``½ V̄ᵀ M V̄``, strain of the other elements plus ``½ ηᵀ K η``,
the work of the loads and drives); the per-step energy guard of the nodal scheme is not run here.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from reference.plain.park import ReferenceStaggered, _cayley, kick_length
from reference.reduced.coupling import BodyState, CoupledModel
from reference.state import Record
from reference.status import DIVERGED, OK, SINGULAR

SWEEPS = 4
"""Kick-and-project passes of a step: the velocity-dependent forces at the mean velocity converge to
round-off in a few passes at a stable step (``h ω_max < 2``, each pass contracts by ~``h_k |∂g/∂V| / M``)."""


class ReducedRun(NamedTuple):
    """The run state: the coupled model and each body's state; ``last`` the step's recorded datasets."""

    coupled: CoupledModel
    bodies: list
    critical_step: float
    energy: float = math.nan


def inverse_mass(M: sp.csr_matrix, free: np.ndarray) -> np.ndarray:
    """``M⁻¹`` (dense) on the free coordinates, zero rows and columns at the fixed ones (the generalised mass is
    block diagonal and small: a 6 × 6 block per node, ``6 + r`` per body)."""
    ids = np.flatnonzero(free)
    out = np.zeros(M.shape)
    out[np.ix_(ids, ids)] = np.linalg.inv(M.toarray()[np.ix_(ids, ids)])
    return out


def step(cm: CoupledModel, state, bodies: list[BodyState], h: float, rec: Record | None) -> int:
    """One step from ``t_n`` in place on ``state`` and ``bodies`` (module docstring); a status code."""
    hk = kick_length(state, h)
    cm.place(bodies, state)
    S, F, U, _ = cm.ev.forces(state.x, state.q, state.v, state.w, state.t, state.angle)
    T = cm.velocity_map(bodies)
    Q = T.T @ (F - S).ravel()
    V0 = cm.gather(state, bodies)
    Minv = inverse_mass(cm.mass(bodies), cm.free)
    phi, BT, phi_t, eps = cm.constraints(state, bodies, T)
    if phi.size:
        BM = Minv @ BT.T.toarray()
        W = BT @ BM + np.diag(eps / (h * hk))
        try:
            L = scipy.linalg.cho_factor(W)
        except np.linalg.LinAlgError:
            return SINGULAR
    V, lam = V0.copy(), np.zeros(phi.size)
    for _ in range(SWEEPS):
        V = V0 + hk * (Minv @ (Q - cm.inertial(bodies, 0.5 * (V0 + V))))
        if phi.size:
            impulse = scipy.linalg.cho_solve(L, BT @ V + phi_t + phi / h)
            V, lam = V - BM @ impulse, impulse / hk
    if not np.all(np.isfinite(V)):
        return DIVERGED
    QF = T.T @ F.ravel()
    clock = state.clock[0]
    if state.n > 0:
        clock["work"] += h * float(0.5 * (state.f_prev.ravel() @ (T @ V0) + QF @ V0))
    mean = 0.5 * (V0 + V)
    drive = -float(lam @ (BT @ mean)) if phi.size else 0.0
    if rec is not None:
        _record(cm, rec, state, bodies, V0 if state.n == 0 else mean, (U, phi, BT, phi_t, lam))
    clock["work"] += hk * drive
    _drift(cm, state, bodies, V, h)
    state.f_prev[:] = F
    clock["n"], clock["t"] = state.n + 1, (state.n + 1) * h
    cm.place(bodies, state)
    return OK


def _record(cm: CoupledModel, rec: Record, state, bodies, Vbar, parts) -> None:
    """The output record at ``t_n``: the nodes placed with the integer-step velocities ``Vbar``, the energies,
    ``‖Φ‖``, ``‖B T V̄ + Φ_t‖`` and the joints' multipliers (the model's m rows)."""
    U, phi, BT, phi_t, lam = parts
    saved = [b.V.copy() for b in bodies]
    v, w = state.v.copy(), state.w.copy()
    cm.scatter(Vbar, state, bodies)
    cm.place(bodies, state)
    rec.x[:], rec.q[:], rec.v[:], rec.w[:] = state.x, state.q, state.v, state.w
    kinetic = 0.5 * float(Vbar @ (cm.mass(bodies) @ Vbar))
    clock = state.clock[0]
    rec.energy[:] = (kinetic, U + cm.strain(bodies), clock["work"], clock["dissipated"])
    rate = BT @ Vbar + phi_t if phi.size else np.zeros(0)
    rec.constraint[:] = (np.linalg.norm(phi), np.linalg.norm(rate))
    rec.lam[:] = lam[:rec.lam.size]
    state.v[:], state.w[:] = v, w
    for b, V in zip(bodies, saved):
        b.V[:] = V


def _drift(cm: CoupledModel, state, bodies, V, h: float) -> None:
    """Positions to ``t_{n+1}`` with the half-step velocities ``V`` (module docstring, stage 4)."""
    cm.scatter(V, state, bodies)
    ids = cm.others
    state.x[ids] += h * state.v[ids]
    if ids.size:
        q = np.array(_cayley(*state.q[ids].T, *state.w[ids].T, h)).T
        state.q[ids] = q / np.linalg.norm(q, axis=1)[:, None]
    for b in bodies:
        b.r += h * b.V[:3]
        p = np.array(_cayley(*b.p[:, None], *b.V[3:6, None], h)).T[0]
        b.p[:] = p / np.linalg.norm(p)
        b.eta += h * b.V[6:]
    cm.ev.master_slave_positions(state.x, state.q)


class ReducedStaggered(ReferenceStaggered):
    """Park's staggered central difference for a model with reduced bodies (module docstring): the settings,
    deck keys and records of :class:`~reference.plain.park.ReferenceStaggered`, plus each body's modal
    coordinates and frame (``reduced/<label>/…``, :meth:`~reference.reduced.coupling.CoupledModel.recorded`)."""

    coupled_model: CoupledModel | None = None
    """Set by :func:`reference.plain.backend.twin` for the model of the run."""

    def start(self, model, state, critical_step=math.inf, guard=None) -> ReducedRun:
        cm = self.coupled_model
        bodies = cm.initial(state)
        cm.place(bodies, state)
        return ReducedRun(cm, bodies, float(critical_step))

    def failure(self, code, state, run):
        from reference.status import explicit_failure
        from reference.monitor import likely_cause

        return explicit_failure(code, state.t, likely_cause(self.dt, run.critical_step))

    def advance(self, model, state, run: ReducedRun, n_steps: int, record: Record | None) -> int:
        for k in range(max(int(n_steps), 1)):
            if n_steps == 0:
                return _record_only(run, state, self.dt, record)
            code = step(run.coupled, state, run.bodies, self.dt, record if k == 0 else None)
            if code != OK:
                return code
        return OK

    def recorded(self, run) -> dict:
        return run.coupled.recorded(run.bodies)


def _record_only(run: ReducedRun, state, h: float, record) -> int:
    """The record at the current time without a step (the run's last output): a step taken on copies."""
    if record is None:
        return OK
    copy = state.__class__(*(a.copy() for a in state))
    bodies = [b.copy() for b in run.bodies]
    return step(run.coupled, copy, bodies, h, record)
