"""``flexmbs sweep``: a parameter study of one deck, every case a task on dask.distributed.

A study file (TOML) names a deck and a grid of overrides::

    deck = "../models/embedded_beam.toml"   # relative to the study file
    description = "mesh × damping"          # optional

    [grid]
    refine = [1, 2]                         # the deck reader's refine, dt, t_end
    damping = [20.0, 25.0]                  # a bare [solver] key: solver.damping
    "sections.rollup.EI2" = [100.0, 120.0]  # any deck value by its dotted name

``sensitivities = true`` (optional) also differentiates the deck's ``[sensitivities]`` at every case
(:mod:`flexmbs.sweep_sensitivities`: the results file's ``/sensitivities`` and the summary's columns).

Every combination of the grid (their Cartesian product, in the order written)
is a case: the deck read with those overrides (:func:`reference.io.deck.load_deck`,
so every value is validated as if written in the deck), solved, its results
written to ``OUT/case_NNN/results.h5``.  The cases run as tasks on a Dask
cluster — a local one of ``workers`` processes by default, or an existing
scheduler (``scheduler = "tcp://host:8786"``).  They are made and submitted as
others finish, :data:`IN_FLIGHT` per worker thread at a time, so that a grid of
millions of cases starts at once, holds little memory and stops at a Ctrl-C.  ``OUT/summary.csv`` has one row
per finished case: the grid values, the status (``completed`` or the error of a failed
case), the wall time and the case's values (:func:`case_values`; a check's values
are the columns ``check.NAME…``, so that no check can overwrite the summary's own).
It is rewritten as cases finish (whole, under its name at once): a study that is
interrupted or killed leaves a valid summary of the cases finished so far.

Dask is imported only here (the engine, ``reference/``, never needs it); the
pieces are usable from Python: :func:`load_study` (or :func:`make_study`), :func:`cases`
(:func:`combinations` one at a time, :func:`n_cases`),
:func:`run_case` (one case, in this process) and :func:`run_study`.
"""

from __future__ import annotations

import csv
import itertools
import logging
import math
import os
import signal
import sys
import time
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from reference.io.deck import DeckError

DECK_OVERRIDES = ("refine", "dt", "t_end")
"""Grid names passed to the deck reader as they are."""
SOLVER_KEYS = ("algorithm", "damping", "output_every", "consistent_initial_velocities")
"""Bare grid names that mean ``solver.NAME``."""
CHECK_PREFIX = "check."
"""Prefix of the summary's columns of the deck's checks (a check may be called ``status``)."""
SUMMARY_EVERY = 0.5
"""Longest time [s] a finished case waits to be written to ``summary.csv`` (longer once the file takes
long to write: at most a tenth of the time goes to rewriting it)."""
IN_FLIGHT = 2
"""Cases submitted and not finished, per worker thread: the workers never wait for the next case, the
scheduler holds a few tasks (not the whole grid: submitting 10⁷ tasks took longer than any Ctrl-C waited)."""
POLL = 0.05
"""Interval [s] at which a study looks for finished cases and for ``stop``."""
QUIET = logging.CRITICAL + 1
"""Log level of Dask's loggers in a local cluster: none of its messages (a task cancelled, a worker killed,
a connection closed when a stopped study closes the cluster) is shown; a case that fails is its row."""


@dataclass
class Study:
    """A parameter study: ``deck`` (path), ``grid`` (name → list of values, in the file's order), and
    ``sensitivities``: whether every case also differentiates the deck's ``[sensitivities]``
    (:mod:`flexmbs.sweep_sensitivities`)."""

    path: Path
    deck: Path
    grid: dict
    description: str = ""
    sensitivities: bool = False


def _fail(path, entry: str, problem: str, fix: str = "") -> DeckError:
    return DeckError(f"{path}: {entry}: {problem}" + (f"; {fix}" if fix else ""))


def load_study(path) -> Study:
    """Read and validate a study file (one-line :class:`DeckError` messages naming the entry and the fix).

    The grid's names are checked against the deck by reading it with the first
    case's overrides, so a misspelt name fails here, before any task runs.
    """
    path = Path(path)
    if not path.is_file():
        raise DeckError(f"{path}: no such study file" + (" (it is a directory)" if path.exists() else ""))
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise DeckError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise DeckError(f"{path}: not valid TOML: {exc}") from None
    for key in data:
        if key not in ("deck", "grid", "description", "sensitivities"):
            raise _fail(path, key, "unknown key", "a study has deck, [grid] and optionally description and "
                        "sensitivities")
    if not isinstance(data.get("deck"), str):
        raise _fail(path, "deck", "missing or not a string", 'give the deck file, e.g. deck = "model.toml"')
    deck = (path.parent / data["deck"]).resolve()
    if not deck.is_file():
        raise _fail(path, "deck", f"no such deck file {data['deck']!r} (looked for {deck})",
                    "the path is relative to the study file")
    return make_study(deck, data.get("grid"), str(data.get("description", "")), path,
                      data.get("sensitivities", False))


