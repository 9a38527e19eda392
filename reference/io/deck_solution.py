"""The deck's tables about the solution: how to run the model and what to check in its results.

``[solver]`` (:func:`read_solver`): the algorithm and its settings, with the
overrides of ``t_end``, ``dt`` and ``refine``; the step is checked against the
critical step of the explicit scheme (× :data:`reference.monitor.SAFETY`), the
step limit (``max_steps``) and a whole number of steps to ``t_end``, and a
refused step comes with a step that works (:func:`_suggest_dt`); ``backend`` picks the
implementation that runs the algorithm (:mod:`reference.plain.backend`).
``[checks.NAME]`` and ``[crosscheck.NAME]`` (:func:`read_checks`): their
observables are parsed against the model (:mod:`reference.observables`), so a
typo is refused before any engine runs.  Keys: docs/deck.md.
"""

from __future__ import annotations

import math

from reference.algorithms import ALGORITHMS, SolverSettings
from reference.algorithms.base import ABOUT
from reference.domain import Domain
from reference.io.deck_reader import Reader, show
from reference.monitor import SAFETY, damping_problem
from reference.plain.backend import BACKENDS, decide, problem
from reference.observables import ObservableError
from reference.observables import parse as parse_observable

MAX_STEPS = 10**9
"""Default limit on the number of time steps; ``solver.max_steps`` raises it."""
MAX_STEPS_LIMIT = 10**12
"""Largest ``solver.max_steps``: more steps than the smallest model takes in weeks (docs/benchmarks.md §10);
a larger value is a typo."""
MAX_ITERATIONS = 1000
"""Largest ``solver.max_iterations``: Newton converges quadratically in a few iterations or not at
all (the implicit runs here need at most 7); a step that needs more needs a smaller step."""
SUGGEST = 0.8
"""Fraction of the critical estimate used for the dt the messages suggest."""
MAX_MODES = 10_000
"""Largest ``solver.modes``: the lowest modes of a model are asked for, not its spectrum."""
ADAPTIVE_OUTPUTS = 1000
"""Output intervals to ``t_end`` of a generalized-α run with ``error_tolerance`` and no ``dt``."""


def read_solver(rd: Reader, deck: dict, domain: Domain, overrides: dict, refine: int):
    """``[solver]`` with the overrides: the settings, and the step checked against the critical
    step of the explicit scheme and the step limit; returns (algorithm name, its class)."""
    if "solver" not in deck:
        raise rd.fail("solver", "missing [solver] table", "give at least dt and t_end")
    sv = deck["solver"]
    if not isinstance(sv, dict):
        raise rd.fail("solver", f"expected a table, got {type(sv).__name__}")
    algorithm = rd.choice(sv.get("algorithm", SolverSettings.algorithm), "solver.algorithm", ALGORITHMS, "algorithm")
    algo_cls = ALGORITHMS[algorithm]
    rd.keys(sv, "solver", required=algo_cls.deck_required, optional=["algorithm", "backend", *algo_cls.deck_optional])
    about = rd.choice(sv.get("about", SolverSettings.about), "solver.about", ABOUT, "configuration",
                      "'reference' (the initial state), 'static' (the static equilibrium at t_end) or 'rotation' "
                      "(the model spinning at spin_rate about spin_axis)")
    # keys that only some values of another accept (modes: the static algorithm's keys with about = "static")
    required, optional = algo_cls.deck_keys(sv)
    rd.keys(sv, "solver", required=required, optional=["algorithm", "backend", *optional])
    modes = rd.integer(sv.get("modes", SolverSettings.modes), "solver.modes", maximum=MAX_MODES,
                       fix=f"ask for the lowest modes, at most {MAX_MODES}")
    dt_entry = "dt override (--dt)" if "dt" in overrides else "solver.dt"
    t_entry = "t_end override (--t-end)" if "t_end" in overrides else "solver.t_end"
    t_end = rd.number(overrides.get("t_end", sv.get("t_end", SolverSettings.t_end)), t_entry, positive=True)
    load_steps = rd.integer(sv.get("load_steps", 1), "solver.load_steps", maximum=MAX_STEPS,
                            fix="a static run of more load steps would take days; raise max_steps is no help")
    # the explicit step shrinks with the refined mesh; an implicit step does not
    mesh_factor = refine if algo_cls.explicit else 1
    adaptive = "error_tolerance" in sv
    deck_dt = (rd.number(sv["dt"], "solver.dt", positive=True) / mesh_factor if "dt" in sv
               else t_end / ADAPTIVE_OUTPUTS if adaptive else t_end / load_steps)
    dt = rd.number(overrides.get("dt", deck_dt), dt_entry, positive=True)
    # keep the deck's output times when the step is overridden by a whole factor
    ratio = deck_dt / dt
    output_scale = int(round(ratio)) if 1 <= ratio < 2.0**62 and abs(ratio - round(ratio)) < 1e-9 else 1
    rho_inf = rd.number(sv.get("rho_inf", 0.8), "solver.rho_inf", nonnegative=True)
    if rho_inf > 1.0:
        raise rd.fail("solver.rho_inf", f"must lie in [0, 1], got {rho_inf!r}",
                      "1 keeps every frequency undamped, 0 annihilates the highest in one step; 0.8 is usual")
    domain.solver = SolverSettings(
        algorithm=algorithm, dt=dt, t_end=t_end,
        damping=rd.number(sv.get("damping", 0.0), "solver.damping", nonnegative=True),
        output_every=rd.integer(sv.get("output_every", 1), "solver.output_every", maximum=MAX_STEPS,
                                fix="every output step of a run is at most max_steps") * mesh_factor * output_scale,
        consistent_initial_velocities=rd.boolean(sv.get("consistent_initial_velocities", False),
                                                 "solver.consistent_initial_velocities"),
        load_steps=load_steps, rho_inf=rho_inf,
        tolerance=rd.number(sv["tolerance"], "solver.tolerance", positive=True) if "tolerance" in sv else None,
        max_iterations=rd.integer(sv["max_iterations"], "solver.max_iterations", maximum=MAX_ITERATIONS,
                                  fix="Newton converges in a few iterations or not at all; use a smaller step")
        if "max_iterations" in sv else None,
        modes=modes, about=about,
        first_step=dt if adaptive and ("dt" in sv or "dt" in overrides) else None,
        backend=_backend(rd, sv, algorithm),
        **algo_cls.deck_settings(rd, sv, domain),
    )
    _check_step(rd, sv, domain, algo_cls, overrides, dt_entry, t_entry)
    algo_cls.deck_check(rd, sv, domain.solver)
    return algorithm, algo_cls


