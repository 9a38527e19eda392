"""The verification suite every registered element family runs.

A family registered in :data:`reference.elements.families.ELEMENT_FAMILIES` by the engine
(its class defined under ``reference.``) gets every check here by registration:

* :func:`element_checks` — one element of the family: rigid motion gives zero forces and
  energy; objectivity (strains unchanged under a superposed rigid motion, Crisfield &
  Jelenić 1999); path independence (a closed loop, a superposed full turn in 16 steps,
  returns the same forces); patch test (the constant-strain states the family claims,
  :attr:`exact_curvature`, represented exactly); tangent against central differences;
* :func:`locking` — a thin cantilever from L/h = 10 to 1e4 under a tip load, linear
  stiffness of 4 elements against Timoshenko's deflection: the error must not grow;
* :func:`orders` — observed convergence orders (meshes n and 2n) of the static roll-up
  (half circle, k = 1), the quarter-arc cantilever under a small out-of-plane force, the
  45° bend (Bathe & Bolourchi 1979, P = 600, against the next finer mesh), the
  large-deflection cantilever (P L²/EI = 1, Bisshopp & Drucker 1945) and the first
  cantilever frequency (Timoshenko equation);
* :func:`integration_point_moments` — the section moments at each family's integration points
  against the statics of a cantilever under a tip force.

``python -m flexmbs.verification.families [--long]`` prints the table (``make families``);
the tests run the short version with the engine uncompiled (``tests/test_families.py``).
"""

from __future__ import annotations

import functools
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from reference.elements.families import ELEMENT_FAMILIES
from reference.elements.section import Section
from reference.generated import rotation_maps as rm

MODELS = Path(__file__).resolve().parents[2] / "models"
SECTION = Section(EA=50.0, GA2=20.0, GA3=30.0, GJ=2.0, EI2=3.0, EI3=4.0, rhoA=1.0, rhoJ1=1e-3, rhoJ2=1e-3,
                  rhoJ3=1e-3)
"""An anisotropic section (every stiffness distinct, so a swapped axis shows)."""


def engine_families() -> list[str]:
    """The families the engine registers (toys registered from tests are left out)."""
    return [name for name, cls in ELEMENT_FAMILIES.items() if cls.__module__.startswith("reference.")]


def _qexp(v) -> np.ndarray:
    out = np.empty(4)
    rm.exp_quaternion(np.asarray(v, float), out)
    return out


def _qmul(a, b) -> np.ndarray:
    out = np.empty(4)
    rm.quat_product(np.asarray(a, float), np.asarray(b, float), out)
    return out


def _matrix(q) -> np.ndarray:
    out = np.empty(9)
    rm.rotation_matrix(np.asarray(q, float), out)
    return out.reshape(3, 3)


def helicoid(gamma, kappa, s: float):
    """Position and Euler parameters at arc length s of ``H(s) = exp(s ε̂)`` from the origin and identity:
    ``x = s J_l(sK) Γ``, ``Λ = exp(sK̃)`` (the constant-strain state ``ε = (Γ, K)``)."""
    phi = s * np.asarray(kappa, float)
    jr = np.empty(9)
    rm.right_jacobian(phi, jr)
    return s * jr.reshape(3, 3).T @ np.asarray(gamma, float), _qexp(phi)


def _formulation(name: str):
    return ELEMENT_FAMILIES[name](SECTION)


def _forces(f, x, q, ref):
    s, U = f.internal_forces(np.asarray(x, float), np.asarray(q, float), ref)
    return np.asarray(s, float), float(U)


def _strain(f, x, q, ref) -> np.ndarray:
    return np.asarray(f.section_resultants(np.asarray(x, float), np.asarray(q, float), ref)[0], float)


def _rigid(x, q, R_q, t):
    """Superpose the rigid motion (rotation ``R_q``, translation ``t``) on node positions and frames."""
    A = _matrix(R_q)
    return [A @ xi + t for xi in x], [_qmul(R_q, qi) for qi in q]


def _arc_positions(cls, L: float) -> tuple[list, list]:
    """Arc-length positions of a family's nodes on one element of length L, in the element's order, and
    that order (the indices along the beam)."""
    k = cls.n_nodes
    order = list(cls.mesh_nodes(list(range(k)), 0))
    return [L * j / (k - 1) for j in order], order


