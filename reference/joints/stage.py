"""The explicit step's constraint stage, layout by layout (the behaviour of the joint formulations).

Park's staggered step (:mod:`reference.algorithms.staggered`, stage 2b) asks the joints two
things: :func:`prepare_constraints` once per step, at ``t_n``, and :func:`project_constraints`
after each predictor pass, to correct the predicted velocities.  Each layout of
:data:`reference.joints.formulations.LAYOUTS` answers with its own functions:

- the multiplier rows (:class:`reference.joints.formulation.Multipliers`): Φ, Φ_t, B and the
  sparse factor of ``B M⁻¹ Bᵀ + ε/(h h_k)`` (:mod:`reference.joints.assembly`), then the
  stabilised impulse — one solve when every row's equation is its solve's (c = ε: Lagrange
  multipliers), iterated from the previous multipliers otherwise (the augmented Lagrangian);
- the master/slave pairs (:mod:`reference.joints.master_slave`): the M-orthogonal projection
  onto the pairs' motions.

A formulation of an existing layout changes only its rows' data (ε, c, the iteration), not
this stage.
"""

from __future__ import annotations

from reference.jit import inlined
from reference.joints.assembly import assemble_constraints, constraint_impulse, factor_constraints, iterated_impulse
from reference.joints.master_slave import master_slave_project
from reference.status import OK, SINGULAR


@inlined
def prepare_constraints(model, scratch, x, q, t, h, hk):
    """What the projections need at ``t_n``: the multiplier rows' Φ, Φ_t, B blocks and factor (into
    ``scratch``), and for iterated rows the estimate λ* = 0 (``scratch.lam``; the passes of the step
    then carry it on); the master/slave pairs need nothing ahead.  Returns ``SINGULAR`` when the factor
    lost rank, else ``OK``."""
    if scratch.PHI.shape[0] > 0:
        if model.joints.iterations > 0:
            # the iterated rows start each step from no estimate: carried over from the step before, the
            # estimate would integrate the constraint error with no damping where the iteration falls short
            for r in range(scratch.lam.shape[0]):
                scratch.lam[r] = 0.0
        assemble_constraints(model, x, q, t, scratch.PHI, scratch.PHIt, scratch.Bj, scratch.prim_phi, scratch.prim_B)
        if factor_constraints(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, h, hk) != OK:
            return SINGULAR
    return OK


@inlined
def project_constraints(model, scratch, q, v, w, h, hk):
    """Correct the predicted velocities ``v, w`` (N, 3) in place, layout after layout: the multiplier
    rows' impulse (``scratch.lam`` receives λ), then the master/slave projection."""
    if scratch.PHI.shape[0] > 0:
        if model.joints.iterations > 0:
            iterated_impulse(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, scratch.PHI, scratch.PHIt,
                             v, w, h, hk, scratch.lam)
        else:
            constraint_impulse(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, scratch.PHI, scratch.PHIt,
                               v, w, h, hk, scratch.lam)
    if model.master_slave.master.shape[0] > 0:
        master_slave_project(model, q, v, w, scratch.T, scratch.A_m, scratch.A_s, scratch.MT, scratch.TMT,
                             scratch.rhs)
