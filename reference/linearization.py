"""Linearisation of the constrained equations of motion about a configuration (docs/formulation.md §11).

About a configuration ``(x, q, v, w, λ, t)`` the residual of the implicit algorithms
(:mod:`reference.algorithms.implicit`), ``r = M V̇ + (gyroscopic, damping) + S − F + Bᵀλ``,
``Φ − ελ = 0``, changes under the increments ``δ = (δx inertial, δθ body frame)`` of every free node
coordinate (``x ← x + δx``, ``q ← q ⊗ exp(δθ)``) and of the velocities as::

    δr = M δV̇ + D δV + K δ + Bᵀ δλ,        B δ = 0

with ``M`` the lumped mass, ``D = ∂r/∂V`` (mass-proportional damping, the gyroscopic tangent
``ω̃J − (Jω)~``, the force elements' dampers), ``K = ∂r/∂δ`` at fixed V and λ (element material +
geometric stiffness, the joints' ``∂(Bᵀλ)/∂δ``, the follower-load tangents, the force elements'
stiffness) and ``B`` the constraint Jacobian.  They are the blocks of the Newton matrix
(:meth:`reference.algorithms.implicit.NewtonSystem.matrix`) taken with the coefficients
``(c_m, c_c, c_k) = (1, 0, 0), (0, 1, 0), (0, 0, 1)``: no derivation here that the Newton solver
does not already use (and that ``tests/test_tangents.py`` does not check).

The increments are reduced to independent ones by a null-space basis Z of B (``B Z = 0``,
:func:`null_space`): ``δ = Z η``, ``M_r = Zᵀ M Z``, ``D_r``, ``K_r`` likewise.  A steady rotation of
the whole model would enter here as the map from the increments to a frame spinning with the model
(Coriolis and centrifugal terms added to D and K); it is not implemented.

Entry points: :func:`linearize` (a configuration), :func:`at_reference` (a Domain's initial state),
:func:`at_static_equilibrium` (the static algorithm's equilibrium at ``t_end``), :func:`at_state` (a
:class:`~reference.state.State`, with multipliers consistent with its accelerations), :func:`at_results`
(one output of a results file); :func:`lowest_modes` the modes about a state.  The ``modes`` and
``buckling`` algorithms (:mod:`reference.algorithms.linear`) linearise about the same configurations.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components

from reference.algorithms.implicit import NewtonSystem
from reference.generated import rotation_maps as rm
from reference.linalg import RANK_TOLERANCE, null_space
from reference.state import Model, State

CONSISTENCY_STEP = 1e-6
"""Step [s] of the central difference of ``B V + Φ_t`` along the motion, for the multipliers consistent
with a moving state (:func:`at_state`); exact for a state at rest without drives."""


@dataclass
class Linearization:
    """The linearised equations about one configuration, on the free node coordinates.

    Attributes
    ----------
    M, D, K : scipy.sparse.csr_matrix (n, n)
        Mass, damping + gyroscopic (``∂r/∂V``) and stiffness (``∂r/∂δ``) on the n free coordinates,
        in the order of ``dof``.  Units: kg and kg m² (M), per second (D), per metre or radian (K).
    B : scipy.sparse.csr_matrix (m, n)
        Constraint Jacobian (velocity form, ``Φ̇ = B V + Φ_t``).
    dof : ndarray (N, 6)
        Index of each node coordinate among the free ones, −1 where fixed.
    x, q, v, w, lam : ndarray
        The configuration (positions, Euler parameters, velocities, body-frame angular velocities,
        multipliers); ``t`` its time (load factor for a static state); ``F`` (N, 6) the external
        generalised forces there (for the load direction of a stability event).
    """

    M: sps.csr_matrix
    D: sps.csr_matrix
    K: sps.csr_matrix
    B: sps.csr_matrix
    dof: np.ndarray
    x: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w: np.ndarray
    lam: np.ndarray
    t: float
    F: np.ndarray

    @property
    def n_free(self) -> int:
        return int(self.M.shape[0])

    def nodal(self, vectors: np.ndarray) -> np.ndarray:
        """Vectors on the free coordinates (k, n) → per node (k, N, 6), zero on fixed coordinates."""
        vectors = np.atleast_2d(vectors)
        out = np.zeros((vectors.shape[0],) + self.dof.shape, dtype=vectors.dtype)
        free = self.dof >= 0
        out[:, free] = vectors[:, self.dof[free]]
        return out


@dataclass
class Reduced:
    """The linearisation on independent coordinates η (``δ = Z η``, ``B Z = 0``).

    ``Z`` (n, n − rank B) sparse; ``M``, ``D``, ``K`` the reduced matrices (sparse); ``rank`` of B."""

    Z: sps.csr_matrix
    M: sps.csr_matrix
    D: sps.csr_matrix
    K: sps.csr_matrix
    rank: int


def linearize(model: Model, x, q, v=None, w=None, lam=None, t: float = 0.0, angle=None,
              system: NewtonSystem | None = None) -> Linearization:
    """M, D, K and B at the configuration ``(x, q, v, w, λ, t)`` (velocities zero and λ = 0 by default).

    ``angle`` (F,) the rotational force elements' continuous angles (zero by default); ``system`` a
    :class:`~reference.algorithms.implicit.NewtonSystem` of the model to reuse.
    """
    system = system or NewtonSystem(model)
    N, m = x.shape[0], model.n_constraints
    v = np.zeros((N, 3)) if v is None else np.asarray(v, dtype=float)
    w = np.zeros((N, 3)) if w is None else np.asarray(w, dtype=float)
    lam = np.zeros(m) if lam is None else np.asarray(lam, dtype=float)
    x, q = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(q, dtype=float)
    system.work.angle[:] = 0.0 if angle is None else angle
    # the forces and the joints' rows at the configuration; the force elements' blocks read its velocities
    system.evaluate(x, q, v, w, np.zeros((N, 6)), lam, t, True)
    F = system.work.F.copy()
    n = system.n_free
    blocks = []
    for coefficients in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        A = system.matrix(x, q, w, t, lam, *coefficients, ce=0.0).tocsr()
        blocks.append(A[:n, :n])
    B = A[n:, :n]
    return Linearization(*(_clean(b) for b in blocks), _clean(B), system.dof, x.copy(), q.copy(), v.copy(),
                         w.copy(), lam.copy(), float(t), F)


def _clean(matrix) -> sps.csr_matrix:
    matrix = sps.csr_matrix(matrix)
    matrix.eliminate_zeros()
    return matrix


def at_state(model: Model, state: State, system: NewtonSystem | None = None) -> Linearization:
    """The linearisation about ``state`` (at ``state.t``), with the multipliers consistent with its
    accelerations (``M V̇ + Bᵀλ = −r``, ``B V̇ = −d/dt(B V + Φ_t)``; at rest: the equilibrium multipliers
    if the state is an equilibrium, the least-M⁻¹-norm balance of the forces if not).

    Raises :class:`reference.linalg.SingularMatrix` when ``[M Bᵀ; B −ε]`` is singular (redundant,
    unregularised joints).
    """
    system = system or NewtonSystem(model)
    system.work.angle[:] = state.angle
    _, lam = system.consistent_accelerations(state.x, state.q, state.v, state.w, state.t, CONSISTENCY_STEP, ce=1.0)
    return linearize(model, state.x, state.q, state.v, state.w, lam, state.t, state.angle, system)


def at_results(model: Model, results, t: float, system: NewtonSystem | None = None) -> Linearization:
    """The linearisation about the output of ``results`` (:class:`reference.io.results.Results`, e.g.
    :func:`reference.io.results.load_results`) nearest to time ``t``: its positions, rotations,
    velocities and multipliers (consistent ones, :func:`at_state`, when the file has none)."""
    k = int(np.argmin(np.abs(np.asarray(results.time) - t)))
    N = len(results.labels)
    x = np.asarray(results.positions[k], dtype=float)
    q = np.asarray(results.rotations[k], dtype=float)
    v = np.nan_to_num(np.asarray(results.velocities[k], dtype=float))
    w = np.nan_to_num(np.asarray(results.angular_velocities[k], dtype=float))
    lam = np.asarray(results.multipliers, dtype=float)
    state = State(x.copy(), q.copy(), v, w, np.zeros((N, 6)), np.array([float(results.time[k]), 0.0, 0.0, 0.0]),
                  np.zeros(model.force_elements.kind.shape[0]))
    if lam.shape[1:] == (model.n_constraints,) and np.all(np.isfinite(lam[k])):
        return linearize(model, x, q, v, w, lam[k], state.t, state.angle, system)
    return at_state(model, state, system)


def at_reference(domain) -> Linearization:
    """The linearisation of a :class:`~reference.domain.Domain` about its initial state (t = 0, its initial
    velocities, consistent multipliers): what ``algorithm = "modes"``, ``about = "reference"`` uses."""
    return at_state(domain.initialization(), domain.initial_conditions())


def at_static_equilibrium(domain, t_end: float | None = None, load_steps: int | None = None) -> Linearization:
    """The linearisation about the static equilibrium of ``domain``'s loads at ``t_end`` (default: its
    solver's), reached by :class:`~reference.algorithms.static.Static` in ``load_steps`` (default: its
    solver's) from t = 0, with the multipliers of that equilibrium.  Raises ValueError with the static
    algorithm's message when it fails."""
    from reference.algorithms.static import Static
    from reference.status import OK

    settings = replace(domain.solver, algorithm="static", t_end=float(t_end or domain.solver.t_end),
                       load_steps=int(load_steps or domain.solver.load_steps))
    algo = Static.from_settings(settings)
    model, state = domain.initialization(), domain.initial_conditions()
    run = algo.start(model, state)
    code = algo.advance(model, state, run, algo.n_steps(settings.t_end), None)
    if code != OK:
        raise ValueError(algo.failure(code, state, run)[1])
    return linearize(model, state.x, state.q, None, None, run.lam, state.t, state.angle, run.system)


