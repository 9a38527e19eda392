"""The explicit step's constraint stage: the joints' behaviour in Park's staggered step, layout by layout.

Park's staggered step (:mod:`reference.algorithms.staggered`, stage 2b) hands its predicted
velocities to :func:`constrain`, which asks each layout of
:data:`reference.joints.formulations.LAYOUTS` for its projection:

- the multiplier rows (:class:`reference.joints.formulation.Multipliers`): Φ, Φ_t, B and the
  sparse factor of ``B M⁻¹ Bᵀ + ε/(h h_k)`` once per step (:mod:`reference.joints.assembly`),
  then the stabilised impulse — one solve when every row's equation is its solve's (c = ε:
  Lagrange multipliers), iterated otherwise (ε ≠ c: the augmented Lagrangian,
  :func:`~reference.joints.assembly.iterated_impulse`);
- the master/slave pairs (:mod:`reference.joints.master_slave`): the M-orthogonal projection
  onto the pairs' motions.

A formulation of an existing layout changes only its rows' data (ε, c, the iteration), not this
stage.  The stage is one inlined function with the layouts' calls written out, not a function per
layout: an inlined helper's arguments cost two atomic reference-count updates per array and call
(:mod:`reference.jit`), and the Model and the step's work arrays are some eighty arrays, passed at
every predictor pass.
"""

from __future__ import annotations

from reference.algorithms.staggered_nodes import kick_range
from reference.jit import inlined
from reference.joints.assembly import assemble_constraints, constraint_impulse, factor_constraints, iterated_impulse
from reference.joints.master_slave import master_slave_project
from reference.status import OK, SINGULAR

CONSTRAINED_SWEEPS = 3
"""Extra (kick, projection) passes when there are joints (contraction ≈ h|ω|)."""


@inlined
def _kick(model, v, w, S, F, hk, v_new, w_new):
    """The kick again at the nodes of joints (``model.nodes.constrained_ids``), one gyroscopic sweep from
    the constrained velocities of the previous pass (:func:`constrain`; the full kick is
    :func:`~reference.algorithms.staggered_nodes.kick_nodes`)."""
    c, J, Jinv, free, mass = model.damping, model.nodes.inertia, model.nodes.inertia_inv, model.nodes.free, model.nodes.mass
    ids = model.nodes.constrained_ids
    kick_range(0, ids.shape[0], ids, True, c, J, Jinv, free, mass, model.nodes.constrained, v, w, S, F, hk, v_new,
               w_new, 1, 0, True)


@inlined
def constrain(model, scratch, state, t, h, hk):
    """Stage 2b, the constraint forces: each joint layout's projection of the predicted velocities
    ``scratch.v_new, scratch.w_new`` (N, 3, in place) at ``t_n``, alternated with the kick's gyroscopic
    sweeps; ``scratch.lam`` receives the multipliers.  Returns ``SINGULAR`` if the constraint matrix lost
    rank, else ``OK``.  ``state`` holds the configuration at ``t_n`` and the velocities at ``t_{n−½}``,
    ``scratch.S, scratch.F`` the forces of the kick."""
    x, q, v, w = state.x, state.q, state.v, state.w
    S, F, v_new, w_new = scratch.S, scratch.F, scratch.v_new, scratch.w_new
    n_rows, n_pairs = scratch.PHI.shape[0], model.master_slave.master.shape[0]
    if n_rows > 0:
        assemble_constraints(model, x, q, t, scratch.PHI, scratch.PHIt, scratch.Bj, scratch.prim_phi, scratch.prim_B)
        if factor_constraints(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, h, hk) != OK:
            return SINGULAR
    # The constraint stage changes ω^{n+½}: redo the predictor with the midpoint
    # gyroscopic term at the constrained velocity and constrain again (same factor),
    # so that the pair (kick, constraint) is solved together (otherwise the gyroscopic
    # term of a constrained spinning body is only first-order accurate).  With both
    # multiplier and master/slave joints the passes also alternate the two projections.
    for sweep in range(1 + CONSTRAINED_SWEEPS):
        if sweep > 0:
            _kick(model, v, w, S, F, hk, v_new, w_new)
        if n_rows > 0 and model.joints.iterations > 0:
            iterated_impulse(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, scratch.PHI, scratch.PHIt,
                             v_new, w_new, h, hk, scratch.lam)
        elif n_rows > 0:
            constraint_impulse(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, scratch.PHI, scratch.PHIt,
                               v_new, w_new, h, hk, scratch.lam)
        if n_pairs > 0:
            master_slave_project(model, q, v_new, w_new, scratch.T, scratch.A_m, scratch.A_s, scratch.MT,
                                 scratch.TMT, scratch.rhs)
    return OK
