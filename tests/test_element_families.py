"""A new element family is a new class: a toy two-node truss registered from outside the engine.

The truss (axial force ``N = EA (ℓ − L0)/L0`` along the chord, energy ``½ EA L0 ε²``)
is defined here, registered with :func:`reference.elements.families.register`, and run
through the explicit, static and generalized-α algorithms, writing results files —
with no edit of the Domain, the algorithms, the solution loop or the results writer.

Where it runs.  A compiled engine kernel called with the toy's data type would store
that type in numba's on-disk cache index, which other processes (that cannot import
this test module) then fail to unpickle.  So the three runs happen in a subprocess
with ``NUMBA_DISABLE_JIT=1`` (the engine as plain Python), and the compiled dispatch
over a tuple of two families (Beam2 and the truss) is checked in-process by a kernel
compiled here without a disk cache.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
import pytest

from reference.elements.families import ELEMENT_FAMILIES, assemble_forces, register, tangent_values
from reference.elements.formulation import ElementFormulation
from reference.newton_blocks import store_block

ROOT = Path(__file__).resolve().parents[1]
EA, RHO_A, HALF_SPAN, HEIGHT, LOAD = 100.0, 1.0, 1.0, 0.5, 1.0
"""Truss of two bars from (±HALF_SPAN, 0, 0) to the apex (0, HEIGHT, 0) [m], axial stiffness
EA [N], mass per length ρA [kg/m], a load LOAD [N] down on the apex."""


class TrussData(NamedTuple):
    conn: np.ndarray
    index: np.ndarray
    L0: np.ndarray
    EA: np.ndarray


@numba.njit(inline="always")
def _assemble(data, work, x, q, S):
    U = 0.0
    for e in range(data.conn.shape[0]):
        i, j = data.conn[e, 0], data.conn[e, 1]
        d0, d1, d2 = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
        length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        strain = (length - data.L0[e]) / data.L0[e]
        N = data.EA[e] * strain
        U += 0.5 * data.EA[e] * data.L0[e] * strain * strain
        for k, dk in enumerate((d0, d1, d2)):
            S[i, k] -= N * dk / length
            S[j, k] += N * dk / length
    return U


@numba.njit(inline="always")
def _tangent_values(data, work, x, q, psi, ck, values, p, Jr, K):
    K12 = K[:144].reshape((12, 12))
    for e in range(data.conn.shape[0]):
        i, j = data.conn[e, 0], data.conn[e, 1]
        K12[:, :] = 0.0
        d = x[j] - x[i]
        length = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        N = data.EA[e] * (length - data.L0[e]) / data.L0[e]
        for a in range(3):
            for b in range(3):
                nn = d[a] * d[b] / length**2
                k = N / length * ((1.0 if a == b else 0.0) - nn) + data.EA[e] / data.L0[e] * nn
                K12[a, b], K12[6 + a, 6 + b], K12[a, 6 + b], K12[6 + a, b] = k, k, -k, -k
        p = store_block(K12, data.conn[e], 2, psi, Jr, ck, values, p)
    return p


@numba.njit(inline="always")
def _resultants(data, work, x, q, N, M):
    for e in range(data.conn.shape[0]):
        i, j = data.conn[e, 0], data.conn[e, 1]
        length = math.sqrt((x[j, 0] - x[i, 0]) ** 2 + (x[j, 1] - x[i, 1]) ** 2 + (x[j, 2] - x[i, 2]) ** 2)
        N[data.index[e], 0] = data.EA[e] * (length - data.L0[e]) / data.L0[e]
    return 0.0


class Truss(ElementFormulation):
    """Two-node axial bar (no bending, no torsion), lumped mass ρA L/2 per node."""

    family = "truss"
    n_nodes = 2
    Data = TrussData
    assemble = staticmethod(_assemble)
    tangent_values = staticmethod(_tangent_values)
    resultants = staticmethod(_resultants)

    def __init__(self, ea: float, rho_a: float):
        self.ea, self.rho_a = ea, rho_a

    def lumped_mass(self, x_nodes):
        length = float(np.linalg.norm(x_nodes[1] - x_nodes[0]))
        m = 0.5 * self.rho_a * length
        return [(m, np.eye(3) * m * length**2 / 12.0)] * 2

    def reference_state(self, x_nodes, q_nodes):
        return {"L0": float(np.linalg.norm(x_nodes[1] - x_nodes[0]))}

    def internal_forces(self, x_nodes, q_nodes, reference):
        S = np.zeros((2, 6))
        data = TrussData(np.array([[0, 1]]), np.zeros(1, np.int64), np.array([reference["L0"]]), np.array([self.ea]))
        U = getattr(_assemble, "py_func", _assemble)(data, None, np.asarray(x_nodes, float), q_nodes, S)
        return S.reshape(-1), U

    def critical_time_step(self, length):
        return length / math.sqrt(self.ea / self.rho_a)  # lumped bar: ω_max = 2c/L, limit 2/ω_max

    @classmethod
    def pack(cls, placed):
        return TrussData(np.array([p.element.nodes for p in placed], dtype=np.int64).reshape(-1, 2),
                         np.array([p.index for p in placed], dtype=np.int64),
                         np.array([np.linalg.norm(p.x[1] - p.x[0]) for p in placed]),
                         np.array([p.element.formulation.ea for p in placed]))

    @staticmethod
    def work(data):
        return np.zeros(1)

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


def run_all(out: Path) -> dict:
    """The three algorithms on the truss (call with the engine uncompiled, see the module docstring)."""
    import h5py

    found = {}
    runs = {"static": dict(t_end=1.0, load_steps=4),
            "staggered_central_difference": dict(dt=1e-3, t_end=1.2),
            "generalized_alpha": dict(dt=5e-3, t_end=1.2, rho_inf=1.0)}
    for algorithm, solver in runs.items():
        d = truss_domain(algorithm, **solver)
        path = out / f"{algorithm}.h5"
        r = d.solve(results_path=path)
        with h5py.File(path, "r") as f:
            found[algorithm] = {"status": str(f.attrs["status"]), "apex_y": r.position("apex")[:, 1].tolist(),
                                "axial": f["elements/section_force"][-1, :, 0].tolist(),
                                "energy": {k: f[f"energy/{k}"][()].tolist() for k in ("kinetic", "strain",
                                                                                     "external_work")}}
    return found


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("truss")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", PYTHONPATH=os.pathsep.join([str(ROOT), str(ROOT / "tests")]))
    proc = subprocess.run([sys.executable, __file__, str(out)], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_registered_toy_family_runs_in_every_algorithm(runs):
    """Static: the apex height equals the closed-form equilibrium to 1e-9 of the height (Newton's
    tolerance 1e-10 × the model size), and the bar force from the results file to 1e-8 of itself.
    Explicit (dt = 1e-3, 1/110 of the critical step) and generalized-α (ρ∞ = 1, dt = 5e-3) from
    rest under the suddenly applied load: both conserve kinetic + strain energy − work to 1e-3 of
    the work done (second-order schemes, (ωh)² ≲ 1e-3), and agree on the apex height at
    t = 1.2 s within 1 % of the dynamic swing (phase error (ωh)²/12 × ωt ≈ 2e-3 rad)."""
    for run in runs.values():
        assert run["status"] == "completed"
    y = static_apex_height()
    assert abs(runs["static"]["apex_y"][-1] - y) <= 1e-9 * HEIGHT
    length = math.hypot(HALF_SPAN, y)
    N = EA * (length - math.hypot(HALF_SPAN, HEIGHT)) / math.hypot(HALF_SPAN, HEIGHT)
    assert np.allclose(runs["static"]["axial"], [N, N], rtol=1e-8)
    for name in ("staggered_central_difference", "generalized_alpha"):
        e = {k: np.array(v) for k, v in runs[name]["energy"].items()}
        residual = e["kinetic"] + e["strain"] - e["external_work"]
        assert np.max(np.abs(residual)) <= 1e-3 * np.max(np.abs(e["external_work"])), name
    swing = HEIGHT - min(runs["staggered_central_difference"]["apex_y"])
    assert swing > 1.5 * (HEIGHT - y)  # a dynamic overshoot past the static height, as a sudden load gives
    assert abs(runs["staggered_central_difference"]["apex_y"][-1] - runs["generalized_alpha"]["apex_y"][-1]) \
        <= 1e-2 * swing


class CableData(NamedTuple):
    conn: np.ndarray
    index: np.ndarray
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
    plain-Python loop over the same tuple, bit for bit (forces, energy, tangent values).  (Beam2's
    compiled path is every other test's; a model of it and a toy family compiles for ~25 s.)"""
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


if __name__ == "__main__":
    print(json.dumps(run_all(Path(sys.argv[1]))))
