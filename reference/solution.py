"""The solution loop (paper §4.3, Fig. 9, ``Solve``): advance, record, watch, and how a run ends.

:meth:`reference.domain.Domain.solve` assembles the model (``initialization``)
and the initial state (``initial_conditions``) and hands them to :func:`run`,
which advances the state one output interval at a time with the algorithm
(``Algorithm.advance``, compiled), completes each record with the derived
outputs (:class:`Outputs`: joint reactions and section resultants) and the
algorithm's own (``Algorithm.recorded``) and hands it to a sink, which also takes
the datasets the algorithm writes at the end (``Algorithm.finish``: a linearised
analysis's modes, a static run's stability events): the results file (:class:`reference.io.results.ResultsWriter`) or
preallocated arrays (:class:`reference.io.results.MemoryRecorder`).  The blow-up
monitor (:mod:`reference.monitor`) checks every record.  Whatever stops the
run, the sink is closed with a status saying how it ended.
"""

from __future__ import annotations

import math
import time as _time
import warnings
from typing import NamedTuple

import numpy as np

from reference.algorithms.base import Algorithm
from reference.elements.families import resultants
from reference.io.results import MemoryRecorder, Results
from reference.jit import boundary, inlined, kernel, named, use_threads
from reference.joints.joint import PRESCRIBED
from reference.joints.reactions import joint_reactions
from reference.joints.reactions import scratch as reaction_scratch
from reference.joints.setup import multiplier_joints
from reference.monitor import BlowUpMonitor, nonfinite_load, rediagnosed
from reference.state import Model, Record, State, element_work
from reference.status import OK
from reference.validation import ModelWarning, axial_strain


class SolverDiverged(RuntimeError):
    """The run failed or blew up; the results written so far are kept."""


class OutputArrays(NamedTuple):
    """The groups of the :class:`~reference.state.Model` that the derived outputs read.

    :func:`derived_outputs` takes these in place of the Model (its kernels read the same
    fields by name): a compiled call unboxes every array it is given, each at a cost (:mod:`reference.jit`).
    """

    joints: tuple
    time_functions: tuple
    elements: tuple


