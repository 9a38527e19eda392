"""The ``flexmbs`` command: run, modes, campbell, crosscheck, plot, view, report, derive, bench, sweep.

Every failure is one line on stderr, ``flexmbs: error: …``, and its exit status is
chosen by the exception's class (:func:`exit_status`; the first row that matches):

=====================================================  ======  =================================
exception                                              status  meaning
=====================================================  ======  =================================
:class:`RunFailed`                                     1       a run failed (an error inside it)
:class:`reference.errors.SolverDiverged` (and        1       a run diverged or its solver gave
``crosscheck.exudyn_model.ExudynFailed``)                      up (the reference's or Exudyn's)
:class:`reference.io.deck_reader.DeckError`            2       a bad deck or override
:class:`reference.observables.ObservableError`         2       a bad observable text
:class:`reference.io.deck_parameters.ParameterError`   2       a sensitivity the run cannot give
:class:`CommandError`                                  2       any other user error (an option,
                                                               an untranslatable deck …)
``OSError``                                            2       a missing file, an unwritable folder
``KeyError``                                           2       an unknown label (``flexmbs plot``)
:class:`Stopped`, ``KeyboardInterrupt``                128+n   stopped by signal n (SIGINT 130,
                                                               SIGHUP 129, SIGTERM 143)
=====================================================  ======  =================================

A command that completes returns 0, or 1 when what it judged failed (a check of
the report, a cross-check verdict, stale generated code).  Any other exception
is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import math
import os
import signal
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from flexmbs import __version__
from flexmbs.signals import SIGNAL_NAMES, Stopped, install_signal_handlers, check_signals


BACKEND_CHOICES = ("compiled", "reference", "auto")
"""``--backend``: the values of ``[solver] backend`` (:data:`reference.plain.backend.BACKENDS`, not imported: the
command line loads the engine only when a command needs it)."""


class CommandError(Exception):
    """A user error to report in one line, without a traceback (exit status 2)."""


class RunFailed(Exception):
    """A run that failed, reported in one line (exit status 1); ``FLEXMBS_TRACEBACK=1`` shows its cause."""


def _module(name: str, command: str):
    """Import ``name`` for ``command`` lazily; a failed import is one clear line, not a traceback."""
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise CommandError(f"`flexmbs {command}` needs the module {name!r}, which could not be imported "
                           f"({type(exc).__name__}: {exc}); check the installation (make test creates the "
                           "virtual environment)") from None


def cmd_run(args) -> int:
    from reference.io.deck import load_deck

    check_signals()  # a stop that came while the engine's modules loaded
    deck = load_deck(args.deck, overrides=_overrides(args))
    _refuse_dt_without_a_step(args, deck)
    _run_deck(args, deck)
    return 0


def _refuse_dt_without_a_step(args, deck) -> None:
    """``--dt`` for an algorithm that takes no time step (static, modes, buckling, arc length): the step would be
    ignored and the output interval scaled by it (a static run's outputs thinned), so it is refused in one line."""
    from reference.algorithms import ALGORITHMS
    from reference.io.deck_reader import DeckError

    if getattr(args, "dt", None) is None:
        return
    algorithm = deck.domain.solver.algorithm
    keys = (*ALGORITHMS[algorithm].deck_required, *ALGORITHMS[algorithm].deck_optional)
    if "dt" in keys:
        return
    step = ("; its load step is t_end / load_steps: set solver.load_steps" if "load_steps" in keys
            else "; its step is solver.arc_length" if "arc_length" in keys else "")
    raise DeckError(f"{args.deck}: dt override (--dt): algorithm = \"{algorithm}\" has no time step to override; "
                    f"drop --dt{step}")


def _overrides(args) -> dict:
    return {k: v for k, v in (("t_end", args.t_end), ("dt", getattr(args, "dt", None)), ("refine", args.refine),
                              ("solver.backend", getattr(args, "backend", None))) if v is not None}


def _run_deck(args, deck):
    """Solve a loaded deck into ``--out`` (results file, ParaView file) with a progress bar, as ``flexmbs run``;
    the model's warnings end the bar's line first.  Returns the results."""
    from flexmbs.progress import ProgressBar
    from reference.io.vtk import write_vtk
    from reference.jit import CompileTimer
    from reference.errors import SolverDiverged
    from reference.validation import show_warning

    domain = deck.domain
    out = Path(args.out) if args.out else Path("out") / Path(args.deck).stem
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "results.h5"
    t0 = time.perf_counter()
    bar = ProgressBar(domain.name)

    def progress(fraction: float, t: float) -> None:
        check_signals()  # every output: a stop lost while the kernels loaded ends the run here
        bar(fraction, t)

    def warning_line(*shown, **named) -> None:
        bar.close()  # a warning during the run (a change of stability) on a line of its own
        show_warning(*shown, **named)

    def compiling() -> None:
        bar.close()
        print("compiling the kernels (once for this version of the engine: a few minutes)…", file=sys.stderr,
              flush=True)

    if domain.solver.backend == "auto":  # the rule's decision and why, before the run (no bar yet)
        from reference.plain.backend import for_domain

        print(for_domain(domain).line, flush=True)
    shown_before, warnings.showwarning = warnings.showwarning, warning_line
    timer = CompileTimer(compiling)
    try:
        check_signals()
        with timer:
            started = time.perf_counter()
            result = deck.solve(results_path=results_path, progress=progress)
            solving = time.perf_counter() - started
    except SolverDiverged as exc:
        raise RunFailed(f"{args.deck}: {exc} (results file: {results_path})") from None
    except (Stopped, KeyboardInterrupt) as exc:
        run = getattr(domain, "last_run", {}) or {}
        where = (f"; results up to {run.get('where') or 't = %.6g' % run['t']} are kept in {run['path']} (status "
                 f"{run['status']!r})") if run.get("path") and Path(run["path"]).exists() else ""
        raise Stopped(getattr(exc, "signum", signal.SIGINT)) from CommandError(where)
    except Exception as exc:
        run = getattr(domain, "last_run", {}) or {}
        at = run.get("where") or f"t = {run.get('t', 0.0):.6g}"
        where = f"; results up to {at} are kept in {run['path']}" if run.get("path") else ""
        raise RunFailed(f"{args.deck}: the run failed at {at}: "
                           f"{type(exc).__name__}: {exc}{where} (status 'failed')") from exc
    finally:
        warnings.showwarning = shown_before
        bar.close()
    wall = time.perf_counter() - t0
    check_signals()
    pvd = None
    if args.vtk_every > 0:
        pvd = write_vtk(domain, result, out / "vtk", domain.name, every=args.vtk_every)
    # the solve is the whole call less the kernels' compilation inside it (which may also come before its
    # solution loop, where result.wall_time starts: subtracting it from that printed a negative solve)
    print(f"{domain.name}: {len(result.time)} outputs to t = {result.time[-1]:g} in {wall:.2f} s "
          f"(solve {solving - timer.seconds:.3f} s"
          + (f", compiling the kernels {timer.seconds:.1f} s" if timer.kernels else "") + f") → {results_path}"
          + (f", {pvd}" if pvd else ""))
    solver = (getattr(domain, "last_run", {}) or {}).get("solver")
    line = domain.algorithm().summary(solver) if solver is not None else ""
    if line:
        print(f"{domain.name}: {line}")
    if deck.sensitivities:
        _write_sensitivities(args, deck, results_path)
    return result


def _write_sensitivities(args, deck, results_path) -> None:
    """The deck's ``[sensitivities]`` into the results file (``/sensitivities/…``, docs/results.md), from a second
    run on the reference path that differentiates every step (:mod:`reference.io.deck_sensitivities`)."""
    from reference.io.deck_sensitivities import sensitivity_datasets
    from reference.io.results import append_datasets

    started = time.perf_counter()
    datasets = sensitivity_datasets(args.deck, deck.sensitivities, _overrides(args))
    append_datasets(results_path, datasets)
    print(f"{deck.domain.name}: {len(deck.sensitivities['parameters'])} parameter sensitivities "
          f"in {time.perf_counter() - started:.2f} s → {results_path} (/sensitivities)")


def cmd_modes(args) -> int:
    from reference.io.deck import load_deck

    check_signals()
    deck = load_deck(args.deck, overrides=_overrides(args))
    _refuse_dt_without_a_step(args, deck)
    algo = deck.domain.algorithm()
    if not algo.linearised:
        raise CommandError(f"{args.deck}: solver.algorithm is {algo.name!r}; `flexmbs modes` runs a deck with "
                           "algorithm = \"modes\" or \"buckling\" (use `flexmbs run` for the others)")
    result = _run_deck(args, deck)
    for line in algo.table(result):
        print(line)
    return 0


def cmd_campbell(args) -> int:
    from flexmbs import campbell
    from reference.io.deck import load_deck

    check_signals()
    try:
        rates = campbell.parse_rates(args.rates)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    deck = load_deck(args.deck, overrides=_overrides(args))
    if deck.domain.solver.algorithm != "modes" or deck.domain.solver.about != "rotation":
        raise CommandError(f"{args.deck}: `flexmbs campbell` needs a modes deck about a steady rotation; set "
                           "[solver] algorithm = \"modes\", about = \"rotation\" with spin_rate and spin_axis")
    result = _run_deck(args, deck)
    try:
        table = campbell.campbell(deck.domain, rates)
    except ValueError as exc:
        raise RunFailed(f"{args.deck}: {exc}") from None
    out = Path(result.source).parent
    campbell.write(result.source, table)
    for line in table.table():
        print(line)
    if args.plot:
        campbell.figure(table, out / "campbell.png", f"Campbell diagram: {deck.domain.name}")
        print(f"campbell diagram → {out / 'campbell.png'}; datasets /campbell/* → {result.source}")
    return 0


def cmd_derive(args) -> int:
    derivations = _module("derivations", "derive")

    if args.check:
        stale = derivations.stale()
        if stale:
            print(f"flexmbs: generated code is stale: reference/generated/{{{', '.join(stale)}}} differ from a "
                  "fresh derivation; run `flexmbs derive` (or `make derive`) and commit the result", file=sys.stderr)
            return 1
        print("reference/generated/ is up to date with derivations/")
        return 0
    for path in derivations.write():
        print(f"wrote {path}")
    return 0


def cmd_crosscheck(args) -> int:
    exudyn_model = _module("crosscheck.exudyn_model", "crosscheck")
    harness = _module("crosscheck.harness", "crosscheck")
    from reference.observables import ObservableError
    from flexmbs.progress import ProgressBar

    refine = args.refine or 1
    # a refined run has its own folder (and figure name): it never overwrites the unrefined run's files
    default = (Path(args.deck).stem + "_crosscheck" + (f"_refine{refine}" if refine != 1 else "")
               + (f"_{args.element}" if args.element else ""))
    out = Path(args.out) if args.out else Path("out") / default
    if _linearised(args.deck):
        if args.element:
            raise CommandError(f"{args.deck}: --element compares time histories on converged meshes; a modes or "
                               "buckling deck is compared on its own mesh: drop --element")
        return _crosscheck_modes(args, out, refine, exudyn_model)
    reduced = _module("crosscheck.reduced_crosscheck", "crosscheck")
    if reduced.is_reduced(args.deck):
        return _crosscheck_reduced(args, refine, exudyn_model, reduced)
    path = _module("crosscheck.path_crosscheck", "crosscheck")
    if path.is_path(_domain(args.deck)):
        return _crosscheck_path(args, out, refine, exudyn_model, path)
    try:
        with _exudyn_errors(args.deck, exudyn_model):
            harness.check_refine(args.deck, refine, args.element)  # before anything runs
            cmp = harness.run(args.deck, out, refine=refine, exudyn_dt=args.exudyn_dt, t_end=args.t_end,
                              progress=ProgressBar("reference"), exudyn_progress=ProgressBar("Exudyn   "),
                              element=args.element)
    except (ObservableError, harness.NoCheckAtRefine) as exc:
        raise CommandError(f"{args.deck}: {exc}") from None
    if cmp.get("converged"):
        print(f"converged meshes: Exudyn has no element of this family; its own beam refined ×{cmp['converged']} "
              "against the reference's mesh")
    if cmp.get("default"):
        print("the deck has no [crosscheck] table: compared every node's position (default, 1 % of the length)")
    failed = [v for v in cmp["verdicts"] if not v.passed]
    for v in cmp["verdicts"]:
        print(f"{'pass' if v.passed else 'FAIL'}  {v.observable}: {v.measure:.3e} (tolerance {v.tolerance:g}, "
              f"relative to {v.relative_to})")
    print(f"solve times: reference {cmp['reference'].wall_time:.3g} s (warm: after a two-step solve that loads its "
          f"kernels), Exudyn {cmp['exudyn_wall']:.3g} s → {out / 'crosscheck.md'}, {cmp['figure']}")
    return 1 if failed else 0


def _linearised(deck) -> bool:
    return bool(_domain(deck).algorithm().linearised)


def _domain(deck):
    from reference.io.deck import load_deck

    return load_deck(deck).domain


@contextlib.contextmanager
def _exudyn_errors(deck, exudyn_model):
    """Exudyn's refusals and failures as the command's one-line errors (status 2 and 1)."""
    try:
        yield
    except exudyn_model.Unsupported as exc:
        raise CommandError(f"{deck}: cannot be cross-checked in Exudyn: {exc}") from None
    except exudyn_model.ExudynFailed as exc:
        raise RunFailed(f"{deck}: {exc}") from None


def _crosscheck_path(args, out: Path, refine: int, exudyn_model, path) -> int:
    """An arc-length deck: its pre-limit path against Exudyn's static solver (:mod:`crosscheck.path_crosscheck`).
    A deck with beams of a family Exudyn lacks (Lee's frame: beam3) is compared with Exudyn's own beam on
    :data:`crosscheck.harness.CONVERGED_REFINE` × its elements, as the harness compares a time history."""
    from flexmbs.progress import ProgressBar

    converged = _module("crosscheck.harness", "crosscheck").CONVERGED_REFINE
    same = all(e.formulation.family in exudyn_model.EXUDYN_ELEMENTS for e in _domain(args.deck).elements)
    if not same:
        print(f"converged meshes: Exudyn has no element of this family; its own beam refined ×{converged} "
              "against the reference's mesh")
    with _exudyn_errors(args.deck, exudyn_model):
        cmp = path.run(args.deck, out, overrides={"refine": refine} if refine != 1 else None,
                       refine=1 if same else converged, progress=ProgressBar("reference"),
                       exudyn_progress=ProgressBar("Exudyn   "))
    for line in cmp["lines"]:
        print(line)
    return 0 if cmp["passed"] else 1


def _crosscheck_reduced(args, refine: int, exudyn_model, reduced) -> int:
    """A deck with reduced beams: flexmbs's reduced run against Exudyn's ObjectFFRFreducedOrder built from the same
    modes and invariants (:mod:`crosscheck.reduced_crosscheck`)."""
    if refine != 1 or args.element:
        raise CommandError(f"{args.deck}: a reduced beam is compared on its own mesh and modes: drop --refine and "
                           "--element")
    with _exudyn_errors(args.deck, exudyn_model):
        cmp = reduced.run(args.deck, t_end=args.t_end)
    for v in cmp["verdicts"]:
        print(f"{'pass' if v.passed else 'FAIL'}  {v.observable}: {v.measure:.3e} (tolerance {v.tolerance:g}, "
              f"relative to {v.relative_to}; Exudyn ObjectFFRFreducedOrder, same modes and invariants)")
    print(f"solve times: reference {cmp['reference'].wall_time:.3g} s, Exudyn {cmp['exudyn']['wall_time']:.3g} s")
    return 0 if all(v.passed for v in cmp["verdicts"]) else 1


def _crosscheck_modes(args, out: Path, refine: int, exudyn_model) -> int:
    """A modes deck: its frequencies against Exudyn's eigen-solve (:mod:`crosscheck.modes_crosscheck`)."""
    compare = _module("crosscheck.modes_crosscheck", "crosscheck")
    with _exudyn_errors(args.deck, exudyn_model):
        cmp = compare.run(args.deck, out, refine)
    for line in cmp["lines"]:
        print(line)
    worst = max(abs(float(d)) for d in cmp["differences"])
    passed = worst <= compare.TOLERANCE
    print(f"{'pass' if passed else 'FAIL'}  frequencies, same mass: largest relative difference {worst:.3e} "
          f"(tolerance {compare.TOLERANCE:g})")
    return 0 if passed else 1


def cmd_plot(args) -> int:
    from reference.observables import ObservableError

    try:
        return _module("flexmbs.plot", "plot").main(args)
    except ObservableError as exc:
        raise CommandError(f"{args.results}: --observable: {exc}") from None


def cmd_view(args) -> int:
    return _module("flexmbs.view", "view").main(args)


def cmd_report(args) -> int:
    return _module("flexmbs.report", "report").main(args)


def cmd_bench(args) -> int:
    return _module("flexmbs.bench", "bench").main(args)


def cmd_sweep(args) -> int:
    _module("dask.distributed", "sweep")
    if args.out is None:
        args.out = str(Path("out") / Path(args.study).stem)
    return _module("flexmbs.sweep", "sweep").main(args)


class Parser(argparse.ArgumentParser):
    """argparse with every error in one line, ``flexmbs run: error: argument --dt: …; see flexmbs run --help``
    (exit 2), in place of the usage block."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}; see {self.prog} --help\n")


def number(kind: type = float, low: float = 0.0, *, low_ok: bool = False, high=None,
           example: str = "") -> Callable[[str], float]:
    """An argparse ``type=`` for a numeric option: an ``int`` or ``float`` (ASCII digits), finite, above
    ``low`` (or equal to it with ``low_ok``) and at most ``high`` (a number, or a callable giving
    ``(bound, why)``); anything else is an ``ArgumentTypeError`` naming the value, the range and ``example``."""
    noun = "a whole number" if kind is int else "a number"

    def read(text: str):
        bound, why = high() if callable(high) else (high, "")
        wanted = f"{noun} {'≥' if low_ok else '>'} {low:g}" + ("" if bound is None else f" and ≤ {bound:g}{why}")
        try:
            if not text.strip().isascii():
                raise ValueError(text)
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or value < low or (value == low and not low_ok) or \
                (bound is not None and value > bound):
            raise argparse.ArgumentTypeError(f"{text[:40]!r} is not {wanted}; give e.g. {example}")
        return value

    read.__name__ = noun  # argparse's name of the type
    return read


def _workers_bound() -> tuple[int, str]:
    cpus = os.cpu_count() or 1
    return 4 * cpus, f" (four per CPU; this machine has {cpus})"


def animation_name(text: str) -> str:
    """``--animate``: a file name ending in ``.gif`` (the animation is written as a GIF), checked before any
    frame is drawn."""
    if Path(text).suffix.lower() != ".gif" or not Path(text).stem:
        raise argparse.ArgumentTypeError(f"{text[:80]!r}: the animation is written as a GIF; give a name "
                                         "ending in .gif, e.g. --animate motion.gif")
    return text


def view_name(text: str) -> str:
    """``view --out``: a file name ending in ``.html`` (the view is one HTML page)."""
    if Path(text).suffix.lower() not in (".html", ".htm") or not Path(text).stem:
        raise argparse.ArgumentTypeError(f"{text[:80]!r}: the view is one HTML page; give a name ending in .html, "
                                         "e.g. --out three_bar.html")
    return text


def scheduler_address(text: str) -> str:
    """``--scheduler``: ``[PROTOCOL://]HOST:PORT`` of a Dask scheduler (the port is required)."""
    host, _, port = text.rpartition("://")[2].rpartition(":")
    if not host or not port.isascii() or not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(f"{text[:80]!r} is not a scheduler address with a port; give e.g. "
                                         "tcp://127.0.0.1:8786 (`dask scheduler` prints its address)")
    return text


def parser() -> argparse.ArgumentParser:
    p = Parser(prog="flexmbs", description="Flexible multibody dynamics: reference engine, "
               "Exudyn cross-check, verification report.")
    p.add_argument("--version", action="version", version=f"flexmbs {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a model deck with the reference engine")
    run.add_argument("deck")
    run.add_argument("--out", help="output folder (default out/<deck name>)")
    run.add_argument("--t-end", type=number(example="--t-end 0.5"), help="end time, overriding the deck's")
    run.add_argument("--dt", type=number(example="--dt 1e-4"), help="time step, overriding the deck's")
    run.add_argument("--refine", type=number(int, 1, low_ok=True, example="--refine 2"),
                     help="multiply every beam's element count (the step shrinks with it)")
    run.add_argument("--no-vtk", dest="vtk_every", action="store_const", const=0, default=1,
                     help="skip the ParaView output")
    run.add_argument("--vtk-every", type=number(int, 0, low_ok=True, example="--vtk-every 10"), default=1,
                     metavar="N", help="ParaView output of every N-th output record (default 1; 0: none)")
    run.add_argument("--backend", choices=BACKEND_CHOICES,
                     help="the implementation that runs the algorithm, overriding the deck's solver.backend: "
                          "compiled (numba kernels), reference (plain NumPy, no compilation) or auto")
    run.set_defaults(func=cmd_run)
    mod = sub.add_parser("modes", help="a modes or buckling deck: its table, and the results file as `run` writes it")
    mod.add_argument("deck")
    mod.add_argument("--out", help="output folder (default out/<deck name>)")
    mod.add_argument("--t-end", type=number(example="--t-end 2"),
                     help="end of the static path (load factor 1 of buckling), overriding the deck's")
    mod.add_argument("--refine", type=number(int, 1, low_ok=True, example="--refine 2"),
                     help="multiply every beam's element count")
    mod.add_argument("--no-vtk", dest="vtk_every", action="store_const", const=0, default=1,
                     help="skip the ParaView output of the configuration")
    mod.add_argument("--backend", choices=BACKEND_CHOICES, help="as for `flexmbs run`")
    mod.set_defaults(func=cmd_modes)
    cb = sub.add_parser("campbell", help="a modes deck about a steady rotation over a range of spin rates: table, "
                        "figure, /campbell/* in the results file")
    cb.add_argument("deck")
    cb.add_argument("--rates", required=True, metavar="START:STOP:N",
                    help="N equally spaced spin rates [rad/s] from START to STOP, e.g. 0:12:13")
    cb.add_argument("--out", help="output folder (default out/<deck name>)")
    cb.add_argument("--refine", type=number(int, 1, low_ok=True, example="--refine 2"),
                    help="multiply every beam's element count")
    cb.add_argument("--no-plot", dest="plot", action="store_false", help="skip the figure campbell.png")
    cb.set_defaults(func=cmd_campbell, vtk_every=0, t_end=None)
    cc = sub.add_parser("crosscheck", help="run a deck in the reference and in Exudyn and compare")
    cc.add_argument("deck")
    cc.add_argument("--out", help="output folder (default out/<deck name>_crosscheck)")
    cc.add_argument("--refine", type=number(int, 1, low_ok=True, example="--refine 2"),
                    help="multiply every flexible beam's element count")
    cc.add_argument("--exudyn-dt", type=number(example="--exudyn-dt 0.001"), help="Exudyn's step (default: the deck's)")
    cc.add_argument("--t-end", type=number(example="--t-end 0.5"), help="end time, overriding the deck's")
    cc.add_argument("--element", metavar="FAMILY",
                    help="the reference's element family for every flexible beam (beam2, beam2_se3, beam3); a family Exudyn lacks is "
                    "compared on converged meshes (Exudyn's own beam refined)")
    cc.set_defaults(func=cmd_crosscheck)
    pl = sub.add_parser("plot", help="time histories, drift, energies and an animation from a results file")
    pl.add_argument("results")
    pl.add_argument("--node", action="append", help="node label (repeatable)")
    pl.add_argument("--observable", action="append", metavar="EXPR",
                    help="any observable, e.g. 'reaction_moment.z:crank drive' (repeatable; docs/observables.md)")
    pl.add_argument("--path", action="append", metavar="EXPR",
                    help="arc-length runs: the load factor against a scalar observable, e.g. 'position.z:apex', "
                    "limit and bifurcation points marked (repeatable)")
    pl.add_argument("--load", metavar="EXPR",
                    help="--path's load axis: a scalar observable in place of the load factor, e.g. "
                    "'prescribed_reaction:push' (a static run under displacement control)")
    pl.add_argument("--sensitivity", action="append", metavar="OUTPUT",
                    help="a static or generalized-α run's sensitivities of an output of the deck's [sensitivities] table "
                    "to every parameter, against the load factor or time, e.g. 'position:beam:end' (repeatable)")
    pl.add_argument("--drift", action="store_true", help="constraint violation history")
    pl.add_argument("--energy", action="store_true", help="energy histories")
    pl.add_argument("--animate", metavar="NAME.gif", type=animation_name,
                    help="animation of the motion: bodies, springs, dampers, joints and the ground, fitted to it")
    pl.add_argument("--every", type=number(int, 1, low_ok=True, example="--every 5"), default=1,
                    help="animate every n-th output")
    pl.add_argument("--magnify", type=number(example="--magnify 50"), default=1.0,
                    help="animation: multiply the beams' deflection from their chord (e.g. 50, as the paper's Fig. 14)")
    pl.add_argument("--mode", type=number(int, 1, low_ok=True, example="--mode 1"), metavar="K",
                    help="mode K (from 1) of a modes or buckling results file as an animated ParaView file "
                    "NAME_modeK.vtkhdf (with --animate: the GIF shows the mode)")
    pl.add_argument("--out", help="folder for the figures (default: the results file's path without .h5, "
                    "e.g. out/three_bar/results/ for out/three_bar/results.h5)")
    pl.set_defaults(func=cmd_plot)
    vw = sub.add_parser("view", help="an interactive 3D view of a results file: one HTML file that works offline")
    vw.add_argument("results")
    vw.add_argument("--out", metavar="FILE.html", type=view_name,
                    help="the page to write (default: the results file's path with .html, e.g. out/three_bar/results.html)")
    vw.add_argument("--max-frames", type=number(int, 2, low_ok=True, example="--max-frames 200"), metavar="N",
                    help="show every k-th output so that at most N frames remain (default: every output)")
    vw.set_defaults(func=cmd_view)
    rep = sub.add_parser("report", help="the verification report → reports/")
    rep.add_argument("--quick", action="store_true", help="reduced version (for the tests)")
    rep.add_argument("--out", help="report folder (default reports/)")
    rep.set_defaults(func=cmd_report)
    der = sub.add_parser("derive", help="regenerate reference/generated/ from derivations/")
    der.add_argument("--check", action="store_true", help="fail if the committed generated code is stale")
    der.set_defaults(func=cmd_derive)
    ben = sub.add_parser("bench", help="solve times of flexmbs and Exudyn, side by side")
    ben.add_argument("--repeat", type=number(int, 1, low_ok=True, example="--repeat 3"), default=3,
                     help="timed rounds of each case (median; default 3)")
    ben.add_argument("--quick", action="store_true", help="fewer steps in the work-precision part")
    ben.add_argument("--large", action="store_true",
                     help="only the large models (50,000-element explicit, 5,004-element static and generalized-alpha, "
                          "thread scaling); with --quick on small meshes")
    ben.add_argument("--first-run", action="store_true",
                     help="only the first-run table: every deck's `flexmbs run` from an empty numba cache beside its "
                          "warm rerun, each in a process of its own (minutes: the long explicit decks compile)")
    ben.add_argument("--out", help="folder of the work-precision figure and tables (default: out/bench/)")
    ben.set_defaults(func=cmd_bench)
    sw = sub.add_parser("sweep", help="a parameter study of a deck (STUDY.toml), every case a Dask task")
    sw.add_argument("study")
    sw.add_argument("--out", help="output folder: one folder per case and summary.csv (default out/<study name>)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=number(int, 1, low_ok=True, high=_workers_bound, example="--workers 2"),
                       help="processes of the local Dask cluster (default 2)")
    where.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                       help="address of a running Dask scheduler, e.g. "
                       "tcp://127.0.0.1:8786")
    sw.set_defaults(func=cmd_sweep)
    return p


MESSAGE_CHARS = 1000
"""Longest error line; anything longer is cut (the deck reader keeps its own to ~300)."""


def exit_status(exc: BaseException) -> int | None:
    """The exit status of a failure by its exception's class (the module docstring's table);
    ``None`` for an exception that is not an expected failure (a bug: its traceback is kept)."""
    from reference.io.deck_parameters import ParameterError
    from reference.io.deck_reader import DeckError
    from reference.observables import ObservableError
    from reference.errors import SolverDiverged

    table = ((RunFailed, 1), (SolverDiverged, 1), (DeckError, 2), (ObservableError, 2), (ParameterError, 2),
             (CommandError, 2), (OSError, 2), (KeyError, 2))
    return next((status for cls, status in table if isinstance(exc, cls)), None)


def one_line(exc: BaseException) -> str:
    """The failure's message on one line of at most :data:`MESSAGE_CHARS` characters."""
    message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
    message = " ".join(str(message).split())
    return message if len(message) <= MESSAGE_CHARS else message[: MESSAGE_CHARS - 1] + "…"


def main(argv=None) -> int:
    """The command; every failure is one line on stderr with the exit status of the module docstring's
    table (2 a user error, 1 a failed run, 128 + the signal number when stopped)."""
    install_signal_handlers()
    try:
        args = parser().parse_args(argv)
        from reference.validation import show_warning

        warnings.showwarning = show_warning  # a model's warning is one line (reference/validation.py)

        try:
            from reference.jit import threads

            try:
                threads()
            except ValueError as exc:
                raise CommandError(f"{exc}; unset it or give e.g. FLEXMBS_THREADS=2") from None
            return args.func(args)
        except Exception as exc:
            status = exit_status(exc)
            if status is None:
                raise
            print(f"flexmbs: error: {one_line(exc)}", file=sys.stderr)
            if os.environ.get("FLEXMBS_TRACEBACK") and isinstance(exc, RunFailed) and exc.__cause__:
                raise
            return status
    except (Stopped, KeyboardInterrupt) as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        where = str(exc.__cause__) if isinstance(exc.__cause__, CommandError) else ""
        word = "interrupted" if signum == signal.SIGINT else f"terminated ({SIGNAL_NAMES.get(signum, signum)})"
        try:
            print(f"flexmbs: {word}{where}", file=sys.stderr)
        except (Stopped, KeyboardInterrupt, OSError):
            pass
        return 128 + int(signum)