def _backend(rd: Reader, sv: dict, algorithm: str) -> str:
    """``solver.backend``: one of :data:`reference.plain.backend.BACKENDS`, and for ``"reference"`` an algorithm
    that the reference path runs (:func:`reference.plain.backend.problem`)."""
    value = rd.choice(sv.get("backend", "compiled"), "solver.backend", BACKENDS, "backend",
                      "'compiled' (the numba kernels), 'reference' (plain NumPy, no compilation) or 'auto'")
    why = problem(value, algorithm) if value != "compiled" else ""
    if why:
        raise rd.fail("solver.backend", *why.split("; ", 1))
    return value


def check_backend(rd: Reader, domain: Domain, algo, model) -> None:
    """``solver.backend = "reference"`` with settings or a model that the algorithm's twin does not run (its
    ``refusal``, :func:`reference.plain.backend.decide`): one line, before any engine runs."""
    try:
        decide(domain.solver.backend, algo, model, 0)
    except ValueError as exc:
        raise rd.fail("solver.backend", *str(exc).removeprefix("solver backend: ").split("; ", 1)) from None


def _check_step(rd: Reader, sv: dict, domain: Domain, algo_cls, overrides: dict, dt_entry: str, t_entry: str):
    """The step of ``domain.solver`` against the explicit scheme's critical step (and its damping limit),
    the step limit ``max_steps`` and a whole number of steps to ``t_end``; refused in one line each."""
    dt, t_end = domain.solver.dt, domain.solver.t_end
    max_steps = rd.integer(sv.get("max_steps", MAX_STEPS), "solver.max_steps", maximum=MAX_STEPS_LIMIT,
                           fix="a run of more steps would take weeks")
    unsafe = rd.boolean(sv.get("allow_unsafe_dt", False), "solver.allow_unsafe_dt")
    if not domain.elements and not domain.nodes:
        raise rd.fail("deck", "the deck defines no nodes or beams")
    crit = domain.critical_time_step()
    if not crit > 0.0:
        raise rd.fail("sections", f"the critical time step of the mesh is {crit:g} (a stiffness so large against "
                      "the mass that no step is stable)", "check the units of the section data")
    if algo_cls.explicit and dt > SAFETY * crit and not unsafe:
        raise rd.fail(dt_entry, f"dt = {dt:g} is above the critical time step {crit:.4g} of the explicit scheme "
                      f"× {SAFETY:g} (the safety margin)",
                      f"use dt ≤ {SUGGEST * crit:.3g}, e.g. {_suggest_dt(t_end, SUGGEST * crit)}, or algorithm = "
                      "\"generalized_alpha\" (implicit: no critical step)"
                      if t_end / (SUGGEST * crit) <= max_steps else
                      f"a stable step needs {t_end / (SUGGEST * crit):.3g} steps, above the limit of {max_steps:.3g}: "
                      "check the units of the section data, raise solver.max_steps, or use algorithm = "
                      "\"generalized_alpha\" (implicit: no critical step)")
    damping = damping_problem(domain.solver.damping, dt, crit, SAFETY) if algo_cls.explicit and not unsafe else ""
    if damping:
        raise rd.fail("solver.damping", damping)
    steps = t_end / dt
    if not steps <= max_steps:
        raise rd.fail(t_entry if "t_end" in overrides else dt_entry if "dt" in overrides else "solver",
                      f"t_end / dt = {t_end:g} / {dt:g} = {steps:.3g} steps, above the limit of {max_steps:.3g}",
                      "use a larger dt or a shorter t_end, or raise solver.max_steps if the run is meant")
    if not _whole_steps(t_end, dt):
        steps = t_end / dt
        raise rd.fail(t_entry, f"t_end = {t_end:g} is not a whole number of steps dt = {dt:g} ({steps:.6g} steps)",
                      f"use t_end = {max(round(steps), 1) * dt:.10g} or {_suggest_dt(t_end, dt)}")


