"""A new element family is its physics: a toy two-node truss registered from outside the engine.

The truss (axial force ``N = EA (ℓ − L0)/L0`` along the chord, energy ``½ EA L0 ε²``) gives
its data (``pack``), its work row (:func:`reference.elements.driver.row_layout`) and three
per-element functions; the generic driver (:mod:`reference.elements.driver`) executes them.
It is registered with :func:`reference.elements.families.register` and run, compiled, in this
process, through the explicit, static, generalized-α, modes and arc-length algorithms, writing
results files, with no edit of any engine file.  Kernels compiled for its data are not written
to the on-disk cache (:func:`reference.kernel_cache.outside`): the test checks that the cache's
indexes never name it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
import pytest

from reference.elements.driver import row_layout
from reference.elements.families import ELEMENT_FAMILIES, assemble_forces, register, tangent_values
from reference.elements.formulation import ElementFormulation
from reference.parallel import node_incidence

EA, RHO_A, HALF_SPAN, HEIGHT, LOAD = 100.0, 1.0, 1.0, 0.5, 1.0
"""Truss of two bars from (±HALF_SPAN, 0, 0) to the apex (0, HEIGHT, 0) [m], axial stiffness
EA [N], mass per length ρA [kg/m], a load LOAD [N] down on the apex."""


class TrussData(NamedTuple):
    conn: np.ndarray
    index: np.ndarray
    offset: np.ndarray
    node_start: np.ndarray
    node_item: np.ndarray
    L0: np.ndarray
    EA: np.ndarray


ROW = row_layout(2, "TrussRow", forces=12, triads=8, moments=6, energy=1, axial=1)


@numba.njit(inline="always")
def element_forces(data, e, X, P, w):
    """Bar e's end forces ``∓N d/ℓ`` (no moments) and its axial force into ``w``; returns ``½ EA L0 ε²``."""
    d0, d1, d2 = X[1, 0] - X[0, 0], X[1, 1] - X[0, 1], X[1, 2] - X[0, 2]
    length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    strain = (length - data.L0[e]) / data.L0[e]
    N = data.EA[e] * strain
    s = w[ROW.forces]
    s[:] = 0.0
    for k, dk in enumerate((d0, d1, d2)):
        s[k] = -N * dk / length
        s[6 + k] = N * dk / length
    w[ROW.axial][0] = N
    return 0.5 * data.EA[e] * data.L0[e] * strain * strain


@numba.njit(inline="always")
def element_tangent(data, e, X, P, w, K):
    """Bar e's 12×12 tangent: ``±(N/ℓ (I − n nᵀ) + EA/L0 n nᵀ)`` on the translations."""
    K12 = K[:144].reshape((12, 12))
    K12[:, :] = 0.0
    d = X[1] - X[0]
    length = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    N = data.EA[e] * (length - data.L0[e]) / data.L0[e]
    for a in range(3):
        for b in range(3):
            nn = d[a] * d[b] / length**2
            k = N / length * ((1.0 if a == b else 0.0) - nn) + data.EA[e] / data.L0[e] * nn
            K12[a, b], K12[6 + a, 6 + b], K12[a, 6 + b], K12[6 + a, b] = k, k, -k, -k


@numba.njit(inline="always")
def element_resultants(w, N, M):
    """The axial force [N] (no shear, no moments)."""
    N[0], N[1], N[2] = w[ROW.axial][0], 0.0, 0.0
    M[0], M[1], M[2] = 0.0, 0.0, 0.0


