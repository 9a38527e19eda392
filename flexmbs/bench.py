"""``flexmbs bench``: solve times of the reference engine and of Exudyn, side by side.

Both engines solve the same dynamic problem from the same deck data, with the
same load history and time step, in one process, one after the other; each is
warmed up once (numba compilation, Exudyn's first-call set-up) and then timed
``repeat`` times; the table shows the median solve times and their ratio.
Only the solve is timed (model building excluded) on both sides.

Then the scaling of the constraint stage — the per-step cost of a chain of K
rigid links joined by spherical joints (K = 50 … 400; linear in K with the
sparse stage) and of two beams welded by a ``fixed`` joint against the same
beams sharing a node — and the Beam2 throughput (µs per element-step, 768
elements) beside PyElastica's on the same clamped rod (the ``bench`` extra),
with both tips printed: the same answer at the same step.  Per-step costs time
the compiled stepping alone (median of ``repeat`` after a warm-up).  Then the
share of a run spent writing ParaView output (2,000 elements, 1,000 outputs).

Last, the implicit algorithms: the static roll-up against Exudyn's
static solver, and the work–precision study — for the three-bar and its steel
variant, each engine/algorithm at several steps, the error of the coupler's
mid-span deflection against a converged-in-time reference of the same mesh and
engine against the solve time; a figure, and the time of each at matched
accuracy (0.1 % of the peak deflection) with the ratios.  ``FLEXMBS_QUICK=1``
(or ``--quick``) runs fewer steps.

Every line with a target ends in ``MET`` or ``MISSED`` (:class:`Target`); the last lines list the
missed targets (:func:`target_summary`), and the command exits with status 1 when one is missed.
"""

from __future__ import annotations

import math
import os
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


@dataclass
class Target:
    """A benchmark's target: the measured ``value`` of ``what`` meets it when ``value ≤ limit``
    (a NaN never does); ``fmt`` formats both numbers."""

    what: str
    value: float
    limit: float
    fmt: str = "{:.3g}"

    @property
    def met(self) -> bool:
        return bool(self.value <= self.limit)

    @property
    def mark(self) -> str:
        """``MET`` or ``MISSED``, the word that ends the benchmark's line."""
        return "MET" if self.met else "MISSED"

    def describe(self) -> str:
        """``what: value (target ≤ limit)``."""
        return f"{self.what}: {self.fmt.format(self.value)} (target ≤ {self.fmt.format(self.limit)})"


def target_summary(targets: list[Target]) -> tuple[list[str], int]:
    """The closing lines of ``flexmbs bench`` — how many targets were met, then every missed one — and
    the exit status (1 when a target was missed)."""
    missed = [t for t in targets if not t.met]
    if not missed:
        return [f"targets: all {len(targets)} met"], 0
    return ([f"targets: {len(targets) - len(missed)} of {len(targets)} met, {len(missed)} MISSED:"]
            + [f"  MISSED  {t.describe()}" for t in missed]), 1


def time_reference(deck: Path, repeat: int) -> tuple[float, int]:
    from reference.domain import Domain

    domain = Domain.from_deck(deck)
    domain.solve()  # warm-up: numba compiles (or loads its cache)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        domain.solve()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), int(round(domain.solver.t_end / domain.solver.dt))


def time_exudyn(deck: Path, repeat: int) -> tuple[float, int]:
    """Exudyn on the same deck through the generic translation (crosscheck.exudyn_model)."""
    from crosscheck.exudyn_model import solve
    from reference.domain import Domain

    solve(Domain.from_deck(deck), t_end=20 * Domain.from_deck(deck).solver.dt)  # warm-up
    times, steps = [], 0
    for _ in range(repeat):
        out = solve(Domain.from_deck(deck))
        times.append(out["wall_time"])
        steps = out["steps"]
    return statistics.median(times), steps


CASES = {
    "embedded beam roll-up (12 Beam2, 10,000 steps)": ROOT / "models" / "embedded_beam.toml",
    "three-bar mechanism (4 Beam2 + 2 rigid, 5 joints, 50,000 steps)": ROOT / "models" / "three_bar.toml",
}


