"""How constraints enter the equations of motion (the paper's ``Joint_Formulation``, Fig. 5).

Each formulation is a strategy the Domain hands its joints to: it validates them
and lays out their part of the :class:`~reference.state.Model`, and it says which
algorithms it serves.  Formulations share a **layout** — the Model field and the
algorithms' stage that treat their joints:

- :class:`Multipliers`: rows of the constraint equations Φ(x, q, t) = 0 with their
  Jacobian B (the generated joint primitives, ``reference/joints/assembly.py``) and
  one multiplier λ per row.  A formulation of this layout is its rows' treatment:
  the regularisation ε of the solves (``B M⁻¹ Bᵀ + ε/(h h_k)``, the Newton matrix's
  −ε block), the compliance c of the row's equation ``Φ − c λ = 0``, and how often
  the multiplier solve is iterated (``λ ← λ + ΔΛ/h_k`` until converged): the
  Lagrange multipliers (:class:`Jacobian`, ε = c, one solve) and the augmented
  Lagrangian (:mod:`reference.joints.augmented_lagrangian`, ε = 1/α, c = 0,
  iterated) are two such treatments of the same rows;
- :class:`MasterSlave`: elimination of the slave's dependent coordinates
  (``reference/joints/master_slave.py``).

The registry (:mod:`reference.joints.formulations`) names them for the deck reader.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable

import numpy as np

from reference.joints.master_slave import master_slave_parameters
from reference.joints.sparse import constraint_pattern
from reference.state import Joints, MasterSlaveJoints

EXPLICIT, STATIC, ALPHA = "staggered_central_difference", "static", "generalized_alpha"
"""The algorithms' names (:data:`reference.algorithms.ALGORITHMS`) that formulations name in ``algorithms``."""


class JointFormulation(ABC):
    """Abstract treatment of a joint's constraint equations.

    Subclasses provide ``name`` (the deck's ``formulation``), ``deck_keys`` (the keys of a
    ``[[joints]]`` entry they read, each with its meaning), :meth:`from_deck`, ``algorithms``
    (the names of the algorithms that can run them; None: all), ``multipliers`` (True when the
    joint has rows of the multiplier layout, hence reactions from its multipliers), ``epsilon``
    (the regularisation of its rows' solves, if any) and :meth:`model_fields`, the Model fields
    of all joints of their layout.
    """

    name: str
    deck_keys: dict = {}
    algorithms: tuple | None = None
    epsilon: float = 0.0
    multipliers: bool = True

    @classmethod
    def from_deck(cls, rd, table: dict, entry: str) -> "JointFormulation":
        """The formulation of a ``[[joints]]`` entry from its keys (``rd`` the deck's
        :class:`~reference.io.deck_reader.Reader`, whose checks give the one-line messages)."""
        return cls()

    @classmethod
    def refusal(cls, algorithm: str) -> str | None:
        """Why ``algorithm`` cannot run joints of this formulation, or None."""
        if cls.algorithms is None or algorithm in cls.algorithms:
            return None
        return (f"formulation {cls.name!r} is available with {', '.join(cls.algorithms)} only, not with "
                f"{algorithm}; use formulation = \"jacobian\" for this analysis")

    @classmethod
    @abstractmethod
    def model_fields(cls, joints: list, n_nodes: int, tf_index: Callable, beam_nodes: set, fixed: set) -> dict:
        """Validate ``joints`` (all of this layout, in the Domain's order) and return their
        :class:`~reference.state.Model` fields.

        ``tf_index(time_function) → int`` gives a time function's row in the Model's table
        (adding it); ``beam_nodes`` and ``fixed`` are the ids of the nodes of elements and of
        the nodes with fixed coordinates.  Raises ``ValueError("joint 'LABEL': problem")``.
        """


