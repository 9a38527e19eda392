"""The model-evaluation layer: what every algorithm asks of the model.

- :mod:`reference.evaluation.forces`: the generalised forces at a configuration and
  time — internal forces and strain energy of every element family
  (:mod:`reference.elements.families`), the force elements' springs and dampers,
  the external loads, gravity and actuators;
- :mod:`reference.evaluation.tangent`: the Newton matrix of the implicit
  algorithms — its block pattern, the element families' tangents, the joints'
  geometric stiffness, the load, gyroscopic and force-element tangents;
- the constraints' values, Jacobian, impulse and Hessian are the joints' own
  (:mod:`reference.joints.assembly`, :mod:`reference.joints.hessian`).

The explicit step (:mod:`reference.algorithms.staggered`) is a kick, the
constraint stage and a drift around :func:`~reference.evaluation.forces.generalized_forces`;
the implicit residual (:mod:`reference.algorithms.implicit`) is the inertia plus
the same forces.  A new force or element family is one edit here or one class
registered there.
"""
