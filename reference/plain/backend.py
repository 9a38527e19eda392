"""Which implementation runs a job: ``[solver] backend`` (``SolverSettings.backend``) and its ``auto`` rule.

- ``"compiled"``: the numba kernels of :mod:`reference.algorithms`.  Fast per step, but the first run of an
  algorithm for a version of the engine compiles its kernels: measured cold on the project's 2-core machine
  (issue 36), 164 s for the explicit step (three_bar, load 2.5), 245 s for modes, 742 s for arc length.
- ``"reference"``: the same algorithm's twin on the plain NumPy path (``reference/plain/``): nothing to
  compile, slower per step (:data:`SECONDS_PER_UNIT`).
- ``"auto"``: the reference path when its estimated run time (:func:`estimate`) is at most
  :data:`REFERENCE_SECONDS`, else the compiled one.  The estimate depends only on the job (algorithm,
  steps, nodes, joint rows), never on what is cached, so the same deck always runs on the same path: a
  short job (a static solve, modes, a lesson's cell, a short explicit horizon) gives its result without
  waiting minutes for a compilation, and a warm cache would have saved it at most
  :data:`REFERENCE_SECONDS`; a long job pays the compilation once and runs fast.  The measurements behind
  the constants are in docs/benchmarks.md ("Reference path").

:func:`choose` returns the decision and its one line (printed by ``flexmbs run`` for ``auto``, recorded in
the results' attributes ``backend`` and ``backend_reason``); :func:`twin` gives the reference algorithm.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

BACKENDS = ("compiled", "reference", "auto")
"""The values of ``[solver] backend``."""

EXPLICIT = "staggered_central_difference"
"""The explicit algorithm's deck name: its unit of work is a step (an implicit one's a Newton iteration)."""

REFERENCE_SECONDS = 15.0
"""``auto`` runs the reference path when its estimated run time is at most this [s]: the first run then costs
at most this much more than a warm compiled one (issue 36's bound), and far less than a cold compilation."""

SECONDS_PER_UNIT = {
    "staggered_central_difference": (4.0e-4, 6.0e-6, 3.0e-6),
    "static": (6.0e-3, 2.0e-4, 1.0e-4),
    "generalized_alpha": (6.0e-3, 2.0e-4, 1.0e-4),
}
"""Seconds of one unit of work on the reference path, ``(a, b, c)`` of ``a + b N + c m`` (N nodes, m joint rows):
a step of the explicit algorithm, a Newton iteration of the implicit ones (measured: docs/benchmarks.md)."""

ITERATIONS = 4
"""Newton iterations assumed per step or load step of an implicit algorithm (the gallery's runs take 2–6)."""


@functools.cache
def twins() -> dict:
    """The reference path's algorithm classes by deck name, each a subclass of the compiled algorithm of that
    name (imported when first asked: the deck reader and a compiled run load none of the reference path)."""
    from reference.plain.algorithms import REFERENCE_TWINS
    from reference.plain.park import ReferenceStaggered

    return {ReferenceStaggered.name: ReferenceStaggered, **REFERENCE_TWINS}


class Choice(NamedTuple):
    """The backend that runs a job and why (one clause)."""

    backend: str
    reason: str

    @property
    def line(self) -> str:
        """The terminal's line: ``backend: reference (…)``."""
        return f"backend: {self.backend} ({self.reason})"


def problem(requested: str, algorithm: str) -> str:
    """Why ``backend = requested`` cannot run ``algorithm`` ("" when it can): an unknown backend, or an
    algorithm with no reference twin yet."""
    if requested not in BACKENDS:
        return f"unknown backend {requested!r}; use one of {', '.join(map(repr, BACKENDS))}"
    if requested == "reference" and algorithm not in twins():
        return (f"algorithm {algorithm!r} has no reference-path twin yet (it has: {', '.join(twins())}); "
                "use backend = \"compiled\" or \"auto\"")
    return ""


def estimate(algorithm: str, steps: int, nodes: int, rows: int) -> float:
    """The estimated run time [s] of a job on the reference path: its units of work (steps; Newton iterations,
    :data:`ITERATIONS` a step, for an implicit algorithm) × :data:`SECONDS_PER_UNIT` at its size; infinite for an
    algorithm without a twin or a cost model."""
    if algorithm not in twins() or algorithm not in SECONDS_PER_UNIT:
        return float("inf")
    a, b, c = SECONDS_PER_UNIT[algorithm]
    units = steps if algorithm == EXPLICIT else ITERATIONS * steps
    return units * (a + b * nodes + c * rows)


def choose(requested: str, algorithm: str, steps: int, nodes: int, rows: int) -> Choice:
    """The backend of a job: ``requested`` itself unless it is ``"auto"``, then the rule of the module docstring.

    Parameters
    ----------
    requested : str
        ``SolverSettings.backend``.
    algorithm : str
        The deck name of the algorithm.
    steps : int
        Its steps (load steps, points) to the end of the run.
    nodes, rows : int
        The model's nodes and joint rows (its size).
    """
    if requested != "auto":
        return Choice(requested, "asked for")
    if algorithm not in twins():
        return Choice("compiled", f"algorithm {algorithm!r} has no reference-path twin yet")
    seconds = estimate(algorithm, steps, nodes, rows)
    if seconds == float("inf"):
        return Choice("compiled", f"no cost model of algorithm {algorithm!r} on the reference path")
    if seconds <= REFERENCE_SECONDS:
        return Choice("reference", f"about {seconds:.2g} s in plain NumPy for {steps} steps of {nodes} nodes: "
                                   "less than compiling the kernels")
    return Choice("compiled", f"about {seconds:.3g} s in plain NumPy for {steps} steps of {nodes} nodes, over "
                              f"{REFERENCE_SECONDS:g} s: compiling the kernels pays")


def for_domain(domain) -> Choice:
    """:func:`choose` for a Domain ready to solve (its ``solver`` settings, nodes and multiplier joints): the
    decision the solution loop will take, known before the run (``flexmbs run`` prints its line first)."""
    algo = domain.algorithm()
    rows = sum(joint.n_equations for joint in domain.joints if joint.formulation.multipliers)
    return choose(domain.solver.backend, algo.name, algo.n_steps(domain.solver.t_end), len(domain.nodes), rows)


def twin(algo):
    """The reference-path twin of the compiled algorithm ``algo``, with its settings (the same attributes)."""
    cls = twins()[algo.name]
    if not isinstance(algo, cls.__mro__[1]):
        raise TypeError(f"{cls.__name__} is not the twin of {type(algo).__name__}")
    copy = object.__new__(cls)
    copy.__dict__.update(vars(algo))
    return copy