class Multipliers(JointFormulation):
    """The layout of constraint rows with multipliers: Φ (m,), B (m × 6N in per-joint blocks), λ (m,).

    A formulation of this layout gives per joint ``epsilon`` (ε, the regularisation of the
    solves), ``compliance`` (c, in the row's equation ``Φ − c λ = 0``: ε of a regularised joint,
    0 for an exact constraint), ``iterations`` (the most multiplier solves per constraint stage:
    one for a direct solve) and ``tolerance`` (the relative change of the multipliers that ends the
    iteration).  All joints of the layout share the stage: it iterates as much as the most
    demanding of them asks.
    """

    compliance: float = 0.0
    iterations: int = 1
    tolerance: float = 0.0

    @classmethod
    def model_fields(cls, joints, n_nodes, tf_index, beam_nodes, fixed) -> dict:
        """``joints``: the joint tables (:class:`~reference.state.Joints`, rows in the joints' order),
        each row's ε and c, the stage's iterations and tolerance, and the fixed sparsity of
        ``B M⁻¹ Bᵀ`` (:func:`reference.joints.sparse.constraint_pattern`)."""
        J = len(joints)
        jt = Joints(np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64), np.zeros((J, 24)),
                    np.full((J, 6), -1, dtype=np.int64), np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64),
                    np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64), None, None, None, 0, 0.0)
        row_eps, row_c, row0 = [], [], 0
        for k, joint in enumerate(joints):
            jt.i[k] = joint.body_i.id
            jt.j[k] = -1 if joint.body_j is None else joint.body_j.id
            jt.par[k] = joint.body_fixed()
            jt.rows[k] = joint.rows
            jt.neq[k] = joint.n_equations
            jt.row0[k] = row0
            jt.drive[k] = joint.drive_code
            jt.tf[k] = tf_index(joint.time_function)
            row0 += joint.n_equations
            row_eps += [joint.formulation.epsilon] * joint.n_equations
            row_c += [joint.formulation.compliance] * joint.n_equations
        pattern = constraint_pattern(jt.i, jt.j, jt.neq,
                                     np.array([joint.formulation.epsilon > 0.0 for joint in joints], dtype=np.int64))
        iterative = [j.formulation for j in joints if j.formulation.compliance != j.formulation.epsilon]
        return {"joints": jt._replace(
            eps=np.array(row_eps, dtype=float), compliance=np.array(row_c, dtype=float), pattern=pattern,
            iterations=max([f.iterations for f in iterative], default=0),
            tolerance=min([f.tolerance for f in iterative], default=0.0))}


@dataclass
class Jacobian(Multipliers):
    """Lagrange multipliers via the constraint Jacobian, Park–Chiou stabilised.

    Parameters
    ----------
    epsilon : float
        Penalty/regularisation ``ε`` of ``ε λ = Φ`` [units of Φ per unit of λ];
        default 0: the stabilised equations are then a linearised position
        projection, exact and drift-free for independent constraints.  Give
        ``ε > 0`` (e.g. 1e-8 of the inverse mass scale) to regularise redundant
        constraints instead of having them reported.  ε is the row's compliance:
        the constraint gives way by ε λ.
    """

    epsilon: float = 0.0
    name = "jacobian"
    multipliers = True
    deck_keys = {"epsilon": "ε ≥ 0 of the stabilised multipliers (default 0), a compliance"}

    def __post_init__(self):
        if not self.epsilon >= 0.0:
            raise ValueError(f"epsilon must be ≥ 0, got {self.epsilon!r}")

    @property
    def compliance(self) -> float:
        return self.epsilon

    @classmethod
    def from_deck(cls, rd, table, entry):
        return cls(rd.number(table.get("epsilon", 0.0), f"{entry}.epsilon", nonnegative=True))


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
    multipliers = False
    algorithms = (EXPLICIT,)

    @classmethod
    def model_fields(cls, joints, n_nodes, tf_index, beam_nodes, fixed) -> dict:
        """``master_slave`` (:class:`~reference.state.MasterSlaveJoints`), after the rules:
        only spherical and revolute joints; the slave (``body_i``) a beam node at the joint point, slave of
        no other joint and master of none; the master (``body_j``) a body, not the ground; neither with
        fixed coordinates."""
        slaves = [j.body_i.id for j in joints]
        masters = {j.body_j.id for j in joints if j.body_j is not None}
        for j in joints:
            problem = None
            if j.kind not in ("spherical", "revolute"):
                problem = f"master/slave is available for spherical and revolute joints, not {j.kind}"
            elif j.body_j is None:
                problem = ("the master (body_j) of a master/slave joint cannot be the ground; use a clamp or "
                           "fixed coordinates")
            elif j.body_i.id not in beam_nodes:
                problem = "the slave (body_i) of a master/slave joint must be a beam node"
            elif np.linalg.norm(j.body_i.position - j.point) > 1e-9 * max(1.0, np.linalg.norm(j.point)):
                problem = "the slave node must sit at the joint point"
            elif slaves.count(j.body_i.id) > 1 or j.body_i.id in masters:
                problem = f"node {j.body_i.label!r} is the slave of one master/slave joint and used by another"
            elif j.body_i.id in fixed or j.body_j.id in fixed:
                problem = "master and slave of a master/slave joint may not have fixed coordinates"
            if problem:
                raise ValueError(f"joint {j.label!r}: {problem}")
        return {"master_slave": MasterSlaveJoints(
            np.array([j.body_j.id for j in joints], dtype=np.int64), np.array([j.body_i.id for j in joints], dtype=np.int64),
            np.array([0 if j.kind == "spherical" else 1 for j in joints], dtype=np.int64),
            np.array([master_slave_parameters(j) for j in joints]).reshape(len(joints), 9))}