class Truss(ElementFormulation):
    """Two-node axial bar (no bending, no torsion), lumped mass ρA L/2 per node."""

    family = "truss"
    n_nodes = 2
    Data = TrussData
    ROW = ROW
    element_forces = staticmethod(element_forces)
    element_tangent = staticmethod(element_tangent)
    element_resultants = staticmethod(element_resultants)

    def __init__(self, ea: float, rho_a: float):
        self.ea, self.rho_a = ea, rho_a

    def lumped_mass(self, x_nodes):
        length = float(np.linalg.norm(x_nodes[1] - x_nodes[0]))
        m = 0.5 * self.rho_a * length
        return [(m, np.eye(3) * m * length**2 / 12.0)] * 2

    def reference_state(self, x_nodes, q_nodes):
        return {"L0": float(np.linalg.norm(x_nodes[1] - x_nodes[0]))}

    def internal_forces(self, x_nodes, q_nodes, reference):
        data = TrussData(np.array([[0, 1]]), np.zeros(1, np.int64), np.zeros((1, 2, 4)), np.zeros(3, np.int64),
                         np.zeros(2, np.int64), np.array([reference["L0"]]), np.array([self.ea]))
        w = np.zeros(ROW.width)
        U = getattr(element_forces, "py_func", element_forces)(data, 0, np.asarray(x_nodes, float), None, w)
        return w[ROW.forces].copy(), U

    def critical_time_step(self, length):
        return length / math.sqrt(self.ea / self.rho_a)  # lumped bar: ω_max = 2c/L, limit 2/ω_max

    @classmethod
    def pack(cls, placed):
        conn = np.array([p.element.nodes for p in placed], dtype=np.int64).reshape(-1, 2)
        return TrussData(conn, np.array([p.index for p in placed], dtype=np.int64),
                         np.array(placed.offset, dtype=float).reshape(-1, 2, 4), *node_incidence(conn),
                         np.array([np.linalg.norm(p.x[1] - p.x[0]) for p in placed]),
                         np.array([p.element.formulation.ea for p in placed]))

    @staticmethod
    def characteristic_energy(data):
        return 0.5 * float(np.sum(data.EA * data.L0))  # a unit strain in every bar


if "truss" not in ELEMENT_FAMILIES:
    register(Truss)


def truss_domain(algorithm: str, **solver):
    """Two bars pinned at (±a, 0, 0), apex at (0, h, 0) loaded by −LOAD along y; the apex moves in x, y."""
    from reference import Domain
    from reference.algorithms import SolverSettings
    from reference.interactions import Clamp, FixedCoordinates, NodalLoad

    d = Domain("truss")
    left, right = d.add_node([-HALF_SPAN, 0, 0], label="left"), d.add_node([HALF_SPAN, 0, 0], label="right")
    apex = d.add_node([0.0, HEIGHT, 0.0], label="apex")
    for support in (left, right):
        d.add_element(Truss(EA, RHO_A), (support, apex), label=f"bar_{support.label}")
        d.add_interaction(Clamp(support))
    d.add_interaction(FixedCoordinates(apex, (2, 3, 4, 5)))
    d.add_interaction(NodalLoad(apex, np.array([0.0, -LOAD, 0.0])))
    d.solver = SolverSettings(algorithm=algorithm, **solver)
    return d


def static_apex_height() -> float:
    """The apex height y of the static equilibrium ``2 N y/ℓ = −P``, ``ℓ = √(a² + y²)``, ``N = EA (ℓ − L0)/L0``
    (brentq on the stable branch, above the limit point near 0.55 h)."""
    from scipy.optimize import brentq

    L0 = math.hypot(HALF_SPAN, HEIGHT)

    def residual(y):
        length = math.hypot(HALF_SPAN, y)
        return 2.0 * EA * (length - L0) / L0 * y / length + LOAD

    return brentq(residual, 0.6 * HEIGHT, HEIGHT)


RUNS = {"static": dict(t_end=1.0, load_steps=4),
        "staggered_central_difference": dict(dt=1e-3, t_end=1.2),
        "generalized_alpha": dict(dt=5e-3, t_end=1.2, rho_inf=1.0),
        "modes": dict(modes=2),
        "arc_length": dict(t_end=1.0, arc_length=0.1, max_points=60, max_load_factor=10.0)}
"""The algorithms the truss runs in, and their settings."""


