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
the whole model is linearised in the frame spinning with it (:func:`at_steady_rotation`: the centrifugally
stretched relative equilibrium, the Coriolis and centrifugal terms added to D and K).

Entry points: :func:`linearize` (a configuration), :func:`at_reference` (a Domain's initial state),
:func:`at_static_equilibrium` (the static algorithm's equilibrium at ``t_end``), :func:`at_state` (a
:class:`~reference.state.State`, with multipliers consistent with its accelerations), :func:`at_results`
(one output of a results file), :func:`at_steady_rotation` (the whole model spinning at a constant rate);
:func:`lowest_modes` the modes about a state.  The ``modes`` and
``buckling`` algorithms (:mod:`reference.algorithms.linear`) linearise about the same configurations.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from reference.algorithms.implicit import NewtonSystem, compose
from reference.generated import rotation_maps as rm
from reference.linalg import RANK_TOLERANCE, SingularMatrix, null_space
from reference.scalar import scalar_twin
from reference.state import Model, State, new_clock

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
    state = State(x.copy(), q.copy(), v, w, np.zeros((N, 6)), new_clock(float(results.time[k])),
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


def at_steady_rotation(model: Model, state: State, spin_rate: float, spin_axis, spin_point=(0.0, 0.0, 0.0),
                       system: NewtonSystem | None = None, tolerance: float = 1e-10, max_iterations: int = 25,
                       max_halvings: int = 8) -> Linearization:
    """The linearisation in the frame spinning with the whole model at the rate Ω about a fixed axis
    (docs/formulation.md §11, "Steady rotation").

    The supports, the joints to the ground and the model turn with the frame: the motion
    ``x(t) = p + R(t)(x₀ − p)``, ``Λ(t) = R(t)Λ₀`` (``R = exp(Ωt ẽ)``), with ``v = Ω̃(x₀ − p)``,
    ``ω = Λ₀ᵀΩe`` (body frame), ``v̇ = Ω̃²(x₀ − p)``, ``ω̇ = 0``, is a relative equilibrium when the
    residual vanishes there.  ``(x₀, Λ₀, λ)`` is found by Newton from ``state`` (the reference) on the
    tangent ``K + D W + M A₀`` of that residual, with Ω² ramped in halved steps when a step fails.  The
    perturbations ``x = p + R(x₀ − p + u)``, ``Λ = RΛ₀ exp(θ̃)`` give ``δV = δ̇ + W δ`` and
    ``δV̇ = δ̈ + A₁ δ̇ + A₀ δ`` with, per node, ``W = (Ω̃, ω̃₀)``, ``A₁ = (2Ω̃, ω̃₀)``, ``A₀ = (Ω̃², 0)``;
    the returned M, D, K are ``M``, ``D + M A₁``, ``K + D W + M A₀`` (co-rotating, constant in time),
    B unchanged; ``v``, ``w`` are the spin velocities and ``lam`` the multipliers of the relative
    equilibrium.  Fixed coordinates stay fixed in the spinning frame.

    Parameters
    ----------
    spin_rate : float
        Ω [rad/s].
    spin_axis : array (3,)
        The axis e (inertial; normalised here).
    spin_point : array (3,)
        A point p of the axis [m].
    tolerance, max_iterations, max_halvings
        Newton stops when the largest correction is below ``tolerance`` × model size (translations) and
        ``tolerance`` rad (rotations); a ramp step that fails in ``max_iterations`` is halved up to
        ``max_halvings`` times.

    Raises ValueError when Newton fails (centrifugal loads beyond what the model carries, a mechanism
    without a relative equilibrium; a singular tangent: a body that nothing holds) or the axis is zero.
    """
    e = np.asarray(spin_axis, dtype=float)
    if not (e.shape == (3,) and np.linalg.norm(e) > 0.0):
        raise ValueError(f"spin_axis must be a nonzero 3-vector, got {spin_axis!r}")
    e = e / np.linalg.norm(e)
    p = np.asarray(spin_point, dtype=float)
    system = system or NewtonSystem(model)
    system.work.angle[:] = state.angle
    x, q, lam = state.x.copy(), state.q.copy(), np.zeros(model.n_constraints)
    span = max(float(np.max(np.ptp(x, axis=0))) if x.shape[0] > 1 else 0.0, 1e-3)
    level, step, cuts = 0.0, 1.0, 0  # the ramp in Ω² / spin_rate²
    while level < 1.0:
        trial = min(1.0, level + step)
        rate = float(spin_rate) * np.sqrt(trial)
        try:
            solved, singular = _relative_equilibrium(model, system, (x, q, lam), rate * e, p, state.t, tolerance,
                                                     max_iterations, span), False
        except SingularMatrix:
            solved, singular = None, True
        if solved is None:
            cuts += 1
            if cuts > max_halvings and singular:
                raise ValueError(_singular_spin(model, system, x, q, state, rate))
            if cuts > max_halvings:
                raise ValueError(f"no steady rotation found at the spin rate {rate:.6g} rad/s (Newton did not "
                                 f"converge in {max_iterations} iterations after {max_halvings} halvings of the "
                                 "ramp): the centrifugal loads exceed what the model carries, or a mechanism has "
                                 "no relative equilibrium; lower spin_rate")
            step *= 0.5
            continue
        (x, q, lam), level = solved, trial
    return _spinning(model, system, x, q, lam, float(spin_rate) * e, p, state.t)


def _singular_spin(model, system, x, q, state, rate: float) -> str:
    """The diagnosis of a steady-rotation search stopped by an exactly singular tangent: the rigid-body
    and mechanism motions that nothing holds (:func:`mobility`), or else a direction without stiffness."""
    movable = mobility(model, linearize(model, x, q, None, None, None, state.t, system.work.angle.copy(), system))
    cause = (f"the model has {movable} rigid-body or mechanism motion{'s' if movable != 1 else ''} that no clamp, "
             "support or joint to the ground holds (a free body has no steady rotation about a fixed axis)"
             if movable else "some direction has no stiffness (an unsupported node, a zero stiffness)")
    return (f"no steady rotation found at the spin rate {rate:.6g} rad/s: the tangent stiffness of the spinning "
            f"model is singular: {cause}; hold every body with a clamp, a support or a joint to the ground, or "
            "use about = \"reference\"")


def _spin_velocities(x, q, Omega, p):
    """Per node ``v = Ω × (x − p)``, ``ω = Λᵀ Ω`` (body frame), and ``V̇ = (Ω × v, 0)``."""
    v = np.cross(Omega, x - p)
    w = np.empty_like(v)
    A, rotation_matrix = np.zeros(9), scalar_twin(rm.rotation_matrix)  # Python: nothing to compile
    for i in range(x.shape[0]):
        rotation_matrix(q[i], A)
        w[i] = A.reshape(3, 3).T @ Omega
    vd = np.zeros((x.shape[0], 6))
    vd[:, :3] = np.cross(Omega, v)
    return v, w, vd


def _spin_maps(dof: np.ndarray, Omega, w) -> tuple:
    """``W``, ``A₁``, ``A₀`` of :func:`at_steady_rotation` on the free coordinates (sparse; a fixed
    coordinate has no increment in the spinning frame)."""
    n = int(np.sum(dof >= 0))
    Ot = _skew(Omega)
    out = []
    for translation, rotation in ((Ot, True), (2.0 * Ot, True), (Ot @ Ot, False)):
        rows, cols, vals = [], [], []
        for i in range(dof.shape[0]):
            for offset, block in ((0, translation), (3, _skew(w[i]) if rotation else None)):
                if block is None:
                    continue
                index = dof[i, offset:offset + 3]
                a, b = np.nonzero((index[:, None] >= 0) & (index[None, :] >= 0) & (block != 0.0))
                rows.append(index[a])
                cols.append(index[b])
                vals.append(block[a, b])
        out.append(sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)))
    return tuple(out)


