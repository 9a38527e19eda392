"""The derived outputs of a record on the reference path: joint reactions and section resultants in NumPy.

:class:`PlainOutputs` is :class:`reference.outputs.Outputs` with its one compiled call (:meth:`~Outputs.derive`)
replaced by the same quantities from the :class:`~reference.plain.model.Evaluation` and the element families'
plain resultants (:func:`reference.plain.elements.element_resultants`), so that a run of the reference path
compiles nothing.  The reactions follow :mod:`reference.joints.reactions`: with ``M a + Bᵀ λ = Q`` the joint's
generalised force on its body i is ``−B_{k,i}ᵀ λ_k`` (an inertial force at the node and a body-frame moment),
reduced to the joint point ``P_i = x_i + A_i s_i``: force ``F_i``, moment ``A_i M_i − (A_i s_i) × F_i``.
"""

from __future__ import annotations

import numpy as np

from reference.monitor import within_stretch
from reference.outputs import Outputs, largest_strain
from reference.plain.elements import element_resultants
from reference.plain.loads import rotation_matrices
from reference.plain.model import Evaluation


class PlainOutputs(Outputs):
    """:class:`~reference.outputs.Outputs` whose derived outputs are computed by the reference path.

    Parameters
    ----------
    model, joints, rec
        As :class:`~reference.outputs.Outputs`.
    evaluation : Evaluation
        The model's equations (its joints' rows B at the record's configuration and time).
    """

    stretch_screen = staticmethod(within_stretch)
    """The blow-up monitor's stretch screen in NumPy: the reference path compiles nothing."""

    def __init__(self, model, joints: list, rec, evaluation: Evaluation):
        super().__init__(model, joints, rec)
        self.evaluation = evaluation

    def derive(self, t: float) -> tuple[float, int]:
        """The reactions of the multiplier joints on their body i, about the joint point, inertial [N], [N m],
        into the rows :attr:`slot`; the section resultants of every element; returns the largest axial strain and
        its element (:func:`~reference.outputs.largest_strain`)."""
        rec, joints = self.rec, self.model.joints
        if self.slot.size:
            _, B, _ = self.evaluation.constraints(rec.x, rec.q, t)
            A = rotation_matrices(rec.q)
            for k, o in enumerate(self.slot):
                rows, i = slice(joints.row0[k], joints.row0[k] + joints.neq[k]), joints.i[k]
                generalised = -(B[rows, 6 * i:6 * i + 6].T @ rec.lam[rows])
                arm = A[i] @ joints.par[k, 0:3]
                self.force[o] = generalised[:3]
                self.moment[o] = A[i] @ generalised[3:] - np.cross(arm, generalised[:3])
        if self.section_force.size:
            self.section_force[:], self.section_moment[:] = element_resultants(self.model, rec.x, rec.q)
        return largest_strain(self.section_force, self.inverse_EA)