def element_checks(name: str, seed: int = 21) -> dict:
    """The one-element checks of a family (module docstring); every entry a measured number."""
    rng = np.random.default_rng(seed)
    f = _formulation(name)
    L, k = 0.7, f.n_nodes
    q0 = _qexp(rng.standard_normal(3))
    x0 = [_matrix(q0) @ np.array([s, 0.0, 0.0]) for s in _arc_positions(type(f), L)[0]]
    ref = f.reference_state(np.array(x0), np.array([q0] * k))
    out = {}
    # rigid motion of the unstrained element
    xr, qr = _rigid(x0, [q0] * k, _qexp(rng.standard_normal(3) * 2.0), rng.standard_normal(3))
    s, U = _forces(f, xr, qr, ref)
    out["rigid_force"] = float(np.abs(s).max()) / (SECTION.EA + SECTION.EI3 / L)
    out["rigid_energy"] = U / (0.5 * SECTION.EA * L)
    # a deformed state: stretch, shear, twist and bending
    xd = [x0[0]] + [x + 0.05 * rng.standard_normal(3) for x in x0[1:]]
    qd = [_qmul(q0, _qexp(0.3 * rng.standard_normal(3))) for _ in range(k)]
    strain = _strain(f, xd, qd, ref)
    xo, qo = _rigid(xd, qd, _qexp(rng.standard_normal(3) * 2.0), rng.standard_normal(3))
    out["objectivity"] = float(np.abs(_strain(f, xo, qo, ref) - strain).max() / np.abs(strain).max())
    # path independence: a superposed full turn about a random axis, in 16 steps
    s_start, U_start = _forces(f, xd, qd, ref)
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    xp, qp = xd, qd
    for _ in range(16):
        xp, qp = _rigid(xp, qp, _qexp(axis * 2.0 * math.pi / 16), np.zeros(3))
    s_end, U_end = _forces(f, xp, qp, ref)
    out["path_force"] = float(np.abs(s_end - s_start).max() / np.abs(s_start).max())
    out["path_energy"] = abs(U_end - U_start) / U_start
    out["patch"] = patch_test(name)
    # tangent against central differences of the forces (ε = 1e-6)
    K = f.tangent(np.array(xd), np.array(qd), ref)
    h, Kfd = 1e-6, np.zeros((6 * k, 6 * k))
    for c in range(6 * k):
        z = np.zeros(6 * k)
        z[c] = h
        sides = []
        for sign in (1.0, -1.0):
            xs = [xd[a] + sign * z[6 * a:6 * a + 3] for a in range(k)]
            qs = [_qmul(qd[a], _qexp(sign * z[6 * a + 3:6 * a + 6])) for a in range(k)]
            sides.append(_forces(f, xs, qs, ref)[0])
        Kfd[:, c] = (sides[0] - sides[1]) / (2 * h)
    out["tangent"] = float(np.abs(K - Kfd).max() / np.abs(K).max())
    return out


def patch_test(name: str) -> float:
    """Largest relative strain error over the constant-strain states the family claims: stretch,
    shear and twist for every family; with :attr:`exact_curvature`, bending and a helix too.
    The element's nodes are put on the helicoid of the state from a straight reference."""
    f = _formulation(name)
    L, k = 0.6, f.n_nodes
    arc, _ = _arc_positions(type(f), L)
    ident = np.array([1.0, 0, 0, 0])
    ref = f.reference_state(np.array([[s, 0.0, 0.0] for s in arc]), np.array([ident] * k))
    states = [((1.02, 0.0, 0.0), (0.0, 0.0, 0.0)), ((1.0, 0.03, -0.02), (0.0, 0.0, 0.0)),
              ((1.0, 0.0, 0.0), (0.8, 0.0, 0.0))]
    if getattr(f, "exact_curvature", False):
        states += [((1.0, 0.0, 0.0), (0.0, 1.5, 0.0)), ((0.99, 0.02, 0.01), (0.5, -0.7, 1.1))]
    worst = 0.0
    for gamma, kappa in states:
        placed = [helicoid(gamma, kappa, s) for s in arc]
        strain = _strain(f, [p[0] for p in placed], [p[1] for p in placed], ref)
        expected = np.concatenate([np.asarray(gamma) - (1.0, 0.0, 0.0), kappa])
        worst = max(worst, float(np.abs(strain - expected).max() / np.abs(expected).max()))
    return worst


