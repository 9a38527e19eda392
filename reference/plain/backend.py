"""Which implementation runs a job: ``[solver] backend`` (``SolverSettings.backend``) and its ``auto`` rule.

- ``"compiled"`` (the default: every deck's results as before the reference path existed): the numba kernels of :mod:`reference.algorithms`.  Fast per step, but the first run of an
  algorithm for a version of the engine compiles its kernels, minutes on a small machine (docs/benchmarks.md
  §9).
- ``"reference"``: the same algorithm's twin on the plain NumPy path (``reference/plain/``): nothing to
  compile, slower per step (:data:`COSTS`).
- ``"auto"``: the reference path when its estimated run time (:func:`estimate`) is at most
  :data:`REFERENCE_SECONDS` and the twin runs these settings, else the compiled path.  The estimate depends
  only on the job (algorithm, steps, nodes, joint rows, force elements), never on what is cached, so the same
  deck always runs on the same path: a short job (a static solve, modes, a lesson's cell, a short explicit
  horizon) gives its result without waiting minutes for a compilation, and a warm cache would have saved it
  at most :data:`REFERENCE_SECONDS`; a long job pays the compilation once and runs fast.  The measurements
  behind :data:`COSTS` are in docs/benchmarks.md ("The reference path").

A model of a formulation that only the reference path runs (:data:`REFERENCE_ONLY`: the reduced bodies of a
``[[beams]] reduce`` table, issue 39, :mod:`reference.reduced.registry`) runs there: ``auto`` chooses it,
``compiled`` is refused in one line (:func:`decide`), and :func:`twin` gives the formulation's twin of the
algorithm.

:func:`decide` returns the decision and its one line (printed by ``flexmbs run`` for ``auto``, recorded in the
results' attributes ``backend`` and ``backend_reason``); :func:`twin` gives the reference algorithm.
"""

from __future__ import annotations

import functools
import weakref
from typing import NamedTuple

import numpy as np

BACKENDS = ("compiled", "reference", "auto")
"""The values of ``[solver] backend``."""

REFERENCE_SECONDS = 15.0
"""``auto`` runs the reference path when its estimated run time is at most this [s]: the first run then costs
at most this much more than a warm compiled one (issue 36's bound), and far less than a cold compilation."""


class Cost(NamedTuple):
    """CPU seconds of one unit of work on the reference path: ``base + node N + row m + force_element F``
    (N nodes, m joint rows, F force elements); a unit is a step of the explicit algorithm, a Newton iteration
    of an implicit one (``iterations`` a step, load step or point); ``analysis`` [s] once, for the eigenvalue
    problem of a linearised analysis."""

    base: float
    node: float
    row: float
    force_element: float
    iterations: int = 1
    analysis: float = 0.0


_IMPLICIT = Cost(8.0e-3, 1.0e-4, 1.0e-4, 1.2e-3, iterations=4)
COSTS = {
    "staggered_central_difference": Cost(2.5e-3, 2.0e-5, 1.6e-4, 1.2e-3),
    "static": _IMPLICIT,
    "generalized_alpha": _IMPLICIT,
    "arc_length": _IMPLICIT,
    "modes": _IMPLICIT._replace(analysis=1.0),
    "buckling": _IMPLICIT._replace(analysis=1.0),
}
"""The reference path's cost model by algorithm, fitted from above to CPU times measured on the gallery decks
(docs/benchmarks.md, "The reference path")."""


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


REFERENCE_ONLY: list = []
"""Formulations whose models run on the reference path only, registered by their packages (this module imports
none of them): each has ``name`` (its words in a message), ``labels(model)`` (the labels of its parts in
``model``, an empty tuple when it has none), ``algorithms`` (the deck names of the algorithms that run it) and
``twin(algo, model)`` (the algorithm that runs it, with ``algo``'s settings)."""

_CHOSEN: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
"""Compiled algorithm → ``(formulation, model)`` that :func:`decide` chose the reference path for (:func:`twin`)."""


def _formulation_choice(requested: str, algo, model, formulation, labels: tuple) -> Choice:
    """The reference path for a model with parts of a :data:`REFERENCE_ONLY` entry, or a one-line ValueError: the
    compiled path asked for, or an algorithm that does not run them."""
    names = ", ".join(map(repr, labels))
    if requested == "compiled":
        raise ValueError(f"solver backend: {formulation.name} {names} runs on the reference path only; set backend "
                         "= \"reference\" (or \"auto\")")
    if algo.name not in formulation.algorithms:
        raise ValueError(f"solver backend: {formulation.name} {names} runs in {', '.join(formulation.algorithms)}, "
                         f"not in {algo.name!r}; choose one of them")
    _CHOSEN[algo] = (formulation, model)
    return Choice("reference", "asked for" if requested == "reference" else
                  f"{formulation.name} {names} runs on the reference path only")