def make_study(deck, grid: dict, description: str = "", path=None, sensitivities: bool = False) -> Study:
    """A study from Python: ``deck`` (path) and ``grid`` (name → list), validated as a study file is;
    ``sensitivities`` (bool): every case also differentiates the deck's ``[sensitivities]`` table.

    E.g. a convergence study, ``run_study(make_study("models/embedded_beam.toml",
    {"refine": [1, 2, 4, 8]}), "out/convergence")``.
    """
    deck = Path(deck).resolve()
    path = Path(path) if path is not None else deck
    if not deck.is_file():
        raise _fail(path, "deck", f"no such deck file {str(deck)!r}")
    if not isinstance(grid, dict) or not grid:
        raise _fail(path, "grid", "missing or empty [grid] table", "e.g. [grid] with refine = [1, 2]")
    for name, values in grid.items():
        entry = f"grid.{name}"
        if not isinstance(values, list) or not values:
            raise _fail(path, entry, f"expected a non-empty list of values, got {values!r}", f"e.g. {name} = [1, 2]")
        for v in values:
            if isinstance(v, (dict, list)):
                raise _fail(path, entry, f"expected single values (numbers, strings, booleans), got {v!r}")
        if name not in DECK_OVERRIDES and name not in SOLVER_KEYS and "." not in name:
            raise _fail(path, entry, "unknown name",
                        f"use {', '.join(DECK_OVERRIDES + SOLVER_KEYS)} or a deck value's dotted name "
                        "(e.g. sections.NAME.EI2)")
    if not isinstance(sensitivities, bool):
        raise _fail(path, "sensitivities", f"expected true or false, got {sensitivities!r}",
                    "write sensitivities = true to differentiate the deck's [sensitivities] at every case")
    study = Study(path, deck, dict(grid), description, sensitivities)
    from reference.io.deck import load_deck

    try:
        first = load_deck(deck, overrides=deck_overrides(next(combinations(study))))
    except DeckError as exc:
        if path == deck:
            raise
        raise DeckError(f"{path}: grid (first case): {exc}") from None
    if sensitivities and not first.sensitivities:
        raise _fail(path, "sensitivities", f"the deck {deck.name} has no [sensitivities] table",
                    "add one with parameters = [...] and outputs = [...] (docs/deck.md), or drop sensitivities")
    return study


def combinations(study: Study):
    """Every combination of the grid, as ``{name: value}`` (the last name varying fastest), one at a time."""
    names = list(study.grid)
    return (dict(zip(names, combo)) for combo in itertools.product(*(study.grid[n] for n in names)))


def cases(study: Study) -> list[dict]:
    """Every combination of the grid (:func:`combinations`) as a list."""
    return list(combinations(study))


def n_cases(study: Study) -> int:
    """The number of cases: the product of the grid's lengths."""
    return math.prod(len(values) for values in study.grid.values())


def deck_overrides(case: dict) -> dict:
    """A case's grid values as the deck reader's overrides (bare solver keys → ``solver.NAME``)."""
    return {(f"solver.{k}" if k in SOLVER_KEYS else k): v for k, v in case.items()}


def case_values(deck, results) -> dict:
    """The numbers recorded for a case in ``summary.csv``.

    The final time, the final energies (kinetic, strain, external work,
    dissipated), the largest constraint violation ‖Φ‖, and for each of the
    deck's (:class:`reference.io.deck.Deck`) ``[checks.NAME]`` with an ``observable``
    (``docs/observables.md``) its value at the final time: ``check.NAME`` for a scalar,
    ``check.NAME.x`` … for the components of a vector (:data:`CHECK_PREFIX`).  A check with a
    ``node`` but no observable gives that node's final position.
    """
    from reference.observables import parse

    out = {"t_final": float(results.time[-1])}
    for key, series in results.energy.items():
        out[f"{key}_final"] = float(series[-1])
    out["max_violation"] = float(results.constraint_violation.max()) if len(results.constraint_violation) else 0.0
    for name, spec in deck.checks.items():
        if not isinstance(spec, dict):
            continue
        text = spec.get("observable")
        if text is None and isinstance(spec.get("node"), str):
            text = f"position:{spec['node']}"
        if not isinstance(text, str):
            continue
        try:
            observable = parse(text, deck.domain)
            value = np.asarray(observable.evaluate(results), dtype=float)[-1]
        except (ValueError, KeyError, IndexError, AttributeError):  # not computable from these results
            continue
        add_columns(out, CHECK_PREFIX + str(name), value, observable.kind)
    return out


