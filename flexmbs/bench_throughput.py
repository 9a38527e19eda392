"""``flexmbs bench``: Beam2 throughput beside PyElastica, and the cost of ParaView output.

The throughput case is a clamped straight rod under a constant end moment (:data:`THROUGHPUT`), the
same rod and step in both codes, runs alternating in one process (µs per element-step, both tips
printed): the stepping alone, and the whole run of issue 25's target (flexmbs' ``Domain.solve()`` against
PyElastica's rod construction, ``finalize`` and ``integrate``); :mod:`flexmbs.bench_large` runs it at
50,000 elements.  Then the share of a run spent writing
ParaView output (2,000 elements, 1,000 outputs).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from flexmbs.bench_common import Target

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


def elastica_runner(elements: int | None = None, dt: float | None = None):
    """PyElastica (numba, position Verlet) on the throughput case with ``elements`` elements (default
    ``THROUGHPUT["elements"]``) at the step ``dt`` [s] (default ``THROUGHPUT["dt"]``): ``run(steps,
    timing=None) → (wall [s], tip z [m])``.  The wall time is the ``integrate`` call alone (the rod, its
    boundary condition and forcing built and ``finalize``-d before the clock starts); ``timing`` (a dict,
    when given) receives ``"setup"``, the wall time of that construction and ``finalize`` [s], and
    ``"integrate"``."""
    import contextlib
    import io

    import elastica as ea
    import numpy as np

    c = THROUGHPUT
    elements, dt = elements or c["elements"], dt or c["dt"]

    class EndTorque(ea.NoForces):
        def __init__(self, torque):
            super().__init__()
            self.torque = np.asarray(torque, dtype=float)

        def apply_torques(self, system, time=np.float64(0.0)):
            system.external_torques[..., -1] += system.director_collection[..., -1] @ self.torque

    def run(steps, timing: dict | None = None):
        class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
            pass

        t_setup = time.perf_counter()
        sim = Sim()
        rod = ea.CosseratRod.straight_rod(elements, np.zeros(3), np.array([1.0, 0.0, 0.0]),
                                          np.array([0.0, 0.0, 1.0]), c["length"], c["radius"], c["density"],
                                          youngs_modulus=c["E"], shear_modulus=c["G"])
        sim.append(rod)
        sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
        sim.add_forcing_to(rod).using(EndTorque, torque=[0.0, c["torque"], 0.0])
        sim.finalize()
        with contextlib.redirect_stdout(io.StringIO()):  # integrate() prints the final time
            t0 = time.perf_counter()
            ea.integrate(ea.PositionVerlet(), sim, steps * dt, steps, progress_bar=False)
            wall = time.perf_counter() - t0
        if timing is not None:
            timing.update(setup=t0 - t_setup, integrate=wall)
        return wall, float(rod.position_collection[2, -1])

    return run


def flexmbs_runner(elements: int | None = None, dt: float | None = None, final: dict | None = None):
    """flexmbs on the throughput case with ``elements`` elements at the step ``dt`` [s] (defaults as
    :func:`elastica_runner`): the compiled stepping alone (the algorithm's ``advance`` from the initial
    state, with the per-step energy guard of every run; model assembly and start excluded): ``run(steps)
    → (wall [s], tip z [m])``; ``final`` (a dict, when given) receives the last run's nodal positions and
    rotations (``"x"``, ``"q"``)."""
    from reference.monitor import energy_floor

    d = throughput_cantilever(elements)
    if dt is not None:
        d.solver.dt = dt
    model, algo = d.initialization(), d.algorithm()

    def run(steps):
        state = d.initial_conditions()
        # the per-step energy guard every run has, from its round-off floor (reference.monitor.energy_floor)
        run_state = algo.start(model, state, d.critical_time_step(), energy_floor(model, state.x))
        t0 = time.perf_counter()
        if algo.advance(model, state, run_state, steps, None) != 0:
            raise RuntimeError("the throughput run failed")
        if final is not None:
            final["x"], final["q"] = state.x.copy(), state.q.copy()
        return time.perf_counter() - t0, float(state.x[-1, 2])

    return run


def solve_runner(elements: int | None = None, dt: float | None = None):
    """flexmbs' whole ``Domain.solve`` on the throughput case (defaults as :func:`elastica_runner`): model
    assembly, the checks, the critical step, the monitor, the start, the stepping and two outputs; the
    Domain (its nodes and elements, ``add_beam``) built once before: ``run(steps) → (wall [s], tip z [m])``."""
    d = throughput_cantilever(elements)
    h = d.solver.dt if dt is None else dt

    def run(steps):
        d.solver.dt, d.solver.t_end, d.solver.output_every = h, steps * h, steps
        t0 = time.perf_counter()
        r = d.solve()
        return time.perf_counter() - t0, float(r.position("rod:end")[-1, 2])

    return run


def beam_throughput(repeat: int = 3, targets: list | None = None) -> tuple[float, float | None]:
    """Per element-step cost of Beam2 elements (768 elements) and of PyElastica on the same cantilever [s],
    runs alternating between the codes (median of ``repeat`` each, after a warm-up), so that all see the same
    machine: the stepping alone (flexmbs' compiled ``advance``, PyElastica's ``integrate``), then the whole
    run as issue 25 asks (flexmbs' ``Domain.solve()``, set-up included; PyElastica's rod built and
    ``finalize``-d, then ``integrate``), compilation excluded in both.  PyElastica is skipped (None) when
    not installed.  Returns flexmbs' and PyElastica's stepping costs."""
    from reference.jit import threads

    c = THROUGHPUT
    steps, size = c["steps"], c["steps"] * c["elements"]
    runners = {"flexmbs": flexmbs_runner(), "flexmbs solve()": solve_runner()}
    try:
        runners["PyElastica"] = elastica_runner()
    except ImportError:
        pass
    times: dict = {name: [] for name in runners} | ({"PyElastica whole": []} if "PyElastica" in runners else {})
    tips = {}
    for run in runners.values():
        run(10)  # warm-up: compilation
    for _ in range(repeat):
        for name, run in runners.items():
            timing: dict = {}
            wall, tips[name] = run(steps, timing) if name == "PyElastica" else run(steps)
            times[name].append(wall / size)
            if timing:
                times["PyElastica whole"].append((timing["setup"] + timing["integrate"]) / size)
    per = {name: statistics.median(t) for name, t in times.items()}
    built = time.perf_counter()
    throughput_cantilever()
    built = time.perf_counter() - built
    print(f"beam throughput: clamped rod, end torque, {c['elements']} elements, dt = {c['dt']:g}, {steps} steps, "
          f"runs alternating (flexmbs on {threads(c['elements'] + 1)} thread(s), the default for this size)")
    targets = targets if targets is not None else []
    cost = Target("beam throughput, flexmbs µs per element-step", per["flexmbs"] * 1e6, 0.15, "{:.3f}")
    targets.append(cost)
    for name in ("flexmbs", "PyElastica"):
        if name in per:
            print(f"  {name:<10} {per[name] * 1e6:7.3f} µs per element-step, stepping alone   tip z {tips[name]:.6e} m"
                  + (f"   (target ≤ 0.15 µs) {cost.mark}" if name == "flexmbs" else ""))
    setup = (per["flexmbs solve()"] - per["flexmbs"]) * size
    print(f"  flexmbs Domain.solve() {per['flexmbs solve()'] * 1e6:.3f} µs per element-step (set-up and outputs "
          f"≈ {setup * 1e3:.1f} ms; building the Domain, add_beam, {built * 1e3:.0f} ms, not counted)")
    if "PyElastica" not in per:
        print("  PyElastica not installed (pip install -e '.[bench]'): comparison skipped")
        return per["flexmbs"], None
    ratio = Target("beam throughput, flexmbs / PyElastica, stepping alone", per["flexmbs"] / per["PyElastica"], 1.0,
                   "{:.2f}")
    targets.append(ratio)
    print(f"  ratio flexmbs / PyElastica, stepping alone {ratio.value:.2f} (target ≤ 1.0) {ratio.mark}")
    pye_setup = (per["PyElastica whole"] - per["PyElastica"]) * size
    print(f"  PyElastica rod built, finalize-d and integrated {per['PyElastica whole'] * 1e6:.3f} µs per "
          f"element-step (set-up ≈ {pye_setup * 1e3:.1f} ms)")
    whole = Target("beam throughput, flexmbs Domain.solve() / PyElastica set-up + integrate (issue 25)",
                   per["flexmbs solve()"] / per["PyElastica whole"], 0.5, "{:.2f}")
    targets.append(whole)
    print(f"  ratio flexmbs Domain.solve() / PyElastica set-up + integrate {whole.value:.2f} (issue 25: target ≤ 0.5) "
          f"{whole.mark}")
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