WP_CASES = {
    # name: deck, t_end [s], output interval [s], implicit steps, explicit steps (fractions of the
    # critical step), reference step
    "three-bar (4 Beam2)": ("three_bar.toml", 4.0, 1e-2, [2e-2, 1e-2, 5e-3, 2e-3, 1e-3], [0.8, 0.4, 0.2], 2.5e-4),
    "steel three-bar (4 Beam2)": ("steel_three_bar.toml", 1.0, 2e-3, [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4], [0.8, 0.4],
                                  1e-5),
}
"""Work–precision cases (output intervals as the decks': 100 and 500 per second); the explicit
steps are fractions of the mesh's critical step."""

MATCHED = 1e-3
"""Matched accuracy of the work–precision table: 0.1 % of the peak coupler deflection."""

REPEAT = 3
"""Timed rounds per point of the work–precision study, the engines alternating (the fastest
counts; fewer rounds when one takes seconds)."""


def _deflection_runner(deck: Path, t_end: float, every: float, algorithm: str, dt: float, engine: str):
    """A warmed-up solver of ``deck`` to ``t_end`` with one engine/algorithm at step dt: a callable
    returning (solve time [s], output times every ``every`` seconds (or every step if longer),
    coupler mid-span deflection)."""
    from flexmbs.verification import observables as ob
    from reference.domain import Domain

    def domain():
        d = Domain.from_deck(deck, overrides={"t_end": t_end})
        d.solver.algorithm, d.solver.dt = algorithm, dt
        d.solver.output_every = max(int(round(every / dt)), 1)
        return d

    if engine == "flexmbs":
        d = domain()
        d.solve(t_end=max(20 * dt, 0.01))  # warm-up (numba cache, first-call set-up)

        def run():
            t0 = time.perf_counter()
            r = d.solve()
            return time.perf_counter() - t0, r.time, ob.midspan_deflection(r)
    else:
        from crosscheck.exudyn_model import solve

        solve(domain(), dt=dt, t_end=20 * dt)

        def run():
            out = solve(domain(), dt=dt)
            return out["wall_time"], out["results"].time, ob.midspan_deflection(out["results"])
    return run


def _timed(runners) -> list:
    """Run the runners in turn, up to ``REPEAT`` rounds (fewer when a round takes seconds), so
    that all see the same machine load; each keeps its fastest time."""
    best = [None] * len(runners)
    spent = 0.0
    for _ in range(REPEAT):
        for k, run in enumerate(runners):
            wall, tt, dd = run()
            spent += wall
            if best[k] is None or wall < best[k][0]:
                best[k] = (wall, tt, dd)
        if spent > 5.0:
            break
    return best


def _error(times, defl, ref_times, ref_defl) -> float:
    """Max deflection error on the common output times, relative to the reference's peak."""
    common = np.intersect1d(np.round(times, 9), np.round(ref_times, 9))
    a = np.interp(common, times, defl)
    b = np.interp(common, ref_times, ref_defl)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(ref_defl)))


def _whole_step(limit: float, every: float) -> float:
    """The largest step ≤ ``limit`` that divides the output interval ``every`` (hence the end time)."""
    return every / int(np.ceil(every / limit))


def work_precision(quick: bool = False) -> dict:
    """Error against a converged-in-time reference of the same mesh and engine, and solve time,
    for flexmbs explicit, flexmbs generalized-α and Exudyn's generalized-α (ρ∞ = 0.8, the
    decks' value) at several steps.  Returns ``{case: {"series": {name: [(dt, time, error)]}, …}}``."""
    from reference.domain import Domain

    data = {}
    for name, (deck_name, t_end, every, implicit, explicit, dt_ref) in WP_CASES.items():
        deck = ROOT / "models" / deck_name
        if quick:
            implicit, explicit = implicit[1:4], explicit[:1]
        crit = Domain.from_deck(deck).critical_time_step()
        series, refs = {}, {}
        for engine in ("flexmbs", "exudyn"):
            _, rt, rd = _deflection_runner(deck, t_end, every, "generalized_alpha", dt_ref, engine)()
            refs[engine] = (rt, rd)
            series[f"{engine} generalized-α"] = []
        for dt in implicit:
            runs = _timed([_deflection_runner(deck, t_end, every, "generalized_alpha", dt, e)
                           for e in ("flexmbs", "exudyn")])
            for engine, (wall, tt, dd) in zip(("flexmbs", "exudyn"), runs):
                series[f"{engine} generalized-α"].append((dt, wall, _error(tt, dd, *refs[engine])))
        rows = []
        for frac in explicit:
            dt = _whole_step(frac * crit, every)
            (wall, tt, dd), = _timed([_deflection_runner(deck, t_end, every, "staggered_central_difference", dt,
                                                         "flexmbs")])
            rows.append((dt, wall, _error(tt, dd, *refs["flexmbs"])))
        series["flexmbs explicit"] = rows
        data[name] = {"series": series, "t_end": t_end, "peak": float(np.max(np.abs(refs["flexmbs"][1]))),
                      "dt_ref": dt_ref}
    return data