def add_columns(out: dict, column: str, value, kind: str) -> None:
    """An observable's value at one time into the row ``out``: ``column`` for a scalar, ``column.x``,
    ``column.y``, … for a vector's components (the observable kind's labels, else 0, 1, …); other shapes none."""
    from reference.observables import KINDS

    value = np.asarray(value, dtype=float)
    if value.ndim == 0:
        out[column] = float(value)
    elif value.ndim == 1:
        comps = KINDS.get(kind, (None, ()))[1]
        labels = comps[: value.size] if len(comps) >= value.size else [str(i) for i in range(value.size)]
        out.update({f"{column}.{c}": float(v) for c, v in zip(labels, value)})


def run_case(deck, case: dict, out_dir, sensitivities: bool = False) -> dict:
    """Run one case in this process; never raises: a failure is the row's status.

    Returns the summary row: the grid values, ``status``, ``wall_time`` [s],
    ``results`` (the file) and :func:`case_values`; with ``sensitivities`` also the deck's
    ``[sensitivities]`` at the case (:func:`flexmbs.sweep_sensitivities.sensitivity_values`).  Its warnings are one line each on stderr (the worker's),
    ``flexmbs: warning: case_NNN: …``, as the command line shows them (:func:`reference.validation.show_warning`).
    """
    from reference.errors import SolverDiverged
    from reference.io.deck import load_deck
    from reference.validation import show_warning

    out_dir = Path(out_dir)
    row = {**case, "status": "completed", "wall_time": math.nan, "results": ""}
    t0 = time.perf_counter()

    def case_warning(message, category, *where, **named):  # one line naming the case, as the command line's
        show_warning(f"{out_dir.name}: {message}", category, *where, **named)

    with warnings.catch_warnings():
        warnings.showwarning = case_warning
        try:
            read = load_deck(deck, overrides=deck_overrides(case))
            out_dir.mkdir(parents=True, exist_ok=True)
            results_path = out_dir / "results.h5"
            results = read.solve(results_path=results_path)
            row["results"] = str(results_path)
            row.update(case_values(read, results))
            if sensitivities:
                from flexmbs.sweep_sensitivities import sensitivity_values

                row.update(sensitivity_values(read, deck, deck_overrides(case), results, results_path, add_columns))
        except (DeckError, SolverDiverged, ValueError, OSError, FloatingPointError) as exc:
            row["status"] = "failed: " + " ".join(str(exc).split())
        except Exception as exc:  # a bug still must not lose the study: record it
            row["status"] = f"failed: {type(exc).__name__}: " + " ".join(str(exc).split())
    row["wall_time"] = time.perf_counter() - t0
    return row


def _client(workers: int | None, scheduler: str | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise DeckError(f"cannot reach the Dask scheduler at {scheduler}: {' '.join(str(exc).split())}; "
                            "start it with `dask scheduler` (and `dask worker ADDRESS`) and give its address, "
                            "e.g. tcp://127.0.0.1:8786, or drop --scheduler") from None
    # the worker processes ignore SIGINT, as the process starting them does while the cluster starts (they
    # inherit it): a Ctrl-C at the terminal, which reaches the whole process group, stops the study here
    # only, which closes the cluster in order.  A Ctrl-C while the cluster starts (a second or two) is
    # ignored; SIGTERM never is.  (Blocking SIGINT meanwhile does not keep it: native threads take it.)
    # Their log (a task cancelled, a busy worker killed, a heartbeat cut when a stopped study closes them) is
    # not shown: a case that fails is its row's status.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        # no dashboard; the scheduler's HTTP server (health, metrics) on a free port, not on 8787, which a
        # second study (or a test worker beside this one) would hold: "Port 8787 is already in use" otherwise
        cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1, processes=True,
                               dashboard_address=None, scheduler_kwargs={"dashboard_address": ":0"},
                               silence_logs=QUIET)
    finally:
        signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster


def run_study(study: Study, out, workers: int | None = None, scheduler: str | None = None,
              progress=None, stop=None) -> list[dict]:
    """Run every case of ``study`` on Dask, writing ``OUT/summary.csv`` as cases finish; return the
    rows of the finished cases (case order).

    The cases are submitted as others finish, :data:`IN_FLIGHT` per worker thread of the cluster.

    Parameters
    ----------
    workers : int, optional
        Processes of the local cluster (default 2); ignored with ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (e.g. ``tcp://127.0.0.1:8786``).
    progress : callable(str), optional
        Called with one line per finished case (default: print to stderr).
    stop : callable() -> bool, optional
        Polled while the cases run (every :data:`POLL` s); when it returns true the cases not finished
        are dropped (the cluster is closed) and the study ends with the rows it has (the
        command's Ctrl-C).

    Whatever ends the study (also an exception, e.g. ``KeyboardInterrupt`` in a notebook), the
    summary holds every case finished by then.
    """
    from dask.distributed import as_completed

    progress = progress or (lambda line: print(line, file=sys.stderr, flush=True))
    stop = stop or (lambda: False)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    total, source = n_cases(study), enumerate(combinations(study))
    summary = out / "summary.csv"
    rows: dict[int, dict] = {}
    write_summary(summary, study, rows)  # an empty summary from the start: a previous study's never remains
    client, cluster = _client(workers, scheduler)
    futures: dict = {}
    try:
        progress(f"flexmbs sweep: {total} cases of {study.deck.name} on "
                 f"{scheduler or f'a local cluster of {workers or 2} workers'}")
        pending, done, unwritten, wait = as_completed(), 0, False, SUMMARY_EVERY
        written = counted = time.monotonic()
        limit = IN_FLIGHT * max(1, sum(client.nthreads().values()))
        while not stop():
            if time.monotonic() - counted > 1.0:  # the workers of an external scheduler come and go
                limit, counted = IN_FLIGHT * max(1, sum(client.nthreads().values())), time.monotonic()
            while len(futures) < limit:
                k, case = next(source, (None, None))
                if case is None:
                    break
                f = client.submit(run_case, str(study.deck), case, str(out / f"case_{k:03d}"), study.sensitivities,
                                  pure=False,
                                  key=f"flexmbs-case-{k}-{time.time_ns()}")
                futures[f] = (k, case)
                pending.add(f)
            if not futures:
                break
            finished = pending.next_batch(block=False)
            if not finished:
                time.sleep(POLL)
            for f in finished:
                k, case = futures.pop(f)
                try:
                    row = f.result()
                except Exception as exc:  # the worker died, or the task could not run
                    row = {**case, "status": f"failed: {type(exc).__name__}: {exc}", "wall_time": math.nan,
                           "results": ""}
                rows[k], done, unwritten = row, done + 1, True
                label = ", ".join(f"{n} = {v}" for n, v in case.items())
                progress(f"[{done}/{total}] case {k} ({label}): {row['status']} in {row['wall_time']:.2f} s")
            if unwritten and time.monotonic() - written > wait:
                t = time.monotonic()
                write_summary(summary, study, rows)
                written, unwritten, wait = time.monotonic(), False, max(SUMMARY_EVERY, 10 * (time.monotonic() - t))
    finally:
        write_summary(summary, study, rows)
        if futures:
            client.cancel(list(futures))
        client.close()
        if cluster is not None:
            cluster.close()
    return [rows[k] for k in sorted(rows)]


def write_summary(path, study: Study, rows: dict) -> None:
    """One row per finished case (``rows``: case number → row), in case order: case number, grid
    values, status, wall time, results file, then the values.

    The file is written beside and renamed over ``path``, so that it is whole at every instant.
    """
    fixed = ["case", *study.grid, "status", "wall_time", "results"]
    extra = sorted({k for r in rows.values() for k in r} - set(fixed))
    path = Path(path)
    partial = path.with_name(path.name + ".part")
    with open(partial, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=fixed + extra)
        w.writeheader()
        for k in sorted(rows):
            w.writerow({"case": k, **{key: (repr(v) if isinstance(v, float) else v) for key, v in rows[k].items()}})
    os.replace(partial, path)


def main(args) -> int:
    """The ``flexmbs sweep`` command; a Ctrl-C or SIGTERM ends it in order: the cases not finished are
    dropped, the summary keeps the finished ones, and one line says how many."""
    from flexmbs.cli import CommandError
    from flexmbs.signals import Stopped, deferred_signals

    study = load_study(args.study)
    summary = Path(args.out) / "summary.csv"
    with deferred_signals() as request:
        rows = run_study(study, args.out, workers=args.workers, scheduler=args.scheduler,
                         stop=lambda: request.signum is not None)
    if request.signum is not None:
        raise Stopped(request.signum) from CommandError(
            f"; {len(rows)} of {n_cases(study)} cases had finished, their rows are in {summary}")
    failed = sum(1 for r in rows if r["status"] != "completed")
    print(f"{len(rows)} cases, {len(rows) - failed} completed, {failed} failed → {summary}")
    return 1 if failed else 0