def _spinning(model, system, x, q, lam, Omega, p, t) -> Linearization:
    """The co-rotating linearisation at ``(x, q, λ)`` spinning at Ω about p (:func:`at_steady_rotation`)."""
    v, w, _ = _spin_velocities(x, q, Omega, p)
    lin = linearize(model, x, q, v, w, lam, t, system.work.angle.copy(), system)
    W, A1, A0 = _spin_maps(lin.dof, Omega, w)
    return replace(lin, D=_clean(lin.D + lin.M @ A1), K=_clean(lin.K + lin.D @ W + lin.M @ A0))


def _force_scale(model, work, vd, w) -> float:
    """The size of the forces of a spinning state: the largest inertial, gyroscopic, internal or external
    force or moment (for the residual test of :func:`_relative_equilibrium`)."""
    Jw = np.einsum("nab,nb->na", model.nodes.inertia, w)
    parts = (model.nodes.mass[:, None] * vd[:, :3], np.cross(w, Jw), work.S, work.F)
    return max(max(float(np.max(np.abs(a), initial=0.0)) for a in parts), 1e-300)


def _relative_equilibrium(model, system, start, Omega, p, t, tolerance, max_iterations, span):
    """Newton on the residual of the spinning state from ``start`` ``(x, q, λ)`` (left as it is): its tangent is
    the co-rotating K (:func:`at_steady_rotation`).  The converged ``(x, q, λ)``, or None; raises
    :class:`reference.linalg.SingularMatrix` when the tangent is exactly singular (SciPy's
    ``MatrixRankWarning``, whose answer would be NaN)."""
    x, q, lam = (a.copy() for a in start)
    free, n, eps = system.free, system.n_free, model.joints.eps
    for _ in range(max_iterations):
        lin = _spinning(model, system, x, q, lam, Omega, p, t)
        v, w, vd = _spin_velocities(x, q, Omega, p)
        system.evaluate(x, q, v, w, vd, lam, t, True)
        rhs = -np.concatenate([system.work.r[free], system.work.PHI - eps * lam])
        if np.max(np.abs(rhs), initial=0.0) <= tolerance * _force_scale(model, system.work, vd, w):
            return x, q, lam  # already balanced (e.g. a body spinning about a principal axis: a singular K)
        A = sps.bmat([[lin.K, lin.B.T], [lin.B, sps.diags(-eps)]], format="csc") if lam.size else lin.K.tocsc()
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("error", spla.MatrixRankWarning)
            try:
                sol = spla.spsolve(A, rhs)
            except spla.MatrixRankWarning as exc:
                raise SingularMatrix(str(exc)) from None
            except RuntimeError:
                return None
        if not np.all(np.isfinite(sol)):
            return None
        delta = np.zeros((x.shape[0], 6))
        delta[free] = sol[:n]
        x += delta[:, :3]
        q_new = np.empty_like(q)
        scalar_twin(compose)(q, np.ascontiguousarray(delta[:, 3:]), q_new, np.empty(4))  # Python: no compilation
        q, lam = q_new, lam + sol[n:]
        if max(np.max(np.abs(delta[:, :3]), initial=0.0) / span, np.max(np.abs(delta[:, 3:]), initial=0.0)) <= tolerance:
            return x, q, lam
    return None


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
    A, rotation_matrix = np.zeros(9), scalar_twin(rm.rotation_matrix)  # Python: nothing to compile
    for b in range(n_bodies):
        nodes = np.flatnonzero(body == b)
        c = x[nodes].mean(axis=0)
        for i in nodes:
            rotation_matrix(lin.q[i], A)
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