def locking(name: str, n: int = 4) -> dict:
    """Tip deflection of a square-section cantilever (E = 1, ν = 0.3, κ = 5/6) under a tip load, from the
    assembled linear stiffness of ``n`` elements, relative to Timoshenko's ``PL³/3EI + PL/κGA``, for
    L/h = 10 … 1e4.  Returns ``{slenderness: relative error}``."""
    out = {}
    cls = ELEMENT_FAMILIES[name]
    per = cls.n_nodes - 1
    points = n * per + 1
    for slenderness in (1e1, 1e2, 1e3, 1e4):
        h, E, G = 1.0 / slenderness, 1.0, 1.0 / 2.6
        A, I = h * h, h**4 / 12
        sec = Section(EA=E * A, GA2=5 / 6 * G * A, GA3=5 / 6 * G * A, GJ=G * 0.141 * h**4, EI2=E * I, EI3=E * I,
                      rhoA=A, rhoJ1=2 * I, rhoJ2=I, rhoJ3=I)
        f = cls(sec)
        arc, order = _arc_positions(cls, 1.0 / n)
        ident = np.array([1.0, 0, 0, 0])
        xe = np.array([[s, 0.0, 0.0] for s in arc])
        Ke = f.tangent(xe, np.array([ident] * cls.n_nodes), f.reference_state(xe, np.array([ident] * cls.n_nodes)))
        K = np.zeros((6 * points, 6 * points))
        for e in range(n):
            dofs = np.concatenate([np.arange(6 * g, 6 * g + 6) for g in cls.mesh_nodes(list(range(points)), e)])
            K[np.ix_(dofs, dofs)] += Ke
        F = np.zeros(6 * points)
        F[-4] = 1.0  # tip force along z
        u = np.linalg.solve(K[6:, 6:], F[6:])
        exact = 1.0 / (3 * E * I) + 1.0 / (5 / 6 * G * A)
        out[slenderness] = abs(u[-4] / exact - 1.0)
    return out


def integration_point_moments(name: str, n: int = 4) -> float:
    """A cantilever (L = 1, EI = 1, EA = GA = 1e6) under a small tip force P = 1e-6 along z, static: the bending
    moment at every integration point (:func:`reference.elements.families.integration_point_resultants`)
    against the statics' ``M₂ = −P (L − s)``; returns the largest difference over P L."""
    from reference.algorithms import SolverSettings
    from reference.domain import Domain
    from reference.elements.families import integration_point_resultants
    from reference.interactions import Clamp, NodalLoad

    P, L = 1e-6, 1.0
    sec = Section(EA=1e6, GA2=1e6, GA3=1e6, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-4, rhoJ2=1e-4, rhoJ3=1e-4)
    d = Domain("cantilever")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (L, 0.0, 0.0), n, sec, element=name)
    d.add_interaction(Clamp(nodes[0]))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, P])))
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=1, tolerance=1e-14)
    r = d.solve()
    worst = 0.0
    for e, (xi, _, M) in enumerate(integration_point_resultants(d, r.positions[-1], r.rotations[-1])):
        s_points = (e + xi) * L / n
        worst = max(worst, float(np.max(np.abs(M[:, 1] + P * (L - s_points)))) / (P * L))
    return worst


def _tip(label: str, name: str, n: int) -> str:
    """The label of the last node of a beam of n elements of the family (n_nodes − 1 segments each)."""
    return f"{label}:{n * (ELEMENT_FAMILIES[name].n_nodes - 1)}"


def _static(deck: str, overrides: dict):
    from reference.io.deck import load_deck

    return load_deck(MODELS / deck, overrides=overrides).domain.solve()


def rollup_error(name: str, n: int) -> float:
    """Static roll-up (docs/benchmarks.md §1) to the half circle, k = 1: |tip − elastica|/L."""
    from flexmbs.verification.analytic import elastica_tip

    r = _static("embedded_beam_static.toml", {"beams.0.elements": n, "beams.0.element": name, "solver.t_end": 1.0,
                                               "solver.load_steps": 4, "solver.tolerance": 1e-12})
    return float(np.linalg.norm(r.position(_tip("beam", name, n))[-1] - elastica_tip(10.0, 1.0)) / 10.0)


def cantilever_tip(name: str, n: int, stiff: float = 1e9) -> np.ndarray:
    """Tip of the static large-deflection cantilever, L = EI = 1, P L²/EI = 1 (dead, along −z), EA = GA =
    ``stiff``, n elements of the family, 4 load steps, Newton to 1e-12."""
    from reference.algorithms import SolverSettings
    from reference.domain import Domain
    from reference.interactions import Clamp, NodalLoad, Ramp

    d = Domain("cantilever")
    sec = Section(EA=stiff, GA2=stiff, GA3=stiff, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-4, rhoJ2=1e-4,
                  rhoJ3=1e-4)
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), n, sec, element=name)
    d.add_interaction(Clamp(nodes[0]))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, -1.0]), time_function=Ramp()))
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=4, tolerance=1e-12)
    return d.solve().position(_tip("beam", name, n))[-1]