def cached_indexes() -> dict[Path, bytes]:
    """Every index file of the engine's on-disk kernel cache and its contents."""
    from reference.kernel_cache import ROOT as CACHE

    return {path: path.read_bytes() for path in CACHE.rglob("*.nbi")}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Each algorithm of :data:`RUNS` on the truss, compiled, in this process: its results (the file's status,
    the apex's height, the bar forces, the energies, the frequencies or the path), the seconds it took, and
    the cache's index files before and after."""
    import h5py

    out, found, before = tmp_path_factory.mktemp("truss"), {}, cached_indexes()
    for algorithm, solver in RUNS.items():
        start = time.perf_counter()
        d = truss_domain(algorithm, **solver)
        path = out / f"{algorithm}.h5"
        r = d.solve(results_path=path)
        with h5py.File(path, "r") as f:
            run = {"status": str(f.attrs["status"]), "seconds": time.perf_counter() - start}
            if algorithm == "modes":
                run["frequency"] = r.data("modes/frequency")
            else:
                run["apex_y"] = r.position("apex")[:, 1]
            if algorithm == "arc_length":
                run["load_factor"] = r.data("path/load_factor")
            if algorithm in ("static", "staggered_central_difference", "generalized_alpha"):
                run["axial"] = f["elements/section_force"][-1, :, 0]
                run["energy"] = {k: f[f"energy/{k}"][()] for k in ("kinetic", "strain", "external_work")}
        found[algorithm] = run
    print({name: f"{run['seconds']:.1f} s" for name, run in found.items()})
    return found, before, cached_indexes()


def truss_load(y: float) -> float:
    """The apex load [N] (down) that holds the apex at height ``y``: ``−2 N y/ℓ``, ``ℓ = √(a² + y²)``,
    ``N = EA (ℓ − L0)/L0``."""
    L0, length = math.hypot(HALF_SPAN, HEIGHT), math.hypot(HALF_SPAN, y)
    return -2.0 * EA * (length - L0) / L0 * y / length


def test_a_registered_toy_family_runs_in_every_algorithm(runs):
    """Static: the apex height equals the closed-form equilibrium to 1e-9 of the height (Newton's
    tolerance 1e-10 × the model size), and the bar force from the results file to 1e-8 of itself.
    Explicit (dt = 1e-3, 1/110 of the critical step) and generalized-α (ρ∞ = 1, dt = 5e-3) from
    rest under the suddenly applied load: both conserve kinetic + strain energy − work to 1e-3 of
    the work done (second-order schemes, (ωh)² ≲ 1e-3), and agree on the apex height at
    t = 1.2 s within 1 % of the dynamic swing (phase error (ωh)²/12 × ωt ≈ 2e-3 rad)."""
    runs = runs[0]
    for run in runs.values():
        assert run["status"] == "completed"
    y = static_apex_height()
    assert abs(runs["static"]["apex_y"][-1] - y) <= 1e-9 * HEIGHT
    length = math.hypot(HALF_SPAN, y)
    N = EA * (length - math.hypot(HALF_SPAN, HEIGHT)) / math.hypot(HALF_SPAN, HEIGHT)
    assert np.allclose(runs["static"]["axial"], [N, N], rtol=1e-8)
    for name in ("staggered_central_difference", "generalized_alpha"):
        e = runs[name]["energy"]
        residual = e["kinetic"] + e["strain"] - e["external_work"]
        assert np.max(np.abs(residual)) <= 1e-3 * np.max(np.abs(e["external_work"])), name
    swing = HEIGHT - min(runs["staggered_central_difference"]["apex_y"])
    assert swing > 1.5 * (HEIGHT - y)  # a dynamic overshoot past the static height, as a sudden load gives
    assert abs(runs["staggered_central_difference"]["apex_y"][-1] - runs["generalized_alpha"]["apex_y"][-1]) \
        <= 1e-2 * swing


def test_the_toy_family_modes_and_arc_length(runs):
    """Modes about the unloaded truss: the apex (mass ρA L0, its two bars' halves) on the bars' axial
    stiffness, ``ω² = 2 EA/L0 (a/L0)² / (ρA L0)`` sideways and ``2 EA/L0 (h/L0)² / (ρA L0)`` vertically
    (no geometric stiffness at zero force), to 1e-9 relative (the dense eigensolver's round-off on a 2×2
    problem, far below).  Arc length: every converged point on the closed-form load–height curve within 1e-6
    of the limit load (Newton's tolerance 1e-10 of the forces), and the path goes on past the limit load
    (the load factor falls again while the apex goes on down)."""
    runs = runs[0]
    L0 = math.hypot(HALF_SPAN, HEIGHT)
    mass = RHO_A * L0
    expected = sorted(math.sqrt(2.0 * EA / L0 * (c / L0) ** 2 / mass) for c in (HALF_SPAN, HEIGHT))
    assert 2.0 * np.pi * np.asarray(runs["modes"]["frequency"]) == pytest.approx(expected, rel=1e-9)
    lam, y = np.asarray(runs["arc_length"]["load_factor"]), np.asarray(runs["arc_length"]["apex_y"])
    limit = max(truss_load(t) for t in np.linspace(0.0, HEIGHT, 20001))
    assert max(abs(lam[k] * LOAD - truss_load(y[k])) for k in range(len(lam))) <= 1e-6 * limit
    peak = int(np.argmax(lam))
    assert 0 < peak < len(lam) - 1 and lam[-1] < lam[peak] - 0.1 * limit and np.all(np.diff(y) < 0.0)


def test_the_toy_family_leaves_the_cache_clean(runs):
    """No index file of the on-disk kernel cache names the toy families' data (written or rewritten by the
    runs): a kernel compiled for a family from outside the engine stays in this process."""
    _, before, after = runs
    changed = [path for path, text in after.items() if before.get(path) != text]
    assert not [path for path in changed if b"TrussData" in after[path] or b"CableData" in after[path]]
    assert not [path for path, text in after.items() if b"test_element_families" in text]


class CableData(NamedTuple):
    conn: np.ndarray
    index: np.ndarray
    offset: np.ndarray
    node_start: np.ndarray
    node_item: np.ndarray
    L0: np.ndarray
    EA: np.ndarray


class Cable(Truss):
    """A second toy family (the truss's kernels on its own data type): a model holding both has a
    tuple of two different family types, what the compiled dispatch must resolve."""

    family = "cable"
    Data = CableData

    @classmethod
    def pack(cls, placed):
        return CableData(*Truss.pack(placed))


if "cable" not in ELEMENT_FAMILIES:
    register(Cable)


def test_the_compiled_dispatch_reaches_both_families():
    """The compiled calls over a tuple of two families (truss and cable) give the numbers of the
    plain-Python loop over the same tuple, bit for bit (forces, energy, tangent values)."""
    from reference.state import element_work

    d = truss_domain("static", t_end=1.0, load_steps=1)
    top = d.add_node([0.0, 2.0 * HEIGHT, 0.3], label="top")
    d.add_element(Cable(EA, RHO_A), (d.node("apex"), top), label="cable")
    model = d.initialization()
    # the engine's Beam2 family is carried empty (one compiled type for every model); the two toys follow
    assert [type(data).__name__ for data in model.elements] == ["Beam2Data", "TrussData", "CableData"]
    assert model.elements[0].conn.shape[0] == 0
    toys = model.elements[1:]
    rng = np.random.default_rng(7)
    x = np.array([n.position for n in d.nodes]) + 1e-3 * rng.standard_normal((len(d.nodes), 3))
    q = np.array([n.rotation for n in d.nodes])
    psi = 1e-2 * rng.standard_normal((len(d.nodes), 3))
    size = 3 * 144

    @numba.njit(cache=False)
    def compiled(elements, works, x, q, S, psi, values, Jr, K):
        U = assemble_forces(elements, works, x, q, S)
        return U, tangent_values(elements, works, x, q, psi, 1.0, values, 0, Jr, K)

    out = []
    for run in (compiled, compiled.py_func):
        S, values = np.zeros((len(d.nodes), 6)), np.zeros(size)
        U, p = run(toys, element_work(model)[1:], x, q, S, psi, values, np.zeros(9), np.zeros(144))
        out.append((U, p, S, values))
    assert out[0][1] == out[1][1] == size
    assert out[0][0] == out[1][0] and np.array_equal(out[0][2], out[1][2]) and np.array_equal(out[0][3], out[1][3])
    assert np.abs(out[0][3]).max() > 0.0 and out[0][0] > 0.0
    assert np.abs(out[0][2][d.node("top").id]).max() > 0.0  # the cable's force reached its node


