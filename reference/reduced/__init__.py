"""Reduced flexible bodies: a beam described by a floating reference frame plus a few modes (issue 39).

- :mod:`reference.reduced.craig_bampton`: the modes from the project's own linearisation of a meshed beam
  (Craig–Bampton fixed-interface and constraint modes, free-free modes, clamped modes, floating-frame modes);
- :mod:`reference.reduced.invariants`: the floating frame's inertia shape integrals and its mass matrix;
- :mod:`reference.reduced.body`: :class:`~reference.reduced.body.ReducedBody`, the formulation (mass matrix,
  quadratic-velocity vector, modal forces, energy, critical step, deformed mesh, the steady-spin pencil);
- :mod:`reference.reduced.stiffening`: the modes' centrifugal stress stiffness.

Not yet coupled to the algorithms (a reduced body joined to others by joints, the deck's ``reduce`` key): the
formulation stands on its own, checked against the full mesh in tests/test_reduced_*.py.
"""