def reduce(lin: Linearization, tol: float = RANK_TOLERANCE) -> Reduced:
    """``Zᵀ M Z``, ``Zᵀ D Z``, ``Zᵀ K Z`` with Z from :func:`null_space` of ``lin.B``."""
    Z, rank = null_space(lin.B, tol)
    Zt = Z.T.tocsr()
    return Reduced(Z, *(_clean(Zt @ A @ Z) for A in (lin.M, lin.D, lin.K)), rank)


def mobility(model: Model, lin: Linearization, tol: float = RANK_TOLERANCE) -> int:
    """The number of rigid-body and mechanism motions the joints and fixed coordinates allow
    (Grübler–Kutzbach on the actual Jacobian; e.g. Nikravesh 1988, §2.5).

    A *body* is a set of nodes joined by elements (one flexible body) or a node without elements
    (a rigid body); its rigid motions are ``δx_n = τ + θ × (x_n − c)``, ``δθ_n = A_nᵀ θ`` (θ
    inertial).  The mobility is ``6 × bodies − rank [B R; E R]``, R those motions on the coordinates, E
    the fixed coordinates: the dimension of the motions that strain no element.  Where nothing stiffens
    or softens them (no pre-stress, no gravity on a pendulum), each is a zero mode.
    """
    N = lin.dof.shape[0]
    x = lin.x
    edges = [data.conn[:, [a, b]] for data in model.elements for a in range(data.conn.shape[1])
             for b in range(a + 1, data.conn.shape[1])]
    edges = np.concatenate(edges) if edges else np.zeros((0, 2), dtype=np.int64)
    graph = sps.csr_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(N, N))
    n_bodies, body = connected_components(graph, directed=False)
    R = np.zeros((N, 6, 6 * n_bodies))
    A = np.zeros(9)
    for b in range(n_bodies):
        nodes = np.flatnonzero(body == b)
        c = x[nodes].mean(axis=0)
        for i in nodes:
            rm.rotation_matrix(lin.q[i], A)
            R[i, :3, 6 * b:6 * b + 3] = np.eye(3)
            R[i, :3, 6 * b + 3:6 * b + 6] = -_skew(x[i] - c)
            R[i, 3:, 6 * b + 3:6 * b + 6] = A.reshape(3, 3).T
    free = lin.dof >= 0
    Rf = np.zeros((lin.n_free, 6 * n_bodies))
    Rf[lin.dof[free]] = R[free]
    C = np.vstack([lin.B @ Rf, R[~free]])
    if C.shape[0] == 0:
        return 6 * n_bodies
    s = sla.svdvals(C)
    rank = int(np.sum(s > tol * s[0])) if s[0] > 0.0 else 0
    return 6 * n_bodies - rank


def _skew(a) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def lowest_modes(model: Model, state: State, n: int = 20):
    """The ``n`` lowest modes of ``model`` about ``state`` (:func:`at_state`, :func:`reduce`,
    :func:`reference.modal.modes`): ``(frequencies [Hz], ModeSet, Linearization, Reduced)``, shapes on the
    nodes by ``lin.nodal((red.Z @ modes.phi).T)``.  What ``flexmbs bench`` times."""
    from reference.modal import modes

    lin = at_state(model, state)
    red = reduce(lin)
    found = modes(red.M, red.D, red.K, n)
    return found.frequency, found, lin, red
