"""The augmented-Lagrangian joint formulation (Bayo, García de Jalón & Serna 1988; Bayo & Ledesma 1996).

Bayo's index-3 augmented Lagrangian writes the constraint forces of a joint as a penalty
around a multiplier estimate λ*::

    M a + Bᵀ (λ* + α Φ) = Q,        λ* ← λ* + α Φ   (iterated)

with α the penalty [force per unit of Φ] and Φ(x, q, t), B the joint's own equations and
Jacobian (the generated primitives of ``reference/generated/joints.py``, the rows of the
multiplier layout: :class:`reference.joints.formulation.Multipliers`).  Eliminating
``λ = λ* + α Φ`` turns each iteration into a solve with the multiplier rows regularised by
``ε = 1/α`` and shifted by the estimate: the rows' equation ``Φ − ε (λ − λ*) = 0``.  So the
formulation is a treatment of the multiplier rows — regularisation ``ε = 1/α`` of the solves,
compliance 0 of the equation (``Φ = 0`` once λ* has converged) — and each algorithm iterates
the estimate as its scheme allows:

- explicit (Park's staggered step, ``reference/joints/assembly.py``, ``multiplier_impulse``):
  the constraint stage is the mass-orthogonal projection of the predicted velocities onto
  ``Φ_{n+1} = 0`` (Bayo & Ledesma's projection); the augmented iteration solves it with
  ``(B M⁻¹ Bᵀ + I/(α h h_k)) ΔΛ = B V + Φ_t + Φ/h`` and ``V ← V − M⁻¹ Bᵀ ΔΛ`` up to
  ``iterations`` times (each solve contracts the error by about ``1/(1 + α h h_k σ)``, σ the
  eigenvalues of ``B M⁻¹ Bᵀ``), from no estimate at each projection.  The estimate is not carried
  from one step to the next: a force ``λ* + α Φ`` whose λ* sums α Φ over the steps is an integral
  control of the constraint error without damping, unstable where the iteration falls short (a
  penalty too small for the step); restarted, a short iteration leaves a penalty-regularised
  constraint instead (one solve: the penalty formulation);
- implicit (static, generalized-α): the estimate is the current multiplier at
  every Newton iteration, so the rows' residual is Φ itself while the Newton matrix keeps the
  −ε block: Newton converges (linearly, by about ``ε/(ε + σ')`` per iteration, σ' the
  eigenvalues of the Newton matrix's Schur complement) to ``Φ = 0``.

In both the converged motion is the exact Lagrange-multiplier solution, for any α: α only sets
how fast it is reached.  Redundant constraints need no ε: ``B M⁻¹ Bᵀ + ε I`` is regular
whatever the rank of B, and the iteration converges to constraint forces ``Bᵀλ`` that hold
every constraint (the multipliers of a redundant loop are not unique; their forces are).
The linearised analyses (modes, buckling, Campbell) would see the joints as springs of
stiffness α: they refuse them.
"""

from __future__ import annotations

from dataclasses import dataclass

from reference.joints.formulation import ALPHA, EXPLICIT, STATIC, Multipliers

PENALTY = 1e11
"""Default penalty α [force per unit of Φ: N/m, N m/rad].  Bayo & Ledesma (1996) use 1e7–1e9 for
models in SI units, where α enters the mass matrix ``M + α h² BᵀB`` and a larger one spoils its
conditioning; here α enters as the regularisation ``1/α`` of the multiplier solves, which stay
well conditioned, so a larger α only converges faster: with explicit steps of 1e-4 s and bodies of
a kilogram one solve contracts the error by about 1/(1 + α h² σ) ~ 1e-3, and redundant rows keep
pivots ``1/(α h²)`` far above the factorisation's threshold (1e-13 of the largest)."""

ITERATIONS = 50
"""Default most multiplier solves per explicit constraint stage."""

MAX_ITERATIONS = 1000
"""Most multiplier solves per explicit constraint stage a deck may ask (each costs a solve with the
stage's factor: a bound keeps a mistyped count from stalling the run)."""

TOLERANCE = 1e-12
"""Default relative change of the multipliers, ``max |ΔΛ| ≤ tolerance · max |Λ|``, that ends the
explicit iteration (about the round-off of the multipliers, so the converged stage is the
Lagrange-multiplier one)."""


@dataclass
class AugmentedLagrangian(Multipliers):
    """Augmented-Lagrangian joint: penalty α around an iterated multiplier estimate.

    Parameters
    ----------
    penalty : float
        α > 0 [force per unit of Φ]; the rows' solves are regularised by ε = 1/α.
    iterations : int
        Most multiplier solves of the explicit constraint stage (≥ 1).  The implicit algorithms
        update the estimate at each Newton iteration (their ``max_iterations`` bounds it).
    tolerance : float
        Relative change of the multipliers below which the explicit iteration stops (> 0).
    """

    penalty: float = PENALTY
    iterations: int = ITERATIONS
    tolerance: float = TOLERANCE
    name = "augmented_lagrangian"
    multipliers = True
    compliance = 0.0
    algorithms = (EXPLICIT, STATIC, ALPHA)
    deck_keys = {"penalty": f"α > 0 [force per unit of Φ] (default {PENALTY:g})",
                 "iterations": f"most multiplier solves per explicit step (default {ITERATIONS})",
                 "tolerance": f"relative change of the multipliers ending them (default {TOLERANCE:g})"}

    def __post_init__(self):
        if not self.penalty > 0.0 or self.penalty == float("inf"):
            raise ValueError(f"penalty must be positive and finite, got {self.penalty!r}")
        if int(self.iterations) != self.iterations or not 1 <= self.iterations <= MAX_ITERATIONS:
            raise ValueError(f"iterations must be an integer from 1 to {MAX_ITERATIONS}, got {self.iterations!r}")
        if not self.tolerance > 0.0:
            raise ValueError(f"tolerance must be positive, got {self.tolerance!r}")
        self.iterations = int(self.iterations)

    @property
    def epsilon(self) -> float:
        """The regularisation of the rows' solves, ε = 1/α."""
        return 1.0 / self.penalty

    @classmethod
    def from_deck(cls, rd, table, entry):
        return cls(rd.number(table.get("penalty", PENALTY), f"{entry}.penalty", positive=True),
                   rd.integer(table.get("iterations", ITERATIONS), f"{entry}.iterations", minimum=1,
                              maximum=MAX_ITERATIONS, fix=f"at most {MAX_ITERATIONS}"),
                   rd.number(table.get("tolerance", TOLERANCE), f"{entry}.tolerance", positive=True))
