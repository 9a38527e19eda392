"""The solution loop (paper §4.3, Fig. 9, ``Solve``): advance, record, watch, and how a run ends.

:func:`solve` (what :meth:`reference.domain.Domain.solve` runs) checks the model as a whole, has the Domain
assemble the model (``initialization``) and the initial state (``initial_conditions``) and hands them to :func:`run`,
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

import numpy as np

from reference.algorithms.base import Algorithm
from reference.io.results import MemoryRecorder, Results
from reference.jit import use_threads
from reference.joints.setup import multiplier_joints
from reference.errors import SolverDiverged
from reference.joints.formulations import refusal as formulation_refusal
from reference.monitor import BlowUpMonitor, damping_problem, nonfinite_load, rediagnosed
from reference.outputs import Outputs, inverse_axial_stiffness
from reference.state import Model, Record, State
from reference.status import OK
from reference.validation import ModelWarning, axial_strain, joint_offsets


def _where(algo, t: float) -> str:
    """``"t = 0.84"``, or ``"load factor 0.84"`` for a path whose time is its load factor (static, arc length)."""
    return f"load factor {t:.6g}" if getattr(algo, "progress_name", "") == "load factor" else f"t = {t:.6g}"


def _on_backend(domain, algo: Algorithm, model: Model, n_total: int, rec: Record) -> tuple:
    """``(algorithm, outputs, (backend, reason))`` of ``domain.solver.backend``: the compiled algorithm and
    outputs, or for the reference path (``"reference"``, or ``"auto"`` for a short job:
    :func:`reference.plain.backend.decide`) the algorithm's twin and outputs computed in NumPy
    (:class:`reference.plain.outputs.PlainOutputs`), which compile nothing.  ValueError (one line) for a backend
    that cannot run the algorithm."""
    from reference.plain import backend

    requested = domain.solver.backend
    choice = backend.decide(requested, algo, model, n_total)  # compiled is refused for a reference-only model
    if choice.backend == "compiled":
        return algo, Outputs(model, domain.joints, rec), tuple(choice)
    from reference.plain.model import Evaluation
    from reference.plain.outputs import PlainOutputs

    return backend.twin(algo), PlainOutputs(model, domain.joints, rec, Evaluation(model)), tuple(choice)


def _sink(domain, algo: Algorithm, outputs: Outputs, results_path, capacity: int, deck, choice: tuple):
    """Where the records go: the results file at ``results_path`` (its attributes say which backend ran and
    why), or ``capacity`` records in memory."""
    if results_path is None:
        return MemoryRecorder(capacity, [n.label for n in domain.nodes], [j.label for j in domain.joints],
                              [e.label for e in domain.elements])
    from reference.io.results import ResultsWriter

    domain.last_run["path"] = str(results_path)
    return ResultsWriter(results_path, domain, algo, template=outputs.entry, deck=deck,
                         attrs={"backend": choice[0], "backend_reason": choice[1]})


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


def solve(domain, *, t_end: float | None = None, dt: float | None = None, results_path=None, progress=None,
          monitor: bool = True, deck=None) -> Results:
    """Run from t = 0 to ``t_end`` (paper: Solve, Fig. 9) and return the time histories.

    Records stream to the results file and are not kept in memory; the returned
    :class:`Results` reads them from the file when asked.  Without a file they are
    kept in preallocated arrays.  Whatever stops the run, the file is closed with
    a status saying how it ended (``"completed"``, ``"diverged after t = …"``,
    ``"interrupted at t = …"`` on Ctrl-C, ``"terminated at t = …"`` on SystemExit —
    the command line raises it on SIGTERM and SIGHUP — or ``"failed: <reason>"``),
    and ``domain.last_run`` says where and how.  Before the first step, the checks that need the whole model:
    the joints' offsets, the joint formulations the algorithm refuses, the damping of an explicit step (a
    ValueError of one line).

    Parameters
    ----------
    domain : reference.domain.Domain
        The problem: its lists, its ``solver`` settings; its ``last_run`` says where and how the run ended.
    t_end, dt : float, optional
        Override the deck's end time and step.
    results_path : path, optional
        HDF5 results file (:mod:`reference.io.results`).
    progress : callable(fraction, t), optional
        Called after every output, and between two outputs after every compiled call of a time-stepping
        algorithm (about every 0.1 s: :class:`reference.algorithms.base.CallBudget`).
    monitor : bool
        Stop a run that blows up while finite (:mod:`reference.monitor`): the algorithm
        checks the energy balance every step (``Scratch.guard``), the solution loop
        (:func:`run`) the energy balance and the deformation at every output.
    deck : optional
        The deck this Domain was read from (:class:`reference.io.deck.Deck`): the results
        file records its ``path`` and ``text``.

    Raises
    ------
    reference.errors.SolverDiverged
        When the algorithm fails (non-finite state, singular constraints) or the
        monitor sees a blow-up; records up to then are kept.
    """
    t_end = domain.solver.t_end if t_end is None else float(t_end)
    algo = domain.algorithm(dt=dt)
    n_total = algo.n_steps(t_end)
    domain.last_run = {"path": None, "status": "not started", "t": 0.0}
    joint_offsets(domain)
    model = domain.initialization()
    problem = formulation_refusal(domain.joints, domain.solver.algorithm)
    if problem:
        raise ValueError(problem)
    critical = domain.critical_time_step()
    problem = damping_problem(model.damping, algo.dt, critical) if algo.explicit else ""
    if problem:
        raise ValueError(f"solver damping: {problem}")
    state = domain.initial_conditions()
    return run(domain, algo, model, state, n_total, results_path, progress, monitor, deck, critical)


def run(domain, algo: Algorithm, model: Model, state: State, n_total: int, results_path=None, progress=None,
        monitor: bool = True, deck=None, critical: float | None = None) -> Results:
    """Advance ``state`` by ``n_total`` steps of ``algo``, recording every ``domain.solver.output_every`` steps.

    The parameters, the statuses and the errors are those of
    :func:`solve`; ``domain.last_run`` is updated with
    the results path, the status, the last time, the energy scale and the work; ``critical`` is the
    domain's critical step estimate [s] when the caller has it (else computed here).
    """
    every = max(int(domain.solver.output_every), 1)
    rec = Record.empty(len(domain.nodes), model.n_constraints)
    algo, outputs, choice = _on_backend(domain, algo, model, n_total, rec)
    domain.last_run["backend"] = choice
    outputs.watch_strain(inverse_axial_stiffness(domain.elements))
    critical = domain.critical_time_step() if critical is None else critical
    watch = BlowUpMonitor(domain, algo.dt, getattr(algo, "explicit", True), critical,
                          outputs.stretch_screen) if monitor else None
    run_state = None
    sink = _sink(domain, algo, outputs, results_path, n_total // every + 2, deck, choice)
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
            if unrecordable is None and not all(map(math.isfinite, rec.constraint.tolist())):
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
                               work=state.work, where=_where(algo, state.t))
        sink.close(status)
    results = sink.results(_time.perf_counter() - wall0)
    results.attrs.update(backend=choice[0], backend_reason=choice[1])  # a run kept in memory too
    return results