def matched_time(rows, target: float = MATCHED):
    """Solve time at the error ``target``: log–log interpolation between the two runs that
    bracket it; ``(time, how)``, time None when no run reaches it."""
    rows = sorted(rows, key=lambda r: -r[0])
    for (_, w0, e0), (_, w1, e1) in zip(rows, rows[1:]):
        if e0 > target >= e1:
            s = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(w0) + s * (np.log(w1) - np.log(w0)))), "interpolated"
    ok = [r for r in rows if r[2] <= target]
    if ok:
        return min(r[1] for r in ok), f"largest step already within (dt = {ok[0][0]:g})"
    return None, "not reached"


def work_precision_table(data: dict) -> list[str]:
    """Markdown lines: every run, then the time at matched accuracy and the ratio to Exudyn."""
    lines = []
    for name, case in data.items():
        lines += [f"**{name}**, {case['t_end']:g} s; reference: each engine's own generalized-α at "
                  f"dt = {case['dt_ref']:g}; peak coupler deflection {case['peak']:.3e} m", "",
                  "| engine / algorithm | dt [s] | solve [s] | error / peak |", "|---|---|---|---|"]
        for series, rows in case["series"].items():
            for dt, wall, err in rows:
                lines.append(f"| {series} | {dt:.3g} | {wall:.4f} | {err:.2e} |")
        lines += ["", f"At matched accuracy ({MATCHED:.1%} of the peak deflection):", "",
                  "| engine / algorithm | solve [s] | how | ratio to Exudyn |", "|---|---|---|---|"]
        t_ex, _ = matched_time(case["series"]["exudyn generalized-α"])
        for series, rows in case["series"].items():
            t, how = matched_time(rows)
            if t is None:
                lines.append(f"| {series} | – | {how} | – |")
            else:
                ratio = f"{t / t_ex:.3f}" if t_ex else "–"
                lines.append(f"| {series} | {t:.4f} | {how} | {ratio} |")
        lines.append("")
    return lines


def work_precision_figure(data: dict, path: Path) -> Path:
    """Error against solve time (log–log), one panel per case; returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(data), figsize=(5.2 * len(data), 4.2))
    for ax, (name, case) in zip(np.atleast_1d(axes), data.items()):
        for (series, rows), marker in zip(case["series"].items(), "os^"):
            rows = sorted(rows)
            ax.loglog([r[1] for r in rows], [r[2] for r in rows], marker=marker, label=series)
        ax.axhline(MATCHED, color="0.5", lw=0.8, ls="--", label=f"matched accuracy {MATCHED:.1%}")
        ax.set_xlabel("solve time [s]")
        ax.set_ylabel("max deflection error / peak")
        ax.set_title(name)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def static_rollup(targets: list | None = None) -> list[str]:
    """The roll-up with ``algorithm = "static"``, 20 load steps: flexmbs against Exudyn's static
    solver, same process (median of 5 interleaved solves after a warm-up), and the tip against
    the discrete polygon."""
    from crosscheck.exudyn_model import solve
    from flexmbs.verification.analytic import polygon_tip
    from reference.domain import Domain, SolverSettings

    def domain():
        d = Domain.from_deck(ROOT / "models" / "embedded_beam.toml")
        d.solver = SolverSettings(algorithm="static", t_end=2.0, load_steps=20, dt=0.1)
        return d

    d = domain()
    d.solve()
    solve(domain())
    ours, theirs = [], []
    for _ in range(5):  # interleaved, so that both see the same machine load
        t0 = time.perf_counter()
        r = d.solve()
        ours.append(time.perf_counter() - t0)
        theirs.append(solve(domain())["wall_time"])
    err = np.linalg.norm(r.position("beam:12")[10] - polygon_tip(10.0, 12, 1.0)) / 10.0
    t_o, t_e = statistics.median(ours), statistics.median(theirs)
    target = Target("static roll-up, flexmbs / Exudyn", t_o / t_e, 0.3, "{:.3f}")
    (targets if targets is not None else []).append(target)
    return ["**Static roll-up** (12 Beam2, 20 load steps to k = 2), median of 5 interleaved solves:", "",
            "| engine | solve [s] |", "|---|---|", f"| flexmbs static | {t_o:.4f} |",
            f"| Exudyn static solver | {t_e:.4f} |", "",
            f"ratio flexmbs / Exudyn = {t_o / t_e:.3f} (target ≤ 0.3) {target.mark}; flexmbs tip at k = 1 "
            "against the "
            f"discrete 12-chord polygon: {err:.1e} L", ""]


LINK = dict(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01, rhoJ3=0.01)
"""A rigid link's section (only the inertia is used): 1 kg/m."""


