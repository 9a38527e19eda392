"""Stop ``flexmbs run`` in every way a user or a batch system does, and open what it leaves.

- SIGKILL at random moments from 0 s (still importing) to the end of the run: the results file
  is either absent (killed before it was created) or opens, with its records up to the last flush;
- SIGTERM / SIGHUP / SIGINT during the run: exit 128 + the signal, one line on stderr that names
  the file only when it exists, and a file whose status is ``"terminated at t = …"`` (or
  ``"interrupted at t = …"`` for SIGINT) — explicit, error-controlled generalized-α, arc-length and
  modes runs in turn (:data:`SOLVERS`);
- Ctrl-C at any moment of the start-up: exit 130, at most one line, no traceback, and a results
  file only if its status is ``"interrupted at t = …"``;
- SIGINT / SIGTERM in the middle of a long output interval (the documented example at one output per
  2,000 s, the heavy top under error control at one per 100 s): the run ends within
  :data:`PROMPT` CPU s, as above (every compiled call returns to Python within a fraction of a second).

``python tests/stop_runs.py --kills 20 --terms 10`` (``make signals``) runs the long version,
``--ints 100`` a hundred Ctrl-Cs in the first 2 s (numba loading its cached kernels, then the run);
the test suite runs a few trials of each (``tests/test_signals.py``).
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py

ROOT = Path(__file__).resolve().parent.parent


SOLVERS = {
    "explicit": None,
    "error_controlled": 'algorithm = "generalized_alpha"\ndt = 1e-3\nt_end = 400.0\nerror_tolerance = 1e-6\n'
                        'output_every = 20\n',
    "arc_length": 'algorithm = "arc_length"\narc_length = 1e-4\nmax_points = 1000000\nmax_load_factor = 1e9\n',
    "modes": 'algorithm = "modes"\nmodes = 3\nabout = "static"\nt_end = 1.0\nload_steps = 1000000\n'
             'output_every = 100\n',
}
"""The runs stopped: the documented example's ``[solver]`` (explicit, made long) or in its place an
error-controlled generalized-α run, an arc-length path and modes about a long static path."""
HEAD_START = {"explicit": 0.0, "error_controlled": 3.0, "arc_length": 3.0, "modes": 3.0}
"""Seconds a signal waits after the results file appeared, before its random delay: the implicit
algorithms' kernels load for a second or two after the file is created, and the signal is to stop the
path or the steps, not the loading."""


def deck(tmp: Path, kind: str = "explicit") -> Path:
    """The documented example with the solver ``kind`` (:data:`SOLVERS`), run long enough (seconds) to be
    stopped in the middle."""
    doc = (ROOT / "docs" / "deck.md").read_text()
    text = doc.split("## A small example")[1].split("```toml\n")[1].split("```")[0]
    path = tmp / f"long_{kind}.toml"
    if SOLVERS[kind] is None:
        path.write_text(text.replace("t_end = 0.02 ", "t_end = 400.0 ").replace("output_every = 5", "output_every = 20"))
    else:
        path.write_text(text.split("[solver]")[0] + "[solver]\n" + SOLVERS[kind])
    return path


LONG_INTERVALS = {
    "explicit": None,
    "error control": """[solver]
algorithm = "generalized_alpha"
error_tolerance = 1e-4
dt = 0.01
output_every = 10000
t_end = 1000.0
""",
}
"""Runs whose outputs are far apart (no output in the first seconds): the documented example at one output per
2,000 s (explicit, about 10 s of stepping), the heavy top (models/heavy_top.toml) under error control at one per 100 s."""
PROMPT = 1.0
"""The most CPU seconds the process spends from a signal to its end (issue 38: within 1 s).  CPU time, not wall
time: on a machine shared by many processes the wall time of the same work is several times longer (measured
1.5–2.3 s of wall time at a load of 14 on 2 cores); on an idle machine the two agree."""


def cpu_seconds(pid: int) -> float:
    """CPU time [s] (user + system) a running process has used so far (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def children_cpu() -> float:
    """CPU time [s] of this process's children reaped so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def long_interval_deck(tmp: Path, kind: str) -> Path:
    """A deck of :data:`LONG_INTERVALS`."""
    if LONG_INTERVALS[kind] is None:
        text = deck(tmp).read_text().replace("t_end = 400.0 ", "t_end = 4000.0 ").replace("output_every = 20",
                                                                                           "output_every = 2000000")
    else:
        top = (ROOT / "models" / "heavy_top.toml").read_text()
        text = top[:top.index("[solver]")] + LONG_INTERVALS[kind]
    path = tmp / f"long_{kind.replace(' ', '_')}.toml"
    path.write_text(text)
    return path


def start(deck_path: Path, out: Path) -> subprocess.Popen:
    """``flexmbs run`` of the deck, with SIGINT's default action as at a terminal (a harness started in
    the background of a shell inherits SIGINT ignored, and would pass that on)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "flexmbs", "run", str(deck_path), "--out", str(out), "--no-vtk"],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def open_results(path: Path):
    """(status, number of records) of a results file; raises if it does not open."""
    with h5py.File(path, "r") as f:
        return str(f.attrs["status"]), f["time"].shape[0], f["nodes/position"].shape[0]


