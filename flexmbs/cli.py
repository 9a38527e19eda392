"""The ``flexmbs`` command: run, crosscheck, report, derive, bench, sweep."""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import time
import warnings
from pathlib import Path

from flexmbs import __version__

SIGNAL_NAMES = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "SIGHUP"}


class CommandError(Exception):
    """An error to report in one line, without a traceback."""


def _module(name: str, command: str):
    """Import ``name`` for ``command`` lazily; a failed import is one clear line, not a traceback."""
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise CommandError(f"`flexmbs {command}` needs the module {name!r}, which could not be imported "
                           f"({type(exc).__name__}: {exc}); check the installation (make test creates the "
                           "virtual environment)") from None


class Stopped(BaseException):
    """A run stopped by a signal (SIGINT, SIGTERM, SIGHUP); ``signum`` says which."""

    def __init__(self, signum: int):
        super().__init__(SIGNAL_NAMES.get(signum, str(signum)))
        self.signum = signum


def _stop(signum, frame):
    """The first SIGINT, SIGTERM or SIGHUP stops the command (as Ctrl-C does); later ones are ignored,
    so that the results file is closed and one message printed."""
    for sig in SIGNAL_NAMES:
        signal.signal(sig, signal.SIG_IGN)
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Stopped(signum)


def install_signal_handlers() -> None:
    for sig in SIGNAL_NAMES:
        signal.signal(sig, _stop)


def cmd_run(args) -> int:
    from flexmbs.progress import ProgressBar
    from reference.domain import Domain, SolverDiverged
    from reference.io.vtk import write_vtk

    overrides = {k: v for k, v in (("t_end", args.t_end), ("dt", args.dt), ("refine", args.refine)) if v is not None}
    domain = Domain.from_deck(args.deck, overrides=overrides)
    out = Path(args.out) if args.out else Path("out") / Path(args.deck).stem
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "results.h5"
    t0 = time.perf_counter()
    bar = ProgressBar(domain.name)
    try:
        result = domain.solve(results_path=results_path, progress=bar)
    except SolverDiverged as exc:
        raise CommandError(f"{args.deck}: {exc} (results file: {results_path})") from None
    except (Stopped, KeyboardInterrupt) as exc:
        run = getattr(domain, "last_run", {}) or {}
        where = (f"; results up to t = {run['t']:.6g} are kept in {run['path']} (status "
                 f"{run['status']!r})") if run.get("path") and Path(run["path"]).exists() else ""
        raise Stopped(getattr(exc, "signum", signal.SIGINT)) from CommandError(where)
    except Exception as exc:
        run = getattr(domain, "last_run", {}) or {}
        where = f"; results up to t = {run['t']:.6g} are kept in {run['path']}" if run.get("path") else ""
        raise CommandError(f"{args.deck}: the run failed at t = {run.get('t', 0.0):.6g}: "
                           f"{type(exc).__name__}: {exc}{where} (status 'failed')") from exc
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    pvd = None
    if args.vtk_every > 0:
        pvd = write_vtk(domain, result, out / "vtk", domain.name, every=args.vtk_every)
    print(f"{domain.name}: {len(result.time)} outputs to t = {result.time[-1]:g} in {wall:.2f} s "
          f"(solve {result.wall_time:.3f} s) → {results_path}" + (f", {pvd}" if pvd else ""))
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
    Unsupported = _module("crosscheck.exudyn_model", "crosscheck").Unsupported
    run = _module("crosscheck.harness", "crosscheck").run
    from reference.observables import ObservableError
    from flexmbs.progress import ProgressBar

    refine = args.refine or 1
    # a refined run has its own folder (and figure name): it never overwrites the unrefined run's files
    default = Path(args.deck).stem + "_crosscheck" + (f"_refine{refine}" if refine != 1 else "")
    out = Path(args.out) if args.out else Path("out") / default
    try:
        cmp = run(args.deck, out, refine=refine, exudyn_dt=args.exudyn_dt, t_end=args.t_end,
                  progress=ProgressBar("reference"), exudyn_progress=ProgressBar("Exudyn   "))
    except Unsupported as exc:
        raise CommandError(f"{args.deck}: cannot be cross-checked in Exudyn: {exc}") from None
    except ObservableError as exc:
        raise CommandError(f"{args.deck}: {exc}") from None
    if cmp.get("default"):
        print("the deck has no [crosscheck] table: compared every node's position (default, 1 % of the length)")
    failed = [v for v in cmp["verdicts"] if not v.passed]
    for v in cmp["verdicts"]:
        print(f"{'pass' if v.passed else 'FAIL'}  {v.observable}: {v.measure:.3e} (tolerance {v.tolerance:g}, "
              f"relative to {v.relative_to})")
    print(f"solve times: reference {cmp['reference'].wall_time:.2f} s (numba compilation included on a first run), "
          f"Exudyn {cmp['exudyn_wall']:.2f} s → {out / 'crosscheck.md'}, {cmp['figure']}")
    return 1 if failed else 0


def cmd_plot(args) -> int:
    from reference.observables import ObservableError

    try:
        return _module("flexmbs.plot", "plot").main(args)
    except ObservableError as exc:
        raise CommandError(f"{args.results}: --observable: {exc}") from None


def cmd_report(args) -> int:
    return _module("flexmbs.report", "report").main(args)


def cmd_bench(args) -> int:
    return _module("flexmbs.bench", "bench").main(args)