def spherical_chain(K: int, length: float = 0.1, dt: float = 1e-4, steps: int = 1000):
    """K rigid links of ``length`` [m] along x, joined end to end by spherical joints, the first
    pinned to the ground at the origin; gravity −9.81 ẑ; ``steps`` steps of ``dt``."""
    import numpy as np

    from reference.domain import Domain, SolverSettings
    from reference.elements import Section
    from reference.interactions import Gravity

    d = Domain(f"spherical chain of {K} links")
    prev = None
    for k in range(K):
        a, b = np.array([k * length, 0.0, 0.0]), np.array([(k + 1) * length, 0.0, 0.0])
        link = d.add_rigid_bar(f"link{k}", a, b, Section(**LINK))
        d.add_joint("spherical", link, prev, a, label=f"J{k}")
        prev = link
    d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    d.solver = SolverSettings(dt=dt, t_end=steps * dt, output_every=steps)
    return d


def two_beams(welded: bool, n_elements: int = 32, steps: int = 1000):
    """A cantilever of two straight beams (1 m each along x, ``n_elements`` Beam2 each), clamped at
    the origin, under gravity: the second beam shares the first one's end node, or (``welded``)
    starts at a node of its own joined to it by a ``fixed`` joint.  Step: half the critical one."""
    import numpy as np

    from reference.domain import Domain, SolverSettings
    from reference.elements import Section
    from reference.interactions import Clamp, Gravity

    section = Section(EA=1e6, GA2=1e6, GA3=1e6, GJ=1e3, EI2=1e3, EI3=1e3, rhoA=1.0, rhoJ1=1e-2, rhoJ2=1e-2,
                      rhoJ3=1e-2)
    d = Domain("two welded beams" if welded else "two beams sharing a node")
    first = d.add_beam("a", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), n_elements, section)
    if welded:
        second = d.add_beam("b", (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), n_elements, section)
        d.add_joint("fixed", second[0], first[-1], (1.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0), label="weld")
    else:
        d.add_beam("b", (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), n_elements, section, start_node=first[-1])
    d.add_interaction(Clamp(first[0]))
    d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    dt = 0.5 * d.critical_time_step()
    d.solver = SolverSettings(dt=dt, t_end=steps * dt, output_every=steps)
    return d


def _per_step(domain, repeat: int) -> float:
    """Median wall time per step of the time stepping alone (the algorithm's compiled ``advance``
    from the initial state, model assembly excluded), after a warm-up [s]."""
    model = domain.initialization()
    algo = domain.algorithm()
    steps = int(round(domain.solver.t_end / domain.solver.dt))
    times = []
    for k in range(repeat + 1):
        state = domain.initial_conditions()
        run_state = algo.start(model, state)  # no energy guard: the stepping alone
        t0 = time.perf_counter()
        if algo.advance(model, state, run_state, steps, None) != 0:
            raise RuntimeError(f"{domain.name}: the benchmark run failed")
        if k > 0:  # the first run is the warm-up (compilation or cache load)
            times.append(time.perf_counter() - t0)
    return statistics.median(times) / steps