def problem(requested: str, algorithm: str) -> str:
    """Why ``backend = requested`` cannot run ``algorithm`` ("" when it can): an unknown backend, or an
    algorithm with no reference twin."""
    if requested not in BACKENDS:
        return f"unknown backend {requested!r}; use one of {', '.join(map(repr, BACKENDS))}"
    if requested == "reference" and algorithm not in twins():
        return (f"algorithm {algorithm!r} has no reference-path twin (it has: {', '.join(twins())}); "
                "use backend = \"compiled\" or \"auto\"")
    return ""


def estimate(algorithm: str, steps: int, nodes: int, rows: int, force_elements: int = 0) -> float:
    """The estimated run time [s] of a job on the reference path (:data:`COSTS`): ``steps`` (load steps, points;
    a linearised analysis one more, its linearisation) × the iterations of each × the cost of one at this size;
    infinite for an algorithm without a cost model."""
    if algorithm not in COSTS:
        return float("inf")
    cost = COSTS[algorithm]
    units = (steps + (1 if cost.analysis else 0)) * cost.iterations
    return units * (cost.base + cost.node * nodes + cost.row * rows + cost.force_element * force_elements) \
        + cost.analysis


def decide(requested: str, algo, model, steps: int) -> Choice:
    """The backend of a job: ``requested`` itself unless it is ``"auto"``, then the rule of the module docstring.

    Parameters
    ----------
    requested : str
        ``SolverSettings.backend``.
    algo : Algorithm
        The compiled algorithm, with its settings.
    model : Model
        The assembled model (its size; the twin's own refusals of a model or a setting, ``Algorithm.refusal``).
    steps : int
        The algorithm's steps (load steps, points) to the end of the run.

    Raises
    ------
    ValueError
        ``backend = "reference"`` for an algorithm or settings the reference path does not run (one line).
    """
    why = problem(requested, algo.name)
    if why:
        raise ValueError(f"solver backend: {why}")
    for formulation in REFERENCE_ONLY:
        labels = formulation.labels(model)
        if labels:
            return _formulation_choice(requested, algo, model, formulation, labels)
    if requested == "compiled":
        return Choice("compiled", "asked for")
    refused = twin(algo).refusal(model) if algo.name in twins() else f"algorithm {algo.name!r} has no twin there"
    if not refused and (model.joints.iterations > 0 or np.any(model.joints.compliance != model.joints.eps)):
        refused = ("augmented-Lagrangian joints run on the compiled path only (the reference path solves the "
                   "multiplier rows Φ − ελ = 0); set backend = \"compiled\"")
    if requested == "reference":
        if refused:
            raise ValueError(f"solver backend: {refused}")
        return Choice("reference", "asked for")
    if refused:
        return Choice("compiled", f"the reference path does not run this: {refused.split(';')[0]}")
    nodes, rows, springs = model.nodes.mass.shape[0], model.n_constraints, model.force_elements.kind.shape[0]
    seconds = estimate(algo.name, steps, nodes, rows, springs)
    job = f"{steps} steps of {nodes} nodes" if steps else f"a linearised analysis of {nodes} nodes"
    if seconds <= REFERENCE_SECONDS:
        return Choice("reference", f"about {seconds:.2g} s in plain NumPy for {job}: less than compiling the kernels")
    return Choice("compiled", f"about {seconds:.3g} s in plain NumPy for {job}, over {REFERENCE_SECONDS:g} s: "
                              "compiling the kernels pays")


def for_domain(domain) -> Choice:
    """:func:`decide` for a Domain ready to solve: the decision the solution loop will take, known before the
    run (``flexmbs run`` prints its line first)."""
    algo = domain.algorithm()
    model = domain.initialization()
    return decide(domain.solver.backend, algo, model, algo.n_steps(domain.solver.t_end))


def twin(algo):
    """The reference-path twin of the compiled algorithm ``algo``, with its settings (the same attributes); the
    formulation's own when :func:`decide` chose this path for a model of a :data:`REFERENCE_ONLY` entry."""
    chosen = _CHOSEN.get(algo)
    if chosen is not None:
        formulation, model = chosen
        return formulation.twin(algo, model)
    cls = twins()[algo.name]
    if not isinstance(algo, cls.__mro__[1]):
        raise TypeError(f"{cls.__name__} is not the twin of {type(algo).__name__}")
    copy = object.__new__(cls)
    copy.__dict__.update(vars(algo))
    return copy