def wait_for(path: Path, proc: subprocess.Popen) -> None:
    t0 = time.monotonic()
    while not path.exists() and proc.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.005)


def kill_trial(tmp: Path, k: int, delay: float, running: bool, kind: str = "explicit") -> str:
    """SIGKILL ``delay`` s after the start (or, if ``running``, after the results file appeared) of a run
    of ``kind`` (:data:`SOLVERS`); return what was left ("no file" or the status), or raise."""
    out = tmp / f"kill{k}"
    proc = start(deck(tmp, kind), out)
    if running:
        wait_for(out / "results.h5", proc)
        delay += HEAD_START[kind]
    time.sleep(delay)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    path = out / "results.h5"
    if not path.exists():
        return "no file"
    status, n_time, n_pos = open_results(path)
    assert n_pos == n_time or n_pos <= n_time, (n_pos, n_time)
    return f"{status} ({n_time} records)"


COMPILING = "compiling the kernels"
"""The first run of an engine version says it is compiling (flexmbs/cli.py): a progress line, not a message
about the stop, which the trials count (a suite run that changed the engine's sources meets it)."""


def _stop_lines(err: str) -> list[str]:
    return [line for line in err.strip().splitlines() if not line.startswith(COMPILING)]


def stop_trial(tmp: Path, k: int, sig: int, delay: float, kind: str = "explicit",
               long_interval: str = "") -> str:
    """``sig`` once the results file of a run of ``kind`` (:data:`SOLVERS`) exists and ``delay`` s more;
    check exit status, message and file.  With ``long_interval`` (:data:`LONG_INTERVALS`) the run's outputs
    are far apart instead, and it must end within :data:`PROMPT` CPU s of the signal."""
    out = tmp / f"stop{k}"
    proc = start(long_interval_deck(tmp, long_interval) if long_interval else deck(tmp, kind), out)
    path = out / "results.h5"
    wait_for(path, proc)
    time.sleep((0.0 if long_interval else HEAD_START[kind]) + delay)
    reaped, used, sent = children_cpu(), cpu_seconds(proc.pid), time.monotonic()
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate(timeout=60)
        raise AssertionError(f"{signal.Signals(sig).name} ignored for 60 s (killed)") from None
    took, cpu = time.monotonic() - sent, children_cpu() - reaped - used
    if long_interval:
        assert cpu <= PROMPT, f"{long_interval}: ended {cpu:.2f} CPU s ({took:.2f} s) after the signal"
    lines = _stop_lines(err)
    word = "interrupted" if sig == signal.SIGINT else "terminated"
    assert proc.returncode == 128 + sig, (proc.returncode, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith(f"flexmbs: {word}"), err[-2000:]
    assert "Traceback" not in err
    status, n_time, _ = open_results(path)
    assert status.startswith(f"{word} at "), status
    assert str(path) in lines[0] and status in lines[0], lines[0]
    return f"{status} ({n_time} records)" + (f", ended {cpu:.2f} CPU s ({took:.2f} s) after the signal"
                                              if long_interval else "")


def early_interrupt_trial(tmp: Path, k: int, delay: float) -> str:
    """Ctrl-C (SIGINT) ``delay`` s after the start, often before the run: exit 130, at most one quiet
    line, no traceback (nor a dropped exception's report), and a results file only if it says
    "interrupted at t = …"; returns the outcome, one of :data:`EARLY_OUTCOMES`."""
    out = tmp / f"early{k}"
    proc = start(deck(tmp), out)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    lines = _stop_lines(err)
    path = out / "results.h5"
    if proc.returncode == 1 and "init_import_site" in err and not path.exists():
        return EARLY_OUTCOMES[3]  # Python's own start-up, which no program can guard
    # before Python has installed its handler the default action ends the process silently (-2)
    assert proc.returncode in (130, -signal.SIGINT), (proc.returncode, err[-2000:])
    assert "Traceback" not in err and "Exception ignored" not in err, err[-2000:]
    assert len(lines) <= 1 and all(line.startswith("flexmbs: interrupted") for line in lines), err[-2000:]
    if proc.returncode < 0:  # the command never ran its handler: no line (it had returned 130 if it printed one)
        assert not path.exists() and not lines, err[-2000:]
        return EARLY_OUTCOMES[0]
    if not path.exists():
        return EARLY_OUTCOMES[1]
    status = open_results(path)[0]
    assert status.startswith("interrupted at t = "), status
    assert "kept in" in lines[0] and status in lines[0], lines[0]
    return EARLY_OUTCOMES[2]


EARLY_OUTCOMES = ("ended by the default action before Python's handler (exit -2)",
                  "interrupted before the results file existed (exit 130)",
                  "interrupted with the results file kept, status 'interrupted at t = …' (exit 130)",
                  "ended in Python's own start-up, importing its site module before any flexmbs code "
                  "(exit 1, 'Fatal Python error: init_import_site' and a traceback)")
"""What an early Ctrl-C may leave (:func:`early_interrupt_trial`)."""


def early_interrupts(tmp: Path, n: int, rng: random.Random, span: float = 2.0) -> int:
    """``n`` Ctrl-Cs at random instants of the first ``span`` s of ``flexmbs run``; prints each trial and
    the counts of each outcome; returns the number of failures."""
    counts = dict.fromkeys(EARLY_OUTCOMES, 0)
    failures = 0
    for k in range(n):
        delay = rng.uniform(0.0, span)
        try:
            outcome = early_interrupt_trial(tmp, k, delay)
            counts[outcome] += 1
            print(f"SIGINT {delay:.3f} s after the start: {outcome}", flush=True)
        except Exception as exc:
            failures += 1
            print(f"SIGINT {delay:.3f} s after the start: FAILED {type(exc).__name__}: {exc}", flush=True)
    print(f"{n} early SIGINTs (first {span:g} s): " + "; ".join(f"{v} {k}" for k, v in counts.items())
          + f"; {failures} failures", flush=True)
    return failures


def main(argv=None) -> int:
    import tempfile

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--kills", type=int, default=20)
    p.add_argument("--terms", type=int, default=10)
    p.add_argument("--ints", type=int, default=0, metavar="N",
                   help="N Ctrl-Cs (SIGINT) at random instants of the first 2 s of the run, counted by outcome")
    p.add_argument("--seed", type=int, default=12)
    args = p.parse_args(argv)
    rng = random.Random(args.seed)
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        kinds = list(SOLVERS)
        for k in range(args.kills):
            running = k >= args.kills // 2
            kind = kinds[k % len(kinds)] if running else "explicit"
            delay = rng.uniform(0.0, 1.5) if running else rng.uniform(0.0, 0.5)
            when = f"{delay:.2f} s after {'the file appeared' if running else 'the start'} ({kind})"
            try:
                print(f"SIGKILL {when}: {kill_trial(tmp, k, delay, running, kind)}", flush=True)
            except Exception as exc:
                failures += 1
                print(f"SIGKILL {when}: FAILED {type(exc).__name__}: {exc}", flush=True)
        failures += early_interrupts(tmp, args.terms // 2, rng, span=3.0) if args.terms // 2 else 0
        for k in range(args.terms):
            sig = signal.SIGTERM if k % 5 else signal.SIGHUP
            kind = kinds[k % len(kinds)]
            try:
                print(f"{signal.Signals(sig).name} ({kind}): {stop_trial(tmp, k, sig, rng.uniform(0.0, 1.0), kind)}",
                      flush=True)
            except Exception as exc:
                failures += 1
                print(f"{signal.Signals(sig).name} ({kind}): FAILED {type(exc).__name__}: {exc}", flush=True)
        failures += early_interrupts(tmp, args.ints, rng) if args.ints else 0
        for k, kind in enumerate(LONG_INTERVALS):
            for j, sig in enumerate((signal.SIGINT, signal.SIGTERM)):
                try:
                    outcome = stop_trial(tmp, 100 + 2 * k + j, sig, rng.uniform(0.5, 2.0), long_interval=kind)
                    print(f"{signal.Signals(sig).name}, {kind}: {outcome}", flush=True)
                except Exception as exc:
                    failures += 1
                    print(f"{signal.Signals(sig).name}, {kind}: FAILED {type(exc).__name__}: {exc}", flush=True)
    print(f"{args.kills} SIGKILL, {args.terms // 2 + args.ints} early SIGINT, {args.terms} SIGTERM/SIGHUP and "
          f"{2 * len(LONG_INTERVALS)} long-interval trials: {failures} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