def chain_scaling(repeat: int = 3, sizes=(50, 100, 200, 400),
                  targets: list | None = None) -> list[tuple[int, float]]:
    """Per-step cost of :func:`spherical_chain` for each K [s]; printed with the ratio to the smallest K
    (target: the largest K costs at most 1.5 × linear, appended to ``targets``)."""
    rows = [(K, _per_step(spherical_chain(K), repeat)) for K in sizes]
    print(f"spherical chain (rigid links, dt = 1e-4, 1000 steps): per-step cost, median of {repeat}")
    print(f"{'K':>5}  {'per step [µs]':>13}  {'ratio to K = ' + str(sizes[0]):>16}  {'K ratio':>7}")
    for K, t in rows:
        print(f"{K:5d}  {t * 1e6:13.2f}  {t / rows[0][1]:16.2f}  {K / sizes[0]:7.1f}")
    target = Target(f"spherical chain, cost of K = {sizes[-1]} / K = {sizes[0]}", rows[-1][1] / rows[0][1],
                    1.5 * sizes[-1] / sizes[0], "{:.2f}")
    (targets if targets is not None else []).append(target)
    print(f"target: K = {sizes[-1]} costs ≤ {target.limit:g}× K = {sizes[0]} (linear: "
          f"{sizes[-1] / sizes[0]:.0f}×): {target.value:.2f}× {target.mark}")
    return rows


def welded_vs_shared(repeat: int = 3, targets: list | None = None) -> tuple[float, float]:
    """Per-step cost of :func:`two_beams` welded by a ``fixed`` joint and sharing the node [s], and
    the tip deflection of both (the weld must not change the answer)."""
    out = []
    for welded in (False, True):
        d = two_beams(welded)
        t = _per_step(d, repeat)
        tip = d.solve().position("b:32")[-1, 2]
        out.append((t, tip))
    (t_s, z_s), (t_w, z_w) = out
    target = Target("two beams, welded / sharing the node", t_w / t_s, 2.0, "{:.2f}")
    (targets if targets is not None else []).append(target)
    print("two beams (2 × 32 Beam2, gravity, 1000 steps): per-step cost")
    print(f"  sharing the node {t_s * 1e6:9.2f} µs   tip z {z_s:.9f} m")
    print(f"  welded (fixed)   {t_w * 1e6:9.2f} µs   tip z {z_w:.9f} m   ratio {t_w / t_s:.2f} (target ≤ 2) "
          f"{target.mark}")
    return t_s, t_w


THROUGHPUT = dict(elements=768, length=10.0, radius=0.05, density=1000.0, E=1e7, G=1e7 / 3.0, torque=0.01,
                  dt=1e-4, steps=1000)
"""The beam-throughput case: a clamped straight rod (circular section) under a constant end torque
about an axis normal to the rod, both codes at the same step; G = E/3 (ν = 0.5, PyElastica's
default relation)."""


def _throughput_section():
    import math

    from reference.elements import Section

    c = THROUGHPUT
    A, I = math.pi * c["radius"] ** 2, math.pi * c["radius"] ** 4 / 4.0
    rho = c["density"]
    return Section(EA=c["E"] * A, GA2=c["G"] * A, GA3=c["G"] * A, GJ=c["G"] * 2.0 * I, EI2=c["E"] * I,
                   EI3=c["E"] * I, rhoA=rho * A, rhoJ1=rho * 2.0 * I, rhoJ2=rho * I, rhoJ3=rho * I)


def throughput_cantilever(elements: int | None = None):
    """The throughput case in flexmbs: Beam2 elements (default ``THROUGHPUT["elements"]``), clamp at
    x = 0, dead end moment about y."""
    import numpy as np

    from reference.domain import Domain, SolverSettings
    from reference.interactions import Clamp, NodalLoad

    c = THROUGHPUT
    elements = elements or c["elements"]
    d = Domain(f"cantilever of {elements} elements")
    nodes = d.add_beam("rod", (0.0, 0.0, 0.0), (c["length"], 0.0, 0.0), elements, _throughput_section())
    d.add_interaction(Clamp(nodes[0]))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, c["torque"], 0.0]), moment=True))
    d.solver = SolverSettings(dt=c["dt"], t_end=c["steps"] * c["dt"], output_every=c["steps"])
    return d


