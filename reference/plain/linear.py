"""Modes and linear buckling on the reference path.

The analyses of :mod:`reference.algorithms.linear` (their configurations, eigenproblems, datasets and
messages, stated there once) with the linearisation taken from :class:`reference.plain.model.Evaluation`:
:mod:`reference.algorithms.linearization` and :mod:`reference.algorithms.linear` read the Newton system through
:class:`reference.plain.newton.EngineFace`, the static path is :class:`reference.plain.static.PlainStatic`,
and the eigenproblems are SciPy's (:mod:`reference.modal`), as on the compiled path.  Modes about a steady
rotation (``about = "rotation"``) search the relative equilibrium with
:func:`reference.algorithms.linearization.at_steady_rotation` over the same face: it calls two small compiled kernels
(the rotation update ``compose`` and ``rotation_matrix`` of :mod:`reference.algorithms.linearization`), the only
compiled code of this module.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components

from reference.algorithms import linearization
from reference.algorithms.linear import Buckling, LinearRun, Modes
from reference.generated import rotation_maps as rm
from reference.linalg import RANK_TOLERANCE
from reference.modal import modes
from reference.plain.newton import EngineFace, Newton
from reference.plain.static import PlainStatic
from reference.rotation import skew
from reference.status import OK
from reference.validation import ModelWarning
from reference.plain.vectorise import plain

_rotation_matrix = plain(rm.rotation_matrix)


def _plain_path(algo):
    """``algo`` with its static path (if any) on the reference path (a twin made from the compiled algorithm's
    settings, :func:`reference.plain.backend.twin`, carries the compiled path until it starts)."""
    if algo.path is not None and not isinstance(algo.path, PlainStatic):
        algo.path = PlainStatic(algo.path.dt, algo.path.tolerance, algo.path.max_iterations)
    return algo


def _start(algo, model, state) -> LinearRun:
    """:meth:`reference.algorithms.linear.LinearAnalysis.start` on the reference path."""
    _plain_path(algo)
    problem = algo.refusal(model)
    if problem:
        raise ValueError(problem)
    if algo.path is not None:
        path = algo.path.start(model, state)
        return LinearRun(path.system, path)
    return LinearRun(EngineFace(Newton(model)), None)


def mobility(model, lin, tol: float = RANK_TOLERANCE) -> int:
    """:func:`reference.algorithms.linearization.mobility` (the rigid-body and mechanism motions the joints and fixed
    coordinates allow, Grübler–Kutzbach on the actual Jacobian) with the rotation matrices of the generated
    ``rotation_matrix`` run on NumPy."""
    N = lin.dof.shape[0]
    edges = [data.conn[:, [a, b]] for data in model.elements for a in range(data.conn.shape[1])
             for b in range(a + 1, data.conn.shape[1])]
    edges = np.concatenate(edges) if edges else np.zeros((0, 2), dtype=np.int64)
    graph = sps.csr_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(N, N))
    n_bodies, body = connected_components(graph, directed=False)
    A = np.empty((9, N))
    _rotation_matrix(lin.q.T, A)
    A = A.T.reshape(N, 3, 3)
    R = np.zeros((N, 6, 6 * n_bodies))
    for b in range(n_bodies):
        nodes = np.flatnonzero(body == b)
        c = lin.x[nodes].mean(axis=0)
        for i in nodes:
            R[i, :3, 6 * b:6 * b + 3] = np.eye(3)
            R[i, :3, 6 * b + 3:6 * b + 6] = -skew(lin.x[i] - c)
            R[i, 3:, 6 * b + 3:6 * b + 6] = A[i].T
    free = lin.dof >= 0
    Rf = np.zeros((lin.n_free, 6 * n_bodies))
    Rf[lin.dof[free]] = R[free]
    C = np.vstack([lin.B @ Rf, R[~free]])
    if C.shape[0] == 0:
        return 6 * n_bodies
    s = sla.svdvals(C)
    rank = int(np.sum(s > tol * s[0])) if s[0] > 0.0 else 0
    return 6 * n_bodies - rank


class PlainModes(Modes):
    """:class:`reference.algorithms.linear.Modes` on the reference path (about the reference state or a
    static equilibrium)."""

    @classmethod
    def from_settings(cls, settings, dt=None):
        return _plain_path(super().from_settings(settings, dt))

    def start(self, model, state, critical_step=None, guard=None) -> LinearRun:
        return _start(self, model, state)

    def analyse(self, model, state, run) -> dict:
        """:meth:`reference.algorithms.linear.Modes.analyse` with :func:`mobility`."""
        if run.spinning is not None:
            lin = run.spinning
        else:
            lin = linearization.linearize(model, state.x, state.q, state.v, state.w, self.multipliers(run), state.t,
                                          state.angle, run.system)
        red = linearization.reduce(lin)
        size = red.M.shape[0]
        if self.n_modes > size:
            raise ValueError(f"{self.n_modes} modes asked of a model with {size} independent coordinates "
                             f"({lin.n_free} free less {red.rank} independent constraints); ask at most {size}")
        movable = mobility(model, lin)
        found = modes(red.M, red.D, red.K, min(self.n_modes + movable, size))
        zero = int(np.sum(found.kind == "zero"))
        if zero > movable:
            warnings.warn(f"{zero} zero modes, but the joints and fixed coordinates allow only {movable} rigid-body "
                          "or mechanism motions: some direction has no stiffness (an unsupported node, a zero "
                          "stiffness)", ModelWarning, stacklevel=2)
        k = self.n_modes
        shapes = lin.nodal((red.Z @ found.phi[:, :k]).T)
        out = {"modes/frequency": found.frequency[:k], "modes/damping_ratio": found.damping_ratio[:k],
               "modes/omega_squared": found.omega2[:k], "modes/root": np.stack([found.s.real, found.s.imag], 1)[:k],
               "modes/kind": found.kind[:k].astype(str), "modes/shape": shapes.real,
               "modes/zero_modes": np.int64(zero), "modes/mobility": np.int64(movable),
               "modes/constraint_rank": np.int64(red.rank), "modes/coordinates": np.int64(size),
               "modes/time": np.float64(state.t)}
        if self.spin is not None:
            out["modes/spin_rate"] = np.float64(self.spin[0])
        if found.damped:
            out["modes/shape_imaginary"] = shapes.imag
        return out


class PlainBuckling(Buckling):
    """:class:`reference.algorithms.linear.Buckling` on the reference path."""

    @classmethod
    def from_settings(cls, settings, dt=None):
        return _plain_path(super().from_settings(settings, dt))

    def start(self, model, state, critical_step=None, guard=None) -> LinearRun:
        return _start(self, model, state)

    def unloaded(self, model, run) -> linearization.Linearization:
        """:meth:`reference.algorithms.linear.Buckling.unloaded` with :class:`PlainStatic`."""
        loads = model.loads._replace(vec=np.zeros_like(model.loads.vec))
        actuators = model.force_elements._replace(tf=np.full_like(model.force_elements.tf, -1))
        bare = model._replace(loads=loads, gravity=np.zeros_like(model.gravity), force_elements=actuators)
        static = PlainStatic(self.path.dt, self.path.tolerance, self.path.max_iterations)
        state = run.unloaded.copy()
        path = static.start(bare, state)
        code = static.advance(bare, state, path, 0, None)
        if code != OK:
            raise ValueError("the equilibrium without the loads (the reference of constant loads) was not found: "
                             + static.failure(code, state, path)[1])
        return linearization.linearize(bare, state.x, state.q, None, None, path.lam, state.t, state.angle, path.system)