def cantilever_error(name: str, n: int) -> float:
    """Static large-deflection cantilever, P L²/EI = 1 (Bisshopp & Drucker 1945), EA = GA = 1e9 so the
    inextensible elastica is the exact answer: |tip − elastica|/L."""
    from flexmbs.verification.analytic import cantilever_large_deflection

    x, delta, _ = cantilever_large_deflection(1.0)
    return float(np.linalg.norm(cantilever_tip(name, n) - np.array([x, 0.0, -delta])))


def frequency_error(name: str, n: int) -> float:
    """First bending frequency of models/cantilever_modes.toml against the Timoshenko frequency equation."""
    from flexmbs.verification.analytic import timoshenko_cantilever_frequencies

    r = _static("cantilever_modes.toml", {"beams.0.elements": n, "beams.0.element": name, "solver.modes": 1})
    exact = timoshenko_cantilever_frequencies(1.0, 1.0, 4e3, 1.0, 1e-4, 1)[0]
    return abs(2 * math.pi * float(r.data("modes/frequency")[0]) / exact - 1.0)


def quarter_arc_error(name: str, n: int) -> float:
    """Quarter-circle cantilever (R = 1, clamped at (R, 0, 0), section axis 2 out of plane) under a small
    out-of-plane tip force P = 1e-4 (linear regime), one static step: tip deflection against the
    curved-beam value ``PR³(π/4EI + (3π/4 − 2)/GJ) + PRπ/2GA`` (EI = 2, GJ = 1.5, GA = 1e4)."""
    from reference.algorithms import SolverSettings
    from reference.domain import Domain
    from reference.interactions import Clamp, NodalLoad

    R, P = 1.0, 1e-4
    sec = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=1.5, EI2=2.0, EI3=2.0, rhoA=1.0, rhoJ1=2e-3, rhoJ2=1e-3, rhoJ3=1e-3)
    d = Domain("quarter arc")
    arc = d.add_beam("arc", (R, 0.0, 0.0), (0.0, R, 0.0), n, sec, axis2=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0),
                     element=name)
    d.add_interaction(Clamp(arc[0]))
    d.add_interaction(NodalLoad(arc[-1], np.array([0.0, 0.0, P])))
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=1, tolerance=1e-13)
    w = d.solve().position(_tip("arc", name, n))[-1][2]
    exact = P * R**3 * (math.pi / (4 * sec.EI2) + (3 * math.pi / 4 - 2) / sec.GJ) + P * R * math.pi / (2 * sec.GA3)
    return abs(w / exact - 1.0)


@functools.lru_cache(maxsize=None)
def bend_tip(name: str, n: int) -> tuple:
    """Tip of the 45° bend (:func:`bend_domain`), static."""
    return tuple(bend_domain(name, n).solve().position(_tip("arc", name, n))[-1])


def bend_domain(name: str, n: int):
    """The 45° bend (Bathe & Bolourchi 1979; models/curved_cantilever.toml's data as one arc of n
    elements) under the out-of-plane tip force P = 600, static in 3 load steps."""
    from reference.algorithms import SolverSettings
    from reference.domain import Domain
    from reference.interactions import Clamp, NodalLoad, Ramp

    sec = Section(EA=1e7, GA2=5e6, GA3=5e6, GJ=833333.3333333334, EI2=833333.3333333334, EI3=833333.3333333334,
                  rhoA=1.0, rhoJ1=5.0, rhoJ2=5.0, rhoJ3=5.0)
    d = Domain("bend")
    end = (100.0 * math.sin(math.pi / 4), 100.0 * (1.0 - math.cos(math.pi / 4)), 0.0)
    arc = d.add_beam("arc", (0.0, 0.0, 0.0), end, n, sec, axis2=(0.0, 0.0, 1.0), center=(0.0, 100.0, 0.0),
                     element=name)
    d.add_interaction(Clamp(arc[0]))
    d.add_interaction(NodalLoad(arc[-1], np.array([0.0, 0.0, 600.0]), time_function=Ramp()))
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=3, tolerance=1e-12)
    return d


def bend_error(name: str, n: int) -> float:
    """The 45° bend's tip change from n to 2n elements over the radius (no closed form: the difference
    of successive meshes falls at the order of the error itself)."""
    return float(np.linalg.norm(np.subtract(bend_tip(name, n), bend_tip(name, 2 * n)))) / 100.0