def _elastica_runner():
    """PyElastica (numba, position Verlet) on the throughput case: ``run(steps) → (wall [s], tip z)``."""
    import contextlib
    import io

    import elastica as ea
    import numpy as np

    c = THROUGHPUT

    class EndTorque(ea.NoForces):
        def __init__(self, torque):
            super().__init__()
            self.torque = np.asarray(torque, dtype=float)

        def apply_torques(self, system, time=np.float64(0.0)):
            system.external_torques[..., -1] += system.director_collection[..., -1] @ self.torque

    def run(steps):
        class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
            pass

        sim = Sim()
        rod = ea.CosseratRod.straight_rod(c["elements"], np.zeros(3), np.array([1.0, 0.0, 0.0]),
                                          np.array([0.0, 0.0, 1.0]), c["length"], c["radius"], c["density"],
                                          youngs_modulus=c["E"], shear_modulus=c["G"])
        sim.append(rod)
        sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
        sim.add_forcing_to(rod).using(EndTorque, torque=[0.0, c["torque"], 0.0])
        sim.finalize()
        with contextlib.redirect_stdout(io.StringIO()):  # integrate() prints the final time
            t0 = time.perf_counter()
            ea.integrate(ea.PositionVerlet(), sim, steps * c["dt"], steps, progress_bar=False)
            wall = time.perf_counter() - t0
        return wall, float(rod.position_collection[2, -1])

    return run


def _flexmbs_runner():
    """flexmbs on the throughput case (the compiled stepping alone, with the per-step energy guard of
    every run): ``run(steps) → (wall [s], tip z)``."""
    from reference.monitor import energy_floor

    d = throughput_cantilever()
    model, algo = d.initialization(), d.algorithm()

    def run(steps):
        state = d.initial_conditions()
        # the per-step energy guard every run has, from its round-off floor (reference.monitor.energy_floor)
        run_state = algo.start(model, state, d.critical_time_step(), energy_floor(model, state.x))
        t0 = time.perf_counter()
        if algo.advance(model, state, run_state, steps, None) != 0:
            raise RuntimeError("the throughput run failed")
        return time.perf_counter() - t0, float(state.x[-1, 2])

    return run


def beam_throughput(repeat: int = 3, targets: list | None = None) -> tuple[float, float | None]:
    """Per element-step cost of the explicit step with Beam2 elements (768 elements) and of PyElastica
    on the same cantilever [s]: runs alternate between the two codes (median of ``repeat`` each,
    after a warm-up), so that both see the same machine; PyElastica is skipped (None) when not
    installed."""
    from reference.jit import threads

    c = THROUGHPUT
    runners = {"flexmbs": _flexmbs_runner()}
    try:
        runners["PyElastica"] = _elastica_runner()
    except ImportError:
        pass
    times: dict = {name: [] for name in runners}
    tips = {}
    for name, run in runners.items():
        run(10)  # warm-up: compilation
    for _ in range(repeat):
        for name, run in runners.items():
            wall, tips[name] = run(c["steps"])
            times[name].append(wall / (c["steps"] * c["elements"]))
    per = {name: statistics.median(t) for name, t in times.items()}
    print(f"beam throughput: clamped rod, end torque, {c['elements']} elements, dt = {c['dt']:g}, {c['steps']} steps, "
          f"runs alternating (FLEXMBS_THREADS = {threads()})")
    targets = targets if targets is not None else []
    cost = Target("beam throughput, flexmbs µs per element-step", per["flexmbs"] * 1e6, 0.15, "{:.3f}")
    targets.append(cost)
    for name in runners:
        print(f"  {name:<10} {per[name] * 1e6:7.3f} µs per element-step   tip z {tips[name]:.6e} m"
              + (f"   (target ≤ 0.15 µs) {cost.mark}" if name == "flexmbs" else ""))
    if "PyElastica" not in per:
        print("  PyElastica not installed (pip install -e '.[bench]'): comparison skipped")
        return per["flexmbs"], None
    ratio = Target("beam throughput, flexmbs / PyElastica", per["flexmbs"] / per["PyElastica"], 1.0, "{:.2f}")
    targets.append(ratio)
    print(f"  ratio flexmbs / PyElastica {ratio.value:.2f} (target ≤ 1.0) {ratio.mark}")
    return per["flexmbs"], per["PyElastica"]


