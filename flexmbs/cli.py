"""The ``flexmbs`` command: run, crosscheck, report, derive, bench."""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

from flexmbs import __version__


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


def cmd_run(args) -> int:
    from flexmbs.progress import ProgressBar
    from reference.domain import Domain, SolverDiverged
    from reference.io.results import load_results
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
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    pvd = None
    if not args.no_vtk:
        pvd = write_vtk(domain, load_results(results_path), out / "vtk", domain.name)
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
    run.add_argument("--no-vtk", action="store_true", help="skip the ParaView output")
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
    ben.set_defaults(func=cmd_bench)
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    from reference.domain import SolverDiverged
    from reference.io.deck import DeckError

    try:
        return args.func(args)
    except (DeckError, SolverDiverged, CommandError, OSError, KeyError) as exc:
        # one line: the deck reader's messages name file, entry and fix; OSError covers a missing
        # deck or an unwritable output folder; KeyError is an unknown node label (flexmbs plot)
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        message = " ".join(str(message).split())
        print(f"flexmbs: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("flexmbs: interrupted; results written so far are kept", file=sys.stderr)
        return 130
