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
the compiled stepping alone (median of ``repeat`` after a warm-up).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


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
    from reference.state import Scratch

    model = domain.initialization()
    algo = domain.algorithm()
    steps = int(round(domain.solver.t_end / domain.solver.dt))
    times = []
    for k in range(repeat + 1):
        state, scratch = domain.initial_conditions(), Scratch.for_model(model)
        t0 = time.perf_counter()
        if algo.advance(model, state, steps, None, scratch) != 0:
            raise RuntimeError(f"{domain.name}: the benchmark run failed")
        if k > 0:  # the first run is the warm-up (compilation or cache load)
            times.append(time.perf_counter() - t0)
    return statistics.median(times) / steps


def chain_scaling(repeat: int = 3, sizes=(50, 100, 200, 400)) -> list[tuple[int, float]]:
    """Per-step cost of :func:`spherical_chain` for each K [s]; printed with the ratio to the smallest K."""
    rows = [(K, _per_step(spherical_chain(K), repeat)) for K in sizes]
    print(f"spherical chain (rigid links, dt = 1e-4, 1000 steps): per-step cost, median of {repeat}")
    print(f"{'K':>5}  {'per step [µs]':>13}  {'ratio to K = ' + str(sizes[0]):>16}  {'K ratio':>7}")
    for K, t in rows:
        print(f"{K:5d}  {t * 1e6:13.2f}  {t / rows[0][1]:16.2f}  {K / sizes[0]:7.1f}")
    print(f"target: K = {sizes[-1]} costs ≤ 12× K = {sizes[0]} (linear: {sizes[-1] / sizes[0]:.0f}×)")
    return rows


def welded_vs_shared(repeat: int = 3) -> tuple[float, float]:
    """Per-step cost of :func:`two_beams` welded by a ``fixed`` joint and sharing the node [s], and
    the tip deflection of both (the weld must not change the answer)."""
    out = []
    for welded in (False, True):
        d = two_beams(welded)
        t = _per_step(d, repeat)
        tip = d.solve().position("b:32")[-1, 2]
        out.append((t, tip))
    (t_s, z_s), (t_w, z_w) = out
    print("two beams (2 × 32 Beam2, gravity, 1000 steps): per-step cost")
    print(f"  sharing the node {t_s * 1e6:9.2f} µs   tip z {z_s:.9f} m")
    print(f"  welded (fixed)   {t_w * 1e6:9.2f} µs   tip z {z_w:.9f} m   ratio {t_w / t_s:.2f} (target ≤ 2)")
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


def throughput_cantilever():
    """The throughput case in flexmbs: Beam2 elements, clamp at x = 0, dead end moment about y."""
    import numpy as np

    from reference.domain import Domain, SolverSettings
    from reference.interactions import Clamp, NodalLoad

    c = THROUGHPUT
    d = Domain(f"cantilever of {c['elements']} elements")
    nodes = d.add_beam("rod", (0.0, 0.0, 0.0), (c["length"], 0.0, 0.0), c["elements"], _throughput_section())
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
    """flexmbs on the throughput case (the compiled stepping alone): ``run(steps) → (wall [s], tip z)``."""
    from reference.state import Scratch

    d = throughput_cantilever()
    model, algo = d.initialization(), d.algorithm()

    def run(steps):
        state, scratch = d.initial_conditions(), Scratch.for_model(model)
        t0 = time.perf_counter()
        if algo.advance(model, state, steps, None, scratch) != 0:
            raise RuntimeError("the throughput run failed")
        return time.perf_counter() - t0, float(state.x[-1, 2])

    return run


def beam_throughput(repeat: int = 3) -> tuple[float, float | None]:
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
    for name in runners:
        print(f"  {name:<10} {per[name] * 1e6:7.3f} µs per element-step   tip z {tips[name]:.6e} m")
    if "PyElastica" not in per:
        print("  PyElastica not installed (pip install -e '.[bench]'): comparison skipped")
        return per["flexmbs"], None
    print(f"  ratio flexmbs / PyElastica {per['flexmbs'] / per['PyElastica']:.2f} (target ≤ 1.0, and ≤ 0.15 µs)")
    return per["flexmbs"], per["PyElastica"]


def main(args=None) -> int:
    repeat = getattr(args, "repeat", 3) or 3
    rows = []
    print(f"flexmbs bench: median of {repeat} timed solves after one warm-up, same process, same data")
    for name, deck in CASES.items():
        t_ref, n_ref = time_reference(deck, repeat)
        t_exu, n_exu = time_exudyn(deck, repeat)
        rows.append((name, t_ref, n_ref, t_exu, n_exu))
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'reference [s]':>13}  {'Exudyn [s]':>10}  {'ratio':>6}  steps (ref/Exudyn)")
    for name, t_ref, n_ref, t_exu, n_exu in rows:
        print(f"{name:<{width}}  {t_ref:13.4f}  {t_exu:10.4f}  {t_ref / t_exu:6.3f}  {n_ref}/{n_exu}")
    print("ratio = reference time / Exudyn time (target ≤ 0.3)")
    print()
    chain_scaling(repeat)
    print()
    welded_vs_shared(repeat)
    print()
    beam_throughput(repeat)
    return 0
