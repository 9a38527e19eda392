"""The parallel explicit step, residual and tangent: bit for bit the same on 1, 2 and 3 threads.

The model has :data:`reference.parallel.PARALLEL_NODES` + 1 nodes, so every parallel loop is taken (the
kick, the chunked sums, the drift, the force reset, the element loop and the gather; the residual's node
loop, the tangent's node and element blocks).  Thread counts above ``NUMBA_NUM_THREADS`` (set to at
least 3 by ``conftest.py``) would be capped: the test says which counts it ran.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from reference.algorithms.implicit import NewtonSystem
from reference.algorithms.staggered import advance
from reference.domain import SolverSettings
from reference.interactions import Gravity, NodalLoad
from reference.jit import use_threads
from reference.monitor import energy_floor
from reference.parallel import CHUNK, PARALLEL_NODES, gather, node_incidence, scatter
from reference.state import Record

from tests.conftest import cantilever
from tests.test_beam2 import SECTION

THREADS = (1, 2, 3)


@pytest.fixture(scope="module")
def large():
    """A clamped rod of PARALLEL_NODES elements, gravity, a follower end force and a dead end moment,
    mass-proportional damping: every node loop of the step is a parallel one (and its sums span
    several chunks)."""
    d, nodes = cantilever(PARALLEL_NODES, SECTION)
    d.add_interaction(Gravity())
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.3, 1.0]), follower=True))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.2, 0.5, 0.0]), moment=True))
    d.solver = SolverSettings(dt=1.0, t_end=1.0, damping=5.0)
    model = d.initialization()
    assert model.nodes.mass.shape[0] > max(PARALLEL_NODES, 2 * CHUNK)
    return d, model


def _threads(n):
    got = use_threads(n)
    assert got == numba.get_num_threads()
    return got


def test_explicit_steps_are_bit_identical_for_any_thread_count(large):
    """Six steps (records at steps 0 and 3) with the energy guard on: state, records and the guard's
    sums are the same bits on every thread count."""
    d, model = large
    h = 0.5 * d.critical_time_step()
    runs, counts = [], []
    for n in THREADS:
        counts.append(_threads(n))
        state = d.initial_conditions()
        run = d.algorithm(dt=h).start(model, state, d.critical_time_step(), energy_floor(model, state.x))
        recs = [Record.empty(state.x.shape[0]) for _ in range(2)]
        for rec in recs:
            model_arg, state_arg, rec_arg, scratch_arg = run.arguments(model, state, rec)
            assert advance(model_arg, state_arg, h, 3, True, rec_arg, scratch_arg) == 0
        runs.append([*state, *recs[0], *recs[1], run.scratch.guard.copy()])
    use_threads(1)
    assert runs[0][0][-1, 2] != d.nodes[-1].position[2] and runs[0][-1][0]["energy"] > 0.0  # it moved; the guard ran
    for n, other in zip(counts[1:], runs[1:]):
        assert all(np.array_equal(a, b) for a, b in zip(runs[0], other)), f"{n} threads differ from one"
    assert max(counts) >= 2, f"ran on {counts} threads only"


def test_residual_and_tangent_are_bit_identical_for_any_thread_count(large):
    """One dynamic residual and one Newton matrix (mass, damping, gyroscopic, load and element blocks,
    the rotation columns times J_r(ψ)) at a perturbed configuration: the same bits on every thread count."""
    d, model = large
    system = NewtonSystem(model)
    rng = np.random.default_rng(25)
    N = model.nodes.mass.shape[0]
    x = np.array([n.position for n in d.nodes]) + 1e-3 * rng.standard_normal((N, 3))
    q = np.array([n.rotation for n in d.nodes]) + 1e-3 * rng.standard_normal((N, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    v, w, psi = (1e-2 * rng.standard_normal((N, 3)) for _ in range(3))
    vd = rng.standard_normal((N, 6))
    out = []
    for n in THREADS:
        _threads(n)
        U = system.evaluate(x, q, v, w, vd, np.zeros(0), 0.3, True)
        system.matrix(x, q, w, 0.3, np.zeros(0), 1.0, 0.7, 2.0, psi=psi)
        out.append((U, system.work.r.copy(), system.work.values.copy()))
    use_threads(1)
    assert out[0][0] > 0.0 and np.abs(out[0][2]).max() > 0.0
    for U, r, values in out[1:]:
        assert U == out[0][0] and np.array_equal(r, out[0][1]) and np.array_equal(values, out[0][2])


def test_gather_adds_what_the_serial_scatter_adds_bit_for_bit():
    """The per-node gather (CSR incidence, ascending element order) of a three-node family's rows, nodes
    shared by up to three elements, equals the element-by-element scatter exactly (random rows: a
    different order of the additions would change the last bits)."""
    rng = np.random.default_rng(7)
    E = 40
    conn = np.stack([2 * np.arange(E), 2 * np.arange(E) + 2, rng.integers(0, 2 * E + 1, E)], axis=1)
    W = rng.standard_normal((E, 63))
    start, item = node_incidence(conn)
    S_scatter = rng.standard_normal((2 * E + 1, 6))
    S_gather = S_scatter.copy()
    scatter(conn, W, 54, S_scatter)
    gather(start, item, 3, W, 54, S_gather)
    assert np.array_equal(S_gather, S_scatter)
