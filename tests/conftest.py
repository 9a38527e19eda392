"""Shared builders for the tests."""

from __future__ import annotations

import os

# One BLAS thread per test process: `make test` runs one pytest-xdist worker per core, and BLAS threads on top
# of them oversubscribe the cores (a 198-coordinate static path's dense stability counts, LDLᵀ of the
# tangent at every load level, ran 0.7–1.3 s instead of 0.02 s on a loaded two-core machine).  Set before
# numpy loads OpenBLAS; the subprocesses the tests start inherit it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# numba's thread pool: at least three threads, so that tests/test_parallel_steps.py can run the parallel loops
# on 1, 2 and 3 of them (the runs themselves use FLEXMBS_THREADS or reference.jit.threads(), capped at the cores)
os.environ.setdefault("NUMBA_NUM_THREADS", str(max(3, os.cpu_count() or 1)))

import numpy as np  # noqa: E402
import pytest

from reference.domain import Domain
from reference.elements import Section
from reference.io.deck import load_deck


LEE_FRAME_BEAM2 = {"beams.0.element": "beam2", "beams.0.elements": 40, "beams.1.element": "beam2",
                   "beams.1.elements": 8, "beams.2.element": "beam2", "beams.2.elements": 32, "solver.backend": "compiled"}
"""Overrides of models/lee_frame.toml that give back its former mesh, 40 Beam2 elements per leg on the compiled
path (the deck itself is beam3 with 5 per leg on ``backend = "auto"``): the tests whose numbers were measured
on that mesh (limit loads, jumps, stability counts) or that need the compiled Beam2 kernels they share with
every other deck, rather than a compilation of the arc length for beam3."""


def cantilever(n_elements: int, section: Section, length: float = 1.0, axis2=(0.0, 1.0, 0.0)):
    """A straight cantilever along +x clamped at x = 0: ``(domain, nodes)``."""
    from reference.interactions import Clamp

    d = Domain("cantilever")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (length, 0.0, 0.0), n_elements, section, axis2=axis2)
    d.add_interaction(Clamp(nodes[0]))
    return d, nodes


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


def _one_compilation_at_a_time(folder) -> None:
    """Make a pytest-xdist worker wait while another compiles the same engine kernel, then read it from the cache.

    Every numba dispatcher of the engine (``reference.*``) takes an exclusive lock file named after the function in
    ``folder`` around its compilation; numba's ``compile`` looks in the disk cache first, so the worker that waited
    loads what the other one wrote instead of compiling it again.  No deadlock: a worker holds the locks of the
    kernels it is compiling, nested as the kernels call each other, and kernels do not call each other in a cycle
    (a function compiling inside its own compilation, a recursion, does not lock again).
    """
    import fcntl
    import hashlib
    import threading

    from numba.core import dispatcher

    original = dispatcher.Dispatcher.compile
    held = threading.local()

    def compile(self, sig):
        name = f"{getattr(self.py_func, '__module__', '')}.{getattr(self.py_func, '__qualname__', '')}"
        mine = getattr(held, "names", None)
        if mine is None:
            mine = held.names = set()
        if not name.startswith("reference.") or name in mine:
            return original(self, sig)
        with open(folder / (hashlib.sha1(name.encode()).hexdigest()[:24] + ".lock"), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            mine.add(name)
            try:
                return original(self, sig)
            finally:
                mine.discard(name)

    dispatcher.Dispatcher.compile = compile


def _warm_up_jobs():
    """The solves whose kernels most tests share, most expensive first (cold, each compiles for half a minute or
    more): generalized-α (the tangent), the explicit step, the static Newton loop, the arc-length path."""
    from pathlib import Path

    from reference.algorithms import SolverSettings

    models = Path(__file__).resolve().parents[1] / "models"

    def alpha():
        d = load_deck(models / "three_bar.toml").domain
        d.solver = SolverSettings(algorithm="generalized_alpha", dt=5e-3, t_end=0.02, output_every=2)
        return d

    def explicit():
        d = load_deck(models / "three_bar.toml").domain
        d.solver.t_end = 10 * d.solver.dt
        return d

    def static():
        d = load_deck(models / "embedded_beam.toml").domain
        d.solver = SolverSettings(algorithm="static", t_end=0.2, load_steps=2, dt=0.1)
        return d

    def arc_length():
        d = load_deck(models / "lee_frame.toml", overrides=LEE_FRAME_BEAM2).domain
        d.solver.max_points = 3
        return d

    return [("generalized_alpha", alpha), ("explicit", explicit), ("static", static), ("arc_length", arc_length)]


@pytest.fixture(scope="session", autouse=True)
def _shared_kernels(request):
    """Share the compilation of the kernels out between the pytest-xdist workers.

    A cold numba cache (a fresh clone, or an edit of a file the kernels reach: :mod:`reference.kernel_cache`) costs minutes of
    compilation, and the first tests of every worker need the same few kernels: left alone, both workers
    compiled the explicit step at once, then both the Newton loop (measured: a third of the suite's compile
    time done twice).  So a worker waits while another compiles a kernel it needs and then reads it from the
    shared disk cache (:func:`_one_compilation_at_a_time`), and at its first test each worker runs the warm-up
    solves that no other worker has claimed (an exclusive lock file per solve), so that the workers compile
    different kernels at the same time instead of waiting for each other.  The warm-up runs only for a run of
    the whole suite (a few selected tests compile what they need).  Under xdist only, never with
    ``NUMBA_DISABLE_JIT=1``.  A warm-up solve that fails is left to the tests to report.
    """
    import fcntl
    import tempfile
    from pathlib import Path

    import numba

    if not os.environ.get("PYTEST_XDIST_WORKER") or numba.config.DISABLE_JIT:
        return
    locks = Path(numba.config.CACHE_DIR) / "locks"
    locks.mkdir(parents=True, exist_ok=True)
    _one_compilation_at_a_time(locks)
    if len(request.session.items) < 200:
        return
    for name, build in _warm_up_jobs():
        with open(locks / f"warm-up-{name}.lock", "a") as lock:
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:  # another worker runs this one now
                continue
            if (locks / f"warm-up-{name}.done").exists():
                continue
            try:
                with tempfile.TemporaryDirectory() as folder:
                    build().solve(results_path=Path(folder) / "warm-up.h5")
            except Exception:  # noqa: BLE001 - the tests themselves report what fails
                pass
            (locks / f"warm-up-{name}.done").touch()
