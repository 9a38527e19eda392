"""Parameter sensitivities by direct differentiation on the reference path (issue 40).

- :mod:`reference.sensitivity.derivatives`: ∂R/∂p by the parameter's kind (the generated ∂S/∂c of the section
  stiffnesses, a load's own vector, the masses' change, a spring alone, a rebuilt model for a drive's speed or a
  node's coordinate) and the outputs' derivatives along a state sensitivity;
- :mod:`reference.sensitivity.static`: ``K dx/dp = −∂R/∂p`` at every converged load step;
- :mod:`reference.sensitivity.eigen`: ``dλ/dp = φᵀ(∂K/∂p − λ ∂M/∂p)φ`` for modes and buckling;
- :mod:`reference.sensitivity.dynamic`: the tangent-linear Lie-group generalized-α step.

The parameters by name and the runs from a deck: :mod:`reference.io.deck_sensitivities`.
"""