def vtk_cost(elements: int = 2000, outputs: int = 1000, every: int = 5, targets: list | None = None) -> float:
    """Share of ``flexmbs run`` spent writing ParaView output: a 2,000-element cantilever with 1,000 outputs.

    The same cantilever as the throughput case, meshed finer, with a results file;
    the solve and then :func:`reference.io.vtk.write_vtk` are timed after a short
    warm-up run (compilation).  Prints and returns vtk / (solve + vtk) (target ≤ 20 %).
    """
    import tempfile

    from reference.io.vtk import write_vtk

    d = throughput_cantilever(elements)
    dt = 0.5 * d.critical_time_step()
    d.solver.dt, d.solver.output_every = dt, every
    with tempfile.TemporaryDirectory() as tmp:
        warm = d.solve(t_end=2 * every * dt, results_path=Path(tmp) / "warm.h5")
        write_vtk(d, warm, Path(tmp) / "warm")
        t0 = time.perf_counter()
        r = d.solve(t_end=outputs * every * dt, results_path=Path(tmp) / "results.h5")
        t1 = time.perf_counter()
        path = write_vtk(d, r, Path(tmp) / "vtk")
        t2 = time.perf_counter()
        size = path.stat().st_size
    share = (t2 - t1) / (t2 - t0)
    target = Target("VTK output, share of the run", share, 0.20, "{:.1%}")
    (targets if targets is not None else []).append(target)
    print(f"VTK output: {elements} elements, {len(r.time)} outputs ({outputs * every} steps): solve {t1 - t0:.2f} s, "
          f"VTKHDF {t2 - t1:.2f} s ({size / 2**20:.0f} MiB) = {share:.1%} of the run (target ≤ 20 %) {target.mark}")
    return share


def main(args=None) -> int:
    repeat = getattr(args, "repeat", 3) or 3
    rows, targets = [], []
    print(f"flexmbs bench: median of {repeat} timed solves after one warm-up, same process, same data")
    for name, deck in CASES.items():
        t_ref, n_ref = time_reference(deck, repeat)
        t_exu, n_exu = time_exudyn(deck, repeat)
        rows.append((name, t_ref, n_ref, t_exu, n_exu))
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'reference [s]':>13}  {'Exudyn [s]':>10}  {'ratio':>6}  steps (ref/Exudyn)  target")
    for name, t_ref, n_ref, t_exu, n_exu in rows:
        target = Target(f"{name}, reference / Exudyn", t_ref / t_exu if t_exu > 0 else math.nan, 0.3, "{:.3f}")
        targets.append(target)
        print(f"{name:<{width}}  {t_ref:13.4f}  {t_exu:10.4f}  {t_ref / t_exu:6.3f}  {f'{n_ref}/{n_exu}':<18}  "
              f"{target.mark}")
    print("ratio = reference time / Exudyn time (target ≤ 0.3)")
    print()
    chain_scaling(repeat, targets=targets)
    print()
    welded_vs_shared(repeat, targets=targets)
    print()
    beam_throughput(repeat, targets=targets)
    print()
    vtk_cost(targets=targets)
    quick = bool(getattr(args, "quick", False)) or os.environ.get("FLEXMBS_QUICK") == "1"
    print()
    from flexmbs.bench_modes import modes_timing

    print("\n".join(modes_timing(repeat, targets)))
    print()
    lines = static_rollup(targets)
    print("\n".join(lines))
    data = work_precision(quick)
    table = work_precision_table(data)
    print("\n".join(table))
    from flexmbs.bench_adaptive import tolerance_table

    adaptive = tolerance_table(data, quick, targets)
    print("\n".join(adaptive))
    table = table + adaptive
    out = Path(getattr(args, "out", None) or ROOT / "out" / "bench")
    figure = work_precision_figure(data, out / "work_precision.png")
    (out / "work_precision.md").write_text("\n".join(lines + table + [f"![work-precision]({figure.name})", ""]),
                                           encoding="utf-8")
    print(f"figure and tables: {figure}, {out / 'work_precision.md'}")
    print()
    from flexmbs import bench_families

    families = bench_families.work_precision(quick)
    lines = bench_families.table(families)
    print("\n".join(lines))
    figure = bench_families.figure(families, out / "work_precision_families.png")
    (out / "work_precision_families.md").write_text("\n".join(lines + [f"![work-precision]({figure.name})", ""]),
                                                    encoding="utf-8")
    ratio = bench_families.target_lines(families)[1]
    targets.append(Target("element families at 1e-6 L, best / Beam2 solve time", 1.0 / ratio, 0.1, "{:.3f}"))
    coupler, worst = bench_families.coupler_crosscheck(out / "three_bar_beam3_crosscheck", t_end=1.0 if quick else None)
    print("\n".join(coupler))
    targets.append(Target("three-bar, beam3 coupler against Exudyn (converged meshes): worst verdict / tolerance",
                          worst, 1.0, "{:.3f}"))
    print()
    closing, status = target_summary(targets)
    print("\n".join(closing))
    return status