STUDIES = {"roll-up": rollup_error, "quarter arc": quarter_arc_error, "45° bend": bend_error,
           "large-deflection cantilever": cantilever_error, "cantilever frequency": frequency_error}
"""Convergence studies: name → error(family, n)."""


def orders(name: str, meshes=(2, 4)) -> dict:
    """Errors at each mesh and the observed order ``log2(e_n/e_2n)`` of the last pair, per study."""
    out = {}
    for study, error in STUDIES.items():
        errors = [error(name, n) for n in meshes]
        a, b = errors[-2], errors[-1]
        out[study] = {"meshes": list(meshes), "errors": errors,
                      "order": math.log(a / b) / math.log(meshes[-1] / meshes[-2]) if b > 0 and a > 0 else None}
    return out


SHORT_MESHES = (3, 6)
"""The meshes of the short suite (the tests'); the long one (``--long``) uses 4, 8, 16, 32."""


def suite(long: bool = False) -> dict:
    """Every check for every engine family."""
    meshes = (4, 8, 16, 32) if long else SHORT_MESHES
    return {name: {"element": element_checks(name), "locking": {str(k): v for k, v in locking(name).items()},
                   "orders": orders(name, meshes), "integration_points": integration_point_moments(name)}
            for name in engine_families()}


def table(results: dict) -> str:
    """The order table: per family and study the errors and the observed order (``exact`` below 1e-11)."""
    rows = ["| family | study | meshes | errors | observed order |", "|---|---|---|---|---|"]
    for name, res in results.items():
        for study, o in res["orders"].items():
            exact = max(o["errors"]) < 1e-11
            order = "exact" if exact else f"{o['order']:.2f}"
            rows.append(f"| {name} | {study} | {', '.join(map(str, o['meshes']))} | "
                        f"{', '.join(f'{e:.2e}' for e in o['errors'])} | {order} |")
    rows += ["", "| family | rigid: max S | objectivity | path | patch | tangent vs CD | locking L/h 10 … 1e4 | "
             "M at integration points |", "|---|---|---|---|---|---|---|---|"]
    for name, res in results.items():
        e = res["element"]
        rows.append(f"| {name} | {e['rigid_force']:.1e} | {e['objectivity']:.1e} | {e['path_force']:.1e} | "
                    f"{e['patch']:.1e} | {e['tangent']:.1e} | "
                    f"{', '.join(f'{v:.2e}' for v in res['locking'].values())} | {res['integration_points']:.1e} |")
    return "\n".join(rows)


def report_lines() -> list[str]:
    """The report's section: the short suite run as plain Python in a subprocess (``NUMBA_DISABLE_JIT=1``,
    a few seconds, instead of compiling every algorithm for each family's model), as the order table."""
    import os
    import subprocess

    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", PYTHONPATH=str(root))
    proc = subprocess.run([sys.executable, "-m", "flexmbs.verification.families", "--json"], env=env, cwd=root,
                          capture_output=True, text=True, timeout=600)
    head = ["## Element families", "",
            "Every engine element family runs the same checks (`flexmbs/verification/families.py`, meshes "
            f"{' and '.join(map(str, SHORT_MESHES))}; `make families` for 4 … 32): observed orders, then the "
            "one-element checks (relative numbers) and the locking study (tip error of 4 elements, L/h = 10 … 1e4).", ""]
    if proc.returncode != 0:
        return head + [f"The suite failed: {proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else proc.returncode}", ""]
    return head + table(json.loads(proc.stdout.strip().splitlines()[-1])).splitlines() + [""] + work_precision_lines(root)


def work_precision_lines(root: Path) -> list[str]:
    """The work–precision table across families of the last ``flexmbs bench`` (``out/bench/
    work_precision_families.md``, :mod:`flexmbs.bench_families`; timed compiled, so not rerun here), dated."""
    path = root / "out" / "bench" / "work_precision_families.md"
    if not path.exists():
        return ["Work–precision across families (error against degrees of freedom and solve time): `make bench` "
                "(`flexmbs/bench_families.py`); the report shows its table once `out/bench/work_precision_families.md` "
                "exists.", ""]
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(path.stat().st_mtime))
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if not ln.startswith("![")]
    return [f"From the last `flexmbs bench` ({when}, `{path.relative_to(root)}`):", "", *lines, ""]


if __name__ == "__main__":
    results = suite(long="--long" in sys.argv)
    if "--json" in sys.argv:
        print(json.dumps(results))
    else:
        print(table(results))
