"""Reduced flexible bodies: a beam described by a floating reference frame plus a few modes (issue 39).

- :mod:`reference.reduced.craig_bampton`: the modes from the project's own linearisation of a meshed beam
  (Craig–Bampton fixed-interface and constraint modes, free-free modes, clamped modes, floating-frame modes);
- :mod:`reference.reduced.invariants`: the floating frame's inertia shape integrals and its mass matrix;
- :mod:`reference.reduced.body`: :class:`~reference.reduced.body.ReducedBody`, the formulation (mass matrix,
  quadratic-velocity vector, modal forces, energy, critical step, deformed mesh, the steady-spin pencil);
- :mod:`reference.reduced.stiffening`: the modes' centrifugal stress stiffness and second-order stiffness;
- :mod:`reference.reduced.coupling`: a model whose reduced beams move as reduced bodies (generalised coordinates,
  the velocity map, mass, forces, joint rows by the chain rule), with :mod:`reference.reduced.attachments` (joints,
  springs and loads at interface nodes only) and :mod:`reference.reduced.registry` (which Domains have them, and
  the formulation's entry in :data:`reference.plain.backend.REFERENCE_ONLY`);
- :mod:`reference.reduced.explicit` and :mod:`reference.reduced.implicit`: the explicit, static, generalized-α and
  modes algorithms on those coordinates (:data:`reference.reduced.algorithms.REDUCED_TWINS`), on the reference
  path (``[[beams]] reduce``, :mod:`reference.io.deck_reduce`).
"""
