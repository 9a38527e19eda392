"""How constraints enter the equations of motion (the paper's ``Joint_Formulation``, Fig. 5).

Each formulation is a strategy the Domain hands its joints to: it validates them
and lays out their part of the :class:`~reference.state.Model`
(:meth:`JointFormulation.model_fields`); the algorithms then treat each part with
its own stage (multiplier rows: ``reference/joints/assembly.py``; eliminated
coordinates: ``reference/joints/master_slave.py``).  :data:`REGISTRY` lists
them in the order their fields are laid out; a penalty or augmented-Lagrangian
formulation would be one more class there.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable

import numpy as np

from reference.joints.master_slave import master_slave_parameters
from reference.joints.sparse import constraint_pattern
from reference.state import Joints, MasterSlaveJoints


class JointFormulation(ABC):
    """Abstract treatment of a joint's constraint equations.

    Subclasses provide ``name`` (the deck's ``formulation``), ``epsilon`` (the
    regularisation, if any), ``multipliers`` (True when the joint has rows of the
    Lagrange-multiplier system, hence reactions from its multipliers) and
    :meth:`model_fields`, the Model fields of all joints of the formulation:

    - :class:`Jacobian`: Lagrange multipliers from the constraint Jacobian B,
      solved by the stabilised implicit procedure (``reference/joints/assembly.py``);
    - :class:`MasterSlave`: elimination of the slave's dependent coordinates
      (``reference/joints/master_slave.py``).
    """

    name: str
    epsilon: float = 0.0
    multipliers: bool = True

    @classmethod
    @abstractmethod
    def model_fields(cls, joints: list, n_nodes: int, tf_index: Callable, beam_nodes: set, fixed: set) -> dict:
        """Validate ``joints`` (all of this formulation, in the Domain's order) and return their
        :class:`~reference.state.Model` fields.

        ``tf_index(time_function) → int`` gives a time function's row in the Model's table
        (adding it); ``beam_nodes`` and ``fixed`` are the ids of the nodes of elements and of
        the nodes with fixed coordinates.  Raises ``ValueError("joint 'LABEL': problem")``.
        """


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
    multipliers = True

    def __post_init__(self):
        if not self.epsilon >= 0.0:
            raise ValueError(f"epsilon must be ≥ 0, got {self.epsilon!r}")

    @classmethod
    def model_fields(cls, joints, n_nodes, tf_index, beam_nodes, fixed) -> dict:
        """``joints``: the joint tables (:class:`~reference.state.Joints`, rows in the joints' order),
        each row's ε and the fixed sparsity of ``B M⁻¹ Bᵀ`` (:func:`reference.joints.sparse.constraint_pattern`)."""
        J = len(joints)
        jt = Joints(np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64), np.zeros((J, 24)),
                    np.full((J, 6), -1, dtype=np.int64), np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64),
                    np.zeros(J, dtype=np.int64), np.zeros(J, dtype=np.int64), None, None)
        row_eps, row0 = [], 0
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
        pattern = constraint_pattern(jt.i, jt.j, jt.neq,
                                     np.array([joint.formulation.epsilon > 0.0 for joint in joints], dtype=np.int64))
        return {"joints": jt._replace(eps=np.array(row_eps, dtype=float), pattern=pattern)}


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


REGISTRY = (Jacobian, MasterSlave)
"""The joint formulations, in the order their Model fields are laid out."""
