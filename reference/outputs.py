"""The derived outputs of a run's records: joint reactions and section resultants (paper §4.3, ``Solve``).

:class:`Outputs` completes each output record of an algorithm (:class:`~reference.state.Record`) with the
joint reactions and the element section resultants, computed by one compiled call (:func:`derived_outputs`);
the solution loop (:func:`reference.solution.run`) hands the completed record to its sink.  Apart from the
solution loop so that the compiled call's cache key (:mod:`reference.kernel_cache`) does not hold the loop's
sources: the loop may choose an algorithm of the reference path (``reference/plain/``) without recompiling it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference.elements.families import resultants
from reference.jit import boundary, inlined, kernel, named
from reference.joints.joint import PRESCRIBED
from reference.joints.reactions import joint_reactions
from reference.joints.reactions import scratch as reaction_scratch
from reference.state import Model, Record, element_work


class OutputArrays(NamedTuple):
    """The groups of the :class:`~reference.state.Model` that the derived outputs read.

    :func:`derived_outputs` takes these in place of the Model (its kernels read the same
    fields by name): a compiled call unboxes every array it is given, each at a cost (:mod:`reference.jit`).
    """

    joints: tuple
    time_functions: tuple
    elements: tuple


@kernel
def within_stretch_compiled(x, conn, low, high):
    """:func:`reference.monitor.within_stretch` compiled: whether every element's squared end-to-end distance lies
    within ``(low, high)`` [m²] (a NaN or an inf is outside), for the monitor of a run on the compiled path."""
    for e in range(conn.shape[0]):
        i, j = conn[e, 0], conn[e, 1]
        d0, d1, d2 = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
        squared = d0 * d0 + d1 * d1 + d2 * d2
        if not (squared > low[e] and squared < high[e]):
            return False
    return True


def largest_strain(section_force: np.ndarray, inverse_EA: np.ndarray) -> tuple[float, int]:
    """The largest finite axial strain ``|N| / EA`` of the elements (section forces ``section_force`` (E, 3) [N],
    ``inverse_EA`` (E,) [1/N], 0 for an element not watched) and its element (the first of equal ones; (0, 0)
    when none is positive); a NaN or an inf counts as 0."""
    with np.errstate(invalid="ignore", over="ignore"):
        strain = np.abs(section_force[:, 0]) * inverse_EA
    strain[~np.isfinite(strain)] = 0.0
    if strain.size == 0:
        return 0.0, 0
    e = int(np.argmax(strain))
    return float(strain[e]), e


@kernel
def largest_strain_compiled(section_force, inverse_EA):
    """:func:`largest_strain` compiled, for the records of a run on the compiled path."""
    best, at = 0.0, 0
    for e in range(inverse_EA.shape[0]):
        strain = abs(section_force[e, 0]) * inverse_EA[e]
        if strain > best and strain < math.inf:  # a NaN fails both
            best, at = strain, e
    return best, at


class Outputs:
    """The output record of a run: the algorithm's :class:`~reference.state.Record` and the derived
    outputs, joint reactions and element section resultants, as one dict of preallocated arrays.

    Reactions of all joints (NaN for master/slave ones, which have no
    multipliers; :func:`reference.joints.reactions.joint_reactions`) and the
    section resultants N, M at every element's midpoint
    (:func:`reference.elements.families.resultants`), both computed by one
    compiled call (:meth:`derive`, :func:`derived_outputs`) into arrays allocated once; with prescribed
    displacements, each one's reaction along its direction (``prescribed_reaction``, NaN for the
    other joints).

    Parameters
    ----------
    model : Model
    joints : list of Joint
        The Domain's joints, in the order of the results' ``/joints``.
    rec : Record
        The record the algorithm fills.
    """

    stretch_screen = staticmethod(within_stretch_compiled)
    """The screen of the run's blow-up monitor (:attr:`reference.monitor.BlowUpMonitor.screen`) on this path."""

    def __init__(self, model: Model, joints: list, rec: Record):
        rows = [k for k, j in enumerate(joints) if j.formulation.multipliers]
        self.model, self.rec = model, rec
        self.arrays = boundary(OutputArrays(model.joints, model.time_functions, model.elements))
        self.slot = np.array(rows, dtype=np.int64)
        J, E = len(joints), model.n_elements
        # rows of master/slave joints are never written: NaN once
        self.force, self.moment = np.full((J, 3), np.nan), np.full((J, 3), np.nan)
        self.section_force, self.section_moment = np.zeros((E, 3)), np.zeros((E, 3))
        self.out = (self.force, self.moment, self.section_force, self.section_moment)
        """The four arrays :func:`derived_outputs` writes."""
        self.scratch, self.element_work = reaction_scratch(), element_work(model)
        self.time = np.zeros(())
        self.entry = {
            "time": self.time, "position": rec.x, "rotation": rec.q, "velocity": rec.v,
            "angular_velocity": rec.w, "violation_norm": rec.constraint[0, ...],
            "velocity_violation_norm": rec.constraint[1, ...], "multipliers": rec.lam,
            "kinetic": rec.energy[0, ...], "strain": rec.energy[1, ...], "external_work": rec.energy[2, ...],
            "dissipated": rec.energy[3, ...], "reaction_force": self.force, "reaction_moment": self.moment,
            "section_force": self.section_force, "section_moment": self.section_moment,
        }
        """Record key (:data:`reference.io.results.DATASETS`) → value; views of arrays that every
        :meth:`record` overwrites (a sink copies them)."""
        # prescribed displacements: their reaction along the direction (the force on body i is u λ)
        self.prescribed = [(k, j.frame[:, 2]) for k, j in enumerate(joints) if j.kind == PRESCRIBED]
        if self.prescribed:
            self.entry["prescribed_reaction"] = self.prescribed_reaction = np.full(J, np.nan)
        self.inverse_EA = np.zeros(E)
        """``1 / EA`` of every element, set by :meth:`watch_strain`; the largest ``|N| / EA`` of the records so
        far is :attr:`strain`."""
        self.strain = (0.0, 0, 0.0)
        """(largest axial strain ``|N| / EA`` at an element's midpoint over the records, its element, its time)."""

    def watch_strain(self, inverse_EA: np.ndarray) -> None:
        """Watch the axial strain ``|N| / EA`` of the elements of ``1 / EA`` [1/N] ``inverse_EA`` (0: not watched)
        over the records (:attr:`strain`)."""
        self.inverse_EA = np.ascontiguousarray(inverse_EA, dtype=float)

    def record(self, t: float) -> dict:
        """Complete the record at time ``t`` with the derived outputs; returns :attr:`entry`."""
        self.time[()] = t
        strain, e = self.derive(float(t))
        for k, u in self.prescribed:
            self.prescribed_reaction[k] = self.force[k] @ u
        if strain > self.strain[0]:
            self.strain = (float(strain), int(e), float(t))
        return self.entry

    def derive(self, t: float) -> tuple[float, int]:
        """The joint reactions (rows :attr:`slot` of :attr:`force`, :attr:`moment`) and the section resultants
        (:attr:`section_force`, :attr:`section_moment`) of the record at time ``t`` [s], one compiled call;
        returns the record's largest axial strain and its element (:func:`largest_strain`, of the elements
        :meth:`watch_strain` watches)."""
        rec = self.rec
        return derived_outputs(self.arrays, rec.x, rec.q, rec.lam, t, self.slot, self.out, self.element_work,
                               self.scratch, self.inverse_EA)