class Outputs:
    """The output record of a run: the algorithm's :class:`~reference.state.Record` and the derived
    outputs, joint reactions and element section resultants, as one dict of preallocated arrays.

    Reactions of all joints (NaN for master/slave ones, which have no
    multipliers; :func:`reference.joints.reactions.joint_reactions`) and the
    section resultants N, M at every element's midpoint
    (:func:`reference.elements.families.resultants`), both computed by one
    compiled call (:func:`derived_outputs`) into arrays allocated once; with prescribed
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

    def __init__(self, model: Model, joints: list, rec: Record):
        rows = [k for k, j in enumerate(joints) if j.formulation.multipliers]
        self.model, self.rec = model, rec
        self.arrays = boundary(OutputArrays(model.joints, model.time_functions, model.elements))
        self.slot = np.array(rows, dtype=np.int64)
        J, E = len(joints), model.n_elements
        # rows of master/slave joints are never written: NaN once
        self.force, self.moment = np.full((J, 3), np.nan), np.full((J, 3), np.nan)
        self.section_force, self.section_moment = np.zeros((E, 3)), np.zeros((E, 3))
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
        """``1 / EA`` of every element, set by the caller (:func:`run`); the largest ``|N| / EA`` of the
        records so far is :attr:`strain`."""
        self.strain = (0.0, 0, 0.0)
        """(largest axial strain ``|N| / EA`` at an element's midpoint over the records, its element, its time)."""

    def record(self, t: float) -> dict:
        """Complete the record at time ``t`` with the derived outputs; returns :attr:`entry`."""
        rec = self.rec
        self.time[()] = t
        derived_outputs(self.arrays, rec.x, rec.q, rec.lam, float(t), self.slot, self.force, self.moment,
                        self.section_force, self.section_moment, self.element_work, *self.scratch)
        for k, u in self.prescribed:
            self.prescribed_reaction[k] = self.force[k] @ u
        if self.inverse_EA.size:
            with np.errstate(invalid="ignore"):
                strain = np.abs(self.section_force[:, 0]) * self.inverse_EA
            e = int(np.argmax(np.where(np.isfinite(strain), strain, 0.0)))
            if strain[e] > self.strain[0]:
                self.strain = (float(strain[e]), e, float(t))
        return self.entry


_joint_reactions = inlined(joint_reactions)  # a compiled call with the Model costs two atomic updates per array


@kernel
def derived_outputs(model, x, q, lam, t, slot, force, moment, section_force, section_moment, element_work,
                    jphi, jB, jphit, prim_phi, prim_B, A):
    """Joint reactions into the rows ``slot`` of ``force``, ``moment`` (J, 3) and section
    resultants into ``section_force``, ``section_moment`` (E, 3), in one compiled call.

    ``model`` is the :class:`~reference.state.Model` or its :class:`OutputArrays`."""
    model = named(model, OutputArrays)
    _joint_reactions(model, x, q, lam, t, slot, force, moment, jphi, jB, jphit, prim_phi, prim_B, A)
    resultants(model.elements, element_work, x, q, section_force, section_moment)


def _where(algo, t: float) -> str:
    """``"t = 0.84"``, or ``"load factor 0.84"`` for a path whose time is its load factor (static, arc length)."""
    return f"load factor {t:.6g}" if getattr(algo, "progress_name", "") == "load factor" else f"t = {t:.6g}"


def inverse_axial_stiffness(elements) -> np.ndarray:
    """``1 / EA`` [1/N] of every element, for the axial strain ``|N| / EA`` of the records; 0 for an element whose
    formulation has no :class:`~reference.elements.Section` (a family of its own data: not checked)."""
    return np.array([1.0 / section.EA if (section := getattr(e.formulation, "section", None)) is not None else 0.0
                     for e in elements], dtype=float)


def _failure(domain, algo: Algorithm, code: int, state: State, run_state, t_record: float, critical: float):
    """``(status, message)`` of a run whose algorithm stopped with ``code``: the algorithm's own, the blow-up's cause
    read from the model (:func:`reference.monitor.rediagnosed`), or a load that is not finite over the step."""
    status, message = algo.failure(code, state, run_state)
    message = rediagnosed(message, domain, algo.dt, critical, bool(getattr(algo, "explicit", False)))
    load = nonfinite_load(domain, (t_record, state.t, state.t + algo.dt))
    if load:
        status, message = f"failed: {load}", f"{load}; give a load finite over the run (results up to then are kept)"
    return status, message


def _completed(domain, outputs: Outputs, unrecordable: str | None) -> str:
    """The status of a run that reached its end, and the one-line warnings its records call for: constraint norms
    that are not finite (a time function's rate infinite, e.g. ``t**(1/3)`` at t = 0), an axial strain beyond
    what a slender structure's units make plausible (:func:`reference.validation.axial_strain`)."""
    status = "completed"
    if unrecordable is not None:
        status = f"completed with a non-finite constraint violation norm at {unrecordable}"
        warnings.warn(f"the constraint violation norms (/constraints/violation_norm, velocity_violation_norm) are "
                      f"not finite at {unrecordable}: a drive's or prescribed displacement's time function or its "
                      "rate is not finite there (e.g. t**(1/3) at t = 0); the status says so", ModelWarning,
                      stacklevel=3)
    strain, element, t_strain = outputs.strain
    axial_strain(strain, domain.elements[element].label if domain.elements else "", t_strain)
    return status


def run(domain, algo: Algorithm, model: Model, state: State, n_total: int, results_path=None, progress=None,
        monitor: bool = True, deck=None, critical: float | None = None) -> Results:
    """Advance ``state`` by ``n_total`` steps of ``algo``, recording every ``domain.solver.output_every`` steps.

    The parameters, the statuses and the errors are those of
    :meth:`reference.domain.Domain.solve`; ``domain.last_run`` is updated with
    the results path, the status, the last time, the energy scale and the work; ``critical`` is the
    domain's critical step estimate [s] when the caller has it (else computed here).
    """
    every = max(int(domain.solver.output_every), 1)
    rec = Record.empty(len(domain.nodes), model.n_constraints)
    outputs = Outputs(model, domain.joints, rec)
    outputs.inverse_EA = inverse_axial_stiffness(domain.elements)
    critical = domain.critical_time_step() if critical is None else critical
    watch = BlowUpMonitor(domain, algo.dt, getattr(algo, "explicit", True), critical) if monitor else None
    run_state = None
    if results_path is not None:
        from reference.io.results import ResultsWriter

        sink = ResultsWriter(results_path, domain, algo, template=outputs.entry, deck=deck)
        domain.last_run["path"] = str(results_path)
    else:
        sink = MemoryRecorder(n_total // every + 2, [n.label for n in domain.nodes], [j.label for j in domain.joints],
                              [e.label for e in domain.elements])
    status = "failed: stopped before the first step"
    unrecordable = None
    wall0 = _time.perf_counter()
    try:
        use_threads(nodes=len(domain.nodes))  # reference.jit: every core for a large model, one for a small one
        algo.joint_labels = tuple(j.label for j in multiplier_joints(domain.joints))
        run_state = algo.start(model, state, critical, watch.floor if watch is not None else None)
        domain.last_run["solver"] = run_state
        done, t_record = 0, state.t
        budget = getattr(run_state, "budget", None)
        if progress is not None and budget is not None:
            # between two outputs too, after every compiled call (reference.algorithms.base.CallBudget)
            budget.tick = lambda: progress(min((done + (state.t - t_record) / algo.dt) / n_total, 1.0), state.t)
        while True:
            chunk = 0 if algo.done(run_state) else min(every, n_total - done)
            t_record = state.t
            code = algo.advance(model, state, run_state, chunk, rec)
            entry, extra = outputs.record(t_record), algo.recorded(run_state)
            sink.append({**entry, **extra} if extra else entry)
            if unrecordable is None and not np.all(np.isfinite(rec.constraint)):
                unrecordable = _where(algo, t_record)
            why = watch.check(rec.energy, rec.x) if watch is not None and code == OK else ""
            if why:
                status = f"diverged after t = {t_record:.6g}"
                raise SolverDiverged(f"{why} (stopped at t = {t_record:.6g}); results up to then are kept")
            if code != OK:
                if algo.record_last(model, state, run_state, rec):  # the last converged state, kept
                    sink.append({**outputs.record(state.t), **algo.recorded(run_state)})
                status, message = _failure(domain, algo, code, state, run_state, t_record, critical)
                raise SolverDiverged(message)
            done += chunk
            if progress is not None and chunk > 0:
                progress(done / n_total, state.t)
            if chunk == 0:
                break
        sink.add_datasets(algo.finish(model, state, run_state, True))
        status = _completed(domain, outputs, unrecordable)
    except SolverDiverged:
        sink.add_datasets(algo.finish(model, state, run_state, False))
        raise
    except KeyboardInterrupt:
        status = f"interrupted at {_where(algo, state.t)}"
        raise
    except Exception as exc:
        status = f"failed: {type(exc).__name__}: {exc}"[:500]
        raise
    except BaseException:
        status = f"terminated at {_where(algo, state.t)}"
        raise
    finally:
        domain.last_run.update(status=status, t=state.t, energy=float(getattr(run_state, "energy", math.nan)),
                               work=float(state.clock[2]), where=_where(algo, state.t))
        sink.close(status)
    return sink.results(_time.perf_counter() - wall0)