def cmd_sweep(args) -> int:
    _module("dask.distributed", "sweep")
    if args.out is None:
        args.out = str(Path("out") / Path(args.study).stem)
    return _module("flexmbs.sweep", "sweep").main(args)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="flexmbs", description="Flexible multibody dynamics: reference engine, "
                                "Exudyn cross-check, verification report.")
    p.add_argument("--version", action="version", version=f"flexmbs {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a model deck with the reference engine")
    run.add_argument("deck")
    run.add_argument("--out", help="output folder (default out/<deck name>)")
    run.add_argument("--t-end", type=float, help="end time, overriding the deck's")
    run.add_argument("--dt", type=float, help="time step, overriding the deck's")
    run.add_argument("--refine", type=int, help="multiply every beam's element count (the step shrinks with it)")
    run.add_argument("--no-vtk", dest="vtk_every", action="store_const", const=0, default=1,
                     help="skip the ParaView output")
    run.add_argument("--vtk-every", type=int, default=1, metavar="N",
                     help="ParaView output of every N-th output record (default 1; 0: none)")
    run.set_defaults(func=cmd_run)
    cc = sub.add_parser("crosscheck", help="run a deck in the reference and in Exudyn and compare")
    cc.add_argument("deck")
    cc.add_argument("--out", help="output folder (default out/<deck name>_crosscheck)")
    cc.add_argument("--refine", type=int, help="multiply every flexible beam's element count")
    cc.add_argument("--exudyn-dt", type=float, help="Exudyn's step (default: the deck's)")
    cc.add_argument("--t-end", type=float, help="end time, overriding the deck's")
    cc.set_defaults(func=cmd_crosscheck)
    pl = sub.add_parser("plot", help="time histories, drift, energies and an animation from a results file")
    pl.add_argument("results")
    pl.add_argument("--node", action="append", help="node label (repeatable)")
    pl.add_argument("--observable", action="append", metavar="EXPR",
                    help="any observable, e.g. 'reaction_moment.z:crank drive' (repeatable; docs/observables.md)")
    pl.add_argument("--drift", action="store_true", help="constraint violation history")
    pl.add_argument("--energy", action="store_true", help="energy histories")
    pl.add_argument("--animate", metavar="NAME.gif", help="animation of the motion")
    pl.add_argument("--every", type=int, default=1, help="animate every n-th output")
    pl.add_argument("--magnify", type=float, default=1.0,
                    help="animation: multiply the beams' deflection from their chord (e.g. 50, as the paper's Fig. 14)")
    pl.add_argument("--out", help="folder for the figures (default: next to the results file)")
    pl.set_defaults(func=cmd_plot)
    rep = sub.add_parser("report", help="the verification report → reports/")
    rep.add_argument("--quick", action="store_true", help="reduced version (for the tests)")
    rep.add_argument("--out", help="report folder (default reports/)")
    rep.set_defaults(func=cmd_report)
    der = sub.add_parser("derive", help="regenerate reference/generated/ from derivations/")
    der.add_argument("--check", action="store_true", help="fail if the committed generated code is stale")
    der.set_defaults(func=cmd_derive)
    ben = sub.add_parser("bench", help="solve times of flexmbs and Exudyn, side by side")
    ben.add_argument("--repeat", type=int, default=3)
    ben.add_argument("--quick", action="store_true", help="fewer steps in the work-precision part")
    ben.add_argument("--out", help="folder of the work-precision figure and tables (default: out/bench/)")
    ben.set_defaults(func=cmd_bench)
    sw = sub.add_parser("sweep", help="a parameter study of a deck (STUDY.toml), every case a Dask task")
    sw.add_argument("study")
    sw.add_argument("--out", help="output folder: one folder per case and summary.csv (default out/<study name>)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="processes of the local Dask cluster (default 2)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="address of a running Dask scheduler, e.g. "
                       "tcp://127.0.0.1:8786")
    sw.set_defaults(func=cmd_sweep)
    return p


MESSAGE_CHARS = 1000
"""Longest error line; anything longer is cut (the deck reader keeps its own to ~300)."""


def main(argv=None) -> int:
    """The command; every failure is one line on stderr: exit 2 for a user error, 1 for an internal
    one, 128 + the signal number when stopped by SIGINT (130), SIGHUP (129) or SIGTERM (143)."""
    install_signal_handlers()
    try:
        args = parser().parse_args(argv)
        from reference.domain import SolverDiverged
        from reference.io.deck import DeckError
        from reference.validation import show_warning

        warnings.showwarning = show_warning  # a model's warning is one line (reference/validation.py)

        try:
            from reference.jit import threads

            try:
                threads()
            except ValueError as exc:
                raise CommandError(f"{exc}; unset it or give e.g. FLEXMBS_THREADS=2") from None
            return args.func(args)
        except (DeckError, SolverDiverged, CommandError, OSError, KeyError) as exc:
            # one line: the deck reader's messages name file, entry and fix; OSError covers a missing
            # deck or an unwritable output folder; KeyError is an unknown node label (flexmbs plot)
            message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
            message = " ".join(str(message).split())
            if len(message) > MESSAGE_CHARS:
                message = message[: MESSAGE_CHARS - 1] + "…"
            print(f"flexmbs: error: {message}", file=sys.stderr)
            if os.environ.get("FLEXMBS_TRACEBACK") and isinstance(exc, CommandError) and exc.__cause__:
                raise
            return 2 if not (isinstance(exc, CommandError) and "the run failed" in str(exc)) else 1
    except (Stopped, KeyboardInterrupt) as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        where = str(exc.__cause__) if isinstance(exc.__cause__, CommandError) else ""
        word = "interrupted" if signum == signal.SIGINT else f"terminated ({SIGNAL_NAMES.get(signum, signum)})"
        try:
            print(f"flexmbs: {word}{where}", file=sys.stderr)
        except (Stopped, KeyboardInterrupt, OSError):
            pass
        return 128 + int(signum)