_joint_reactions = inlined(joint_reactions)  # a compiled call with the Model costs two atomic updates per array
_largest_strain = inlined(largest_strain_compiled)


@kernel
def derived_outputs(model, x, q, lam, t, slot, out, element_work, work, inverse_EA):
    """Joint reactions into the rows ``slot`` of ``force``, ``moment`` (J, 3) and section
    resultants into ``section_force``, ``section_moment`` (E, 3), ``out`` the four of them, in one compiled call;
    returns the largest axial strain ``|N| / EA`` and its element (:func:`largest_strain`, ``inverse_EA`` (E,)
    [1/N]).

    ``model`` is the :class:`~reference.state.Model` or its :class:`OutputArrays`; ``element_work`` the
    families' work arrays (:func:`reference.state.element_work`); ``work`` the reactions' scratch
    (:func:`reference.joints.reactions.scratch`).
    """
    model = named(model, OutputArrays)
    force, moment, section_force, section_moment = out
    _joint_reactions(model, x, q, lam, t, slot, force, moment, work)
    resultants(model.elements, element_work, x, q, section_force, section_moment)
    return _largest_strain(section_force, inverse_EA)


def inverse_axial_stiffness(elements) -> np.ndarray:
    """``1 / EA`` [1/N] of every element, for the axial strain ``|N| / EA`` of the records; 0 for an element whose
    formulation has no :class:`~reference.elements.Section` (a family of its own data: not checked)."""
    return np.array([1.0 / section.EA if (section := getattr(e.formulation, "section", None)) is not None else 0.0
                     for e in elements], dtype=float)