def _whole_steps(t_end: float, dt: float) -> bool:
    steps = t_end / dt
    if not steps < 2.0**62:
        return False
    return abs(steps - round(steps)) <= 1e-9 * max(steps, 1.0) and round(steps) >= 1


def _suggest_dt(t_end: float, limit: float) -> str:
    """A step ≤ ``limit`` that divides ``t_end``: a round number (1, 2, 2.5, 4, 5 × 10^k) if one
    does, else t_end / N to full precision."""
    if not (limit > 0.0 and math.isfinite(limit) and t_end / limit < 2.0**62):
        return f"a step that gives at most {MAX_STEPS:.0e} steps to t_end = {t_end:g}"
    for k in range(math.floor(math.log10(limit)), math.floor(math.log10(limit)) - 3, -1):
        for m in (5.0, 4.0, 2.5, 2.0, 1.0):
            dt = float(f"{m}e{k}")
            if dt <= limit and _whole_steps(t_end, dt):
                return f"dt = {dt:g} ({round(t_end / dt)} steps to t_end = {t_end:g})"
    n = math.ceil(t_end / limit)
    return f"dt = {t_end / n!r} ({n} steps to t_end = {t_end:g})"


def read_checks(rd: Reader, deck: dict, domain: Domain) -> tuple[dict, dict]:
    """``[checks.NAME]`` and ``[crosscheck.NAME]``, their observables checked against the model;
    returns both tables by name."""
    checks = rd.tables(deck, "checks")
    for name, spec in checks.items():
        if not isinstance(spec, dict):
            raise rd.fail(f"checks.{name}", f"expected a table, got {show(spec)}", f"write it as [checks.{name}]")
        if "observable" in spec:
            _observable(rd, spec["observable"], f"checks.{name}.observable", domain)
    crosscheck = rd.tables(deck, "crosscheck")
    for name, spec in crosscheck.items():
        entry = f"crosscheck.{name}"
        rd.keys(spec, entry, required=["observable", "tolerance", "reason"], optional=["relative_to", "refine"])
        _observable(rd, spec["observable"], f"{entry}.observable", domain)
        rd.number(spec["tolerance"], f"{entry}.tolerance", positive=True)
        rd.string(spec["reason"], f"{entry}.reason")
        if spec.get("relative_to", "absolute") not in ("length", "peak", "absolute"):
            raise rd.fail(f"{entry}.relative_to", f"unknown scale {show(spec['relative_to'])}", "'length', 'peak' or 'absolute'")
        rd.integer(spec.get("refine", 1), f"{entry}.refine")
    return checks, crosscheck


def _observable(rd: Reader, text, entry: str, domain: Domain):
    """Check an observable text against the model (``reference/observables.py``): one-line DeckError."""
    if not isinstance(text, str):
        raise rd.fail(entry, f"expected an observable text, got {show(text)}",
                      "e.g. 'position:beam:end'; free text goes in 'description' (docs/observables.md)")
    try:
        return parse_observable(text, domain)
    except ObservableError as exc:
        raise rd.fail(entry, f"{text!r}: {exc}", "" if ";" in str(exc) else "see docs/observables.md") from None
