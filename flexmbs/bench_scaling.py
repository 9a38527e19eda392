"""``flexmbs bench``: the scaling of the constraint stage.

The per-step cost of a chain of K rigid links joined by spherical joints (K = 50 … 1,000; linear in K
with the sparse stage: a straight-line fit cost = a + b·K over the sizes, its largest deviation and the
per-link cost at each size), the same chain in Exudyn where asked, and two beams welded by a ``fixed``
joint against the same beams sharing a node.  Per-step costs time the compiled stepping alone (the
algorithm's ``advance`` from the initial state, model assembly excluded; median of ``repeat`` after a
warm-up).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from flexmbs.bench_common import Target

LINK = dict(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01, rhoJ3=0.01)
"""A rigid link's section (only the inertia is used): 1 kg/m."""


def spherical_chain(K: int, length: float = 0.1, dt: float = 1e-4, steps: int = 1000):
    """K rigid links of ``length`` [m] along x, joined end to end by spherical joints, the first
    pinned to the ground at the origin; gravity −9.81 ẑ; ``steps`` steps of ``dt``."""
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


CHAIN_SIZES = (50, 100, 200, 400, 1000)
"""Links of the chain-scaling rows: up to the issue's 1,000-link chain."""


def linear_fit(sizes, costs) -> tuple[float, float, float]:
    """Least-squares line cost = a + b·K through the rows; ``(a, b, largest |cost − line| / cost)``."""
    K, c = np.asarray(sizes, dtype=float), np.asarray(costs, dtype=float)
    b, a = np.polyfit(K, c, 1)
    return float(a), float(b), float(np.max(np.abs(c - (a + b * K)) / c))


def chain_scaling(repeat: int = 3, sizes=CHAIN_SIZES, targets: list | None = None,
                  exudyn: bool = True) -> list[tuple[int, float]]:
    """Per-step cost of :func:`spherical_chain` for each K [s]; printed with the per-link cost, the ratio to the
    smallest K and the deviation from the straight line :func:`linear_fit` (targets, appended to ``targets``:
    the largest K costs at most 1.5 × linear from the smallest, and no size is off the line by more than 15 %
    — a stage that is K log K or worse bends away from it by more).  ``exudyn``: the same chain in Exudyn
    (its generalized-α at the same step, the translation of :mod:`crosscheck.exudyn_model`; one run each,
    its ``SolveSystem`` call per step) and the distance between the two codes' last links (their nodes) at the end."""
    rows = [(K, _per_step(spherical_chain(K), repeat)) for K in sizes]
    a, b, worst = linear_fit(*zip(*rows))
    theirs = _exudyn_chain(sizes) if exudyn else {}
    print(f"spherical chain (rigid links, dt = 1e-4, 1000 steps): per-step cost, median of {repeat}")
    print(f"{'K':>5}  {'per step [µs]':>13}  {'per link [µs]':>13}  {'ratio to K = ' + str(sizes[0]):>16}  "
          f"{'K ratio':>7}  {'off the line':>12}" + ("  Exudyn per step [µs]  last link apart [m]" if theirs else ""))
    for K, t in rows:
        print(f"{K:5d}  {t * 1e6:13.2f}  {t / K * 1e6:13.3f}  {t / rows[0][1]:16.2f}  {K / sizes[0]:7.1f}  "
              f"{(t - a - b * K) / t:12.1%}" + (f"  {theirs[K][0] * 1e6:20.1f}  {theirs[K][1]:19.1e}" if theirs else ""))
    target = Target(f"spherical chain, cost of K = {sizes[-1]} / K = {sizes[0]}", rows[-1][1] / rows[0][1],
                    1.5 * sizes[-1] / sizes[0], "{:.2f}")
    line = Target("spherical chain, largest deviation from cost = a + b·K", worst, 0.15, "{:.1%}")
    if targets is not None:
        targets += [target, line]
    print(f"fit: cost = {a * 1e6:.2f} µs + {b * 1e6:.4f} µs · K; largest deviation {worst:.1%} (target ≤ 15 %) "
          f"{line.mark}")
    print(f"target: K = {sizes[-1]} costs ≤ {target.limit:g}× K = {sizes[0]} (linear: "
          f"{sizes[-1] / sizes[0]:.0f}×): {target.value:.2f}× {target.mark}")
    return rows


def _exudyn_chain(sizes) -> dict:
    """``{K: (Exudyn's solve time per step [s], distance of the last link's node from flexmbs' at the end [m])}``."""
    from crosscheck.exudyn_model import solve

    solve(spherical_chain(sizes[0], steps=20))  # warm-up: Exudyn's first-call set-up
    out = {}
    for K in sizes:
        d = spherical_chain(K)
        run = solve(d)
        ours, theirs = d.solve().position(f"link{K - 1}")[-1], run["results"].position(f"link{K - 1}")[-1]
        out[K] = (run["wall_time"] / run["steps"], float(np.linalg.norm(ours - theirs)))
    return out


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
