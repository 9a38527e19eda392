"""How constraints enter the equations of motion (the paper's ``Joint_Formulation``, Fig. 5)."""

from __future__ import annotations

from abc import ABC
from dataclasses import dataclass


class JointFormulation(ABC):
    """Abstract treatment of a joint's constraint equations.

    A subclass says how the joint's equations are enforced in the staggered
    step.  It provides ``name`` and the parameters its treatment needs; the
    Domain assembles joints of one formulation together:

    - :class:`Jacobian`: Lagrange multipliers from the constraint Jacobian B,
      solved by the stabilised implicit procedure (``reference/joints/assembly.py``);
    - :class:`MasterSlave`: elimination of the slave's dependent coordinates
      (``reference/joints/master_slave.py``).
    """

    name: str
    epsilon: float = 0.0


@dataclass
class Jacobian(JointFormulation):
    """Lagrange multipliers via the constraint Jacobian, Park–Chiou stabilised.

    Parameters
    ----------
    epsilon : float
        Penalty/regularisation ``ε`` of ``ε λ = Φ`` [units of Φ per unit of λ];
        default 0: the stabilised equations are then a linearised position
        projection, exact and drift-free for independent constraints.  Give
        ``ε > 0`` (e.g. 1e-8 of the inverse mass scale) to regularise redundant
        constraints instead of having them reported.
    """

    epsilon: float = 0.0
    name = "jacobian"

    def __post_init__(self):
        if not self.epsilon >= 0.0:
            raise ValueError(f"epsilon must be ≥ 0, got {self.epsilon!r}")


@dataclass
class MasterSlave(JointFormulation):
    """Master/slave elimination (spherical and revolute joints).

    ``body_i`` of the joint is the slave (a beam node at the joint point),
    ``body_j`` the master (a rigid body or another node); the slave's
    dependent coordinates follow the master exactly, so the joint has no
    constraint drift and no multipliers.
    """

    name = "master_slave"
    epsilon: float = 0.0
