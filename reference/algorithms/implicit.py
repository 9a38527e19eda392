"""What the implicit algorithms share: the residual, its tangent, the Newton system.

Unknowns.  Node n carries six coordinates: a displacement increment ``δx``
(inertial) and a rotation increment ``δθ`` in its body frame, applied as
``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (the left-trivialised update of
SO(3)×R³; Brüls, Cardona & Arnold 2012, §2).  Fixed coordinates are not
unknowns.  The constraints add one multiplier per row.

Residual (per node, the paper's eq. (5) written as ``M a + Bᵀλ = Q``)::

    r_u = m v̇ + c m v + S_u − F_u + (Bᵀλ)_u
    r_θ = J ω̇ + ω × J ω + c J ω + S_θ − F_θ + (Bᵀλ)_θ      (body frame)
    Φ(x, q, t) − ε λ = 0

with ``S`` the Beam2 internal forces (generated kernel), ``F`` the external
forces (:func:`reference.algorithms.staggered.external_forces`), B the joint
Jacobian (:func:`reference.joints.assembly.joint_rows`) and ε the joint's
regularisation (``ε λ = Φ``, the explicit scheme's meaning).  The Static
algorithm uses ``v = v̇ = 0``.

Newton matrix with coefficients ``(c_m, c_c, c_k)`` (static: 0, 0, 1;
generalized-α: 1, γ'/β', 1/β')::

    [ c_m M + c_c C + c_k K    Bᵀ  ] [δ]      [c_k r]
    [ B                      −ε/c_k] [μ]  = − [Φ − ελ]      λ ← λ + μ / c_k

``C = ∂r/∂V`` (damping, the gyroscopic tangent and the force elements' dampers),
``K = ∂r/∂δ`` at fixed velocities: the Beam2 tangent stiffness (material +
geometric), the joints' λ-weighted constraint Hessian ``∂(Bᵀλ)/∂δ``, the
follower-load tangents and the force elements' stiffness — all sympy-derived
kernels (``reference/generated/tangents.py``, ``reference/joints/hessian.py``,
``reference/generated/forces.py`` through :func:`reference.forces.force_element_tangent`;
docs/tangents.md), exact derivatives under the update above, so that Newton
converges quadratically.

Force elements (``[[springs]]``, :mod:`reference.forces`) enter like internal
forces: their spring and damper forces are subtracted from ``S`` and their
energy added to the strain energy, their actuator forces added to ``F``
(external work); the static algorithm evaluates them at zero velocity.  The
continuous angles of rotational springs live in the work arrays during a run
(copied from and back to ``State.angle`` by the algorithms); every evaluation
continues them from the last one, as the explicit scheme does.

Values are written by :func:`tangent_values` block by block in the order that
:func:`newton_pattern` lays out once per model (:class:`reference.linalg.BlockPattern`).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from reference.algorithms.staggered import external_forces
from reference.forces import force_element_forces, force_element_tangent
from reference.elements.formulation import (
    beam2_assemble, beam2_assemble_parallel, is_identity, section_quaternion, tangent_to_node_frame,
)
from reference.generated import rotation_maps as rm
from reference.generated import tangents as generated_tangents
from reference.interactions import tf_value
from reference.jit import inlined, kernel
from reference.joints.assembly import joint_rows
from reference.joints.hessian import joint_rows_hessian
from reference.joints.sparse import jacobian_row_columns
from reference.algorithms.base import Algorithm
from reference.linalg import BlockPattern, SingularMatrix, SparseLU, lu_solve


class Work:
    """Work arrays of the implicit algorithms for one model (allocated once)."""

    def __init__(self, model):
        N, m, E, J = model.mass.shape[0], model.n_constraints, model.conn.shape[0], model.jt_i.shape[0]
        self.S = np.zeros((N, 6))
        self.F = np.zeros((N, 6))
        self.r = np.zeros((N, 6))
        self.PHI = np.zeros(m)
        self.PHIt = np.zeros(m)
        self.Bl = np.zeros((m, 12))
        self.s_el = np.zeros(40)
        self.W = np.zeros((E, 40))  # one row per Beam2 element (beam2_assemble_parallel)
        self.A = np.zeros(9)
        self.jphi, self.jB, self.jphit = np.zeros(6), np.zeros((6, 12)), np.zeros(6)
        self.prim_phi, self.prim_B = np.zeros(10), np.zeros(120)
        self.small = np.zeros((8, 12))
        self.K12 = np.zeros((12, 12))
        nF = model.fe_kind.shape[0]
        self.values = np.zeros(36 * N + 144 * E + 144 * J + 24 * m + m + 144 * nF)
        # force elements: their spring/damper forces G, continuous angles, work arrays of
        # reference.forces, the damping matrix, the velocities of the last evaluation (zero for a
        # static one; the tangent is taken there) and [damper power] of the last evaluation
        self.G = np.zeros((N, 6))
        self.angle = np.zeros(nF)
        self.fe_e, self.fe_B, self.fe_G = np.zeros(6), np.zeros(72), np.zeros(864)
        self.C12 = np.zeros((12, 12))
        self.fe_v, self.fe_w = np.zeros((N, 3)), np.zeros((N, 3))
        self.fe_out = np.zeros(1)


PARALLEL_ELEMENTS = 8
"""From this many Beam2 elements on, :func:`evaluate` computes them with the parallel element loop
(:func:`~reference.elements.formulation.beam2_assemble_parallel`, no per-view reference counts)
instead of the serial one (no parallel launch): measured 1.6 against 2.1 µs at 4 elements,
3.2 against 2.7 µs at 12; both give the same numbers."""



@kernel
def evaluate(model, x, q, v, w, vd, lam, t, dynamic, w_):
    """Residual ``r`` (N,6), constraint rows ``Φ, Φ_t, B`` (local (m,12)) at time t; returns U.

    ``w_`` is a tuple of work arrays (S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi,
    prim_B, fe, W) with ``fe`` those of the force elements and ``W`` (E, 40) the Beam2 elements'
    rows of the parallel element loop (:func:`work_tuple`, :data:`PARALLEL_ELEMENTS`).  With ``dynamic``
    false the inertia, gyroscopic and damping terms are left out and the force elements see
    zero velocities.  U includes the springs' energy; the dampers' power ``Σ c (B_e V)²`` [W]
    goes to ``fe_out[0]``.
    """
    S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi, prim_B, fe, W = w_
    G, angle, fe_e, fe_B, fe_G, C12, fv, fw, fe_out = fe
    if model.conn.shape[0] >= PARALLEL_ELEMENTS:
        U = beam2_assemble_parallel(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff,
                                    S, W)
    else:
        U = beam2_assemble(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff, S, s_el)
    external_forces(model, x, q, t, F, A)
    N = x.shape[0]
    if model.fe_kind.shape[0] > 0:
        # springs and dampers like internal forces (S −= G), actuators into F
        for i in range(N):
            for k in range(3):
                fv[i, k] = v[i, k] if dynamic else 0.0
                fw[i, k] = w[i, k] if dynamic else 0.0
            for k in range(6):
                G[i, k] = 0.0
        U_fe, D_fe = force_element_forces(model, x, q, fv, fw, t, angle, G, F, fe_e, fe_B)
        U += U_fe
        fe_out[0] = D_fe
        for i in range(N):
            for k in range(6):
                S[i, k] -= G[i, k]
    # the model's arrays are taken out once: each access of a Model field in a loop costs two
    # atomic reference-count updates
    c = model.damping
    mass, J = model.mass, model.inertia
    jt_i, jt_j, jt_neq, jt_row0, jt_tf = model.jt_i, model.jt_j, model.jt_neq, model.jt_row0, model.jt_tf
    jt_par, jt_rows, jt_drive, tf_kind, tf_par = model.jt_par, model.jt_rows, model.jt_drive, model.tf_kind, model.tf_par
    for i in range(N):
        for k in range(6):
            r[i, k] = S[i, k] - F[i, k]
        if dynamic:
            m = mass[i]
            for k in range(3):
                r[i, k] += m * (vd[i, k] + c * v[i, k])
            jw0 = J[i, 0, 0] * w[i, 0] + J[i, 0, 1] * w[i, 1] + J[i, 0, 2] * w[i, 2]
            jw1 = J[i, 1, 0] * w[i, 0] + J[i, 1, 1] * w[i, 1] + J[i, 1, 2] * w[i, 2]
            jw2 = J[i, 2, 0] * w[i, 0] + J[i, 2, 1] * w[i, 1] + J[i, 2, 2] * w[i, 2]
            r[i, 3] += w[i, 1] * jw2 - w[i, 2] * jw1 + c * jw0
            r[i, 4] += w[i, 2] * jw0 - w[i, 0] * jw2 + c * jw1
            r[i, 5] += w[i, 0] * jw1 - w[i, 1] * jw0 + c * jw2
            for a in range(3):
                r[i, 3 + a] += J[i, a, 0] * vd[i, 3] + J[i, a, 1] * vd[i, 4] + J[i, a, 2] * vd[i, 5]
    for k in range(jt_i.shape[0]):
        neq = jt_neq[k]
        r0 = jt_row0[k]
        i, j = jt_i[k], jt_j[k]
        tf = jt_tf[k]
        joint_rows(x, q, i, j, jt_par[k], jt_rows[k], jt_drive[k], tf_kind[tf], tf_par[tf], t, jphi[:neq], jB[:neq],
                    jphit[:neq], prim_phi, prim_B)
        for rr in range(neq):
            PHI[r0 + rr] = jphi[rr]
            PHIt[r0 + rr] = jphit[rr]
            for cc in range(12):
                Bl[r0 + rr, cc] = jB[rr, cc]
            for cc in range(6):
                r[i, cc] += jB[rr, cc] * lam[r0 + rr]
                if j >= 0:
                    r[j, cc] += jB[rr, 6 + cc] * lam[r0 + rr]
    return U


@kernel
def load_tangent(model, q, t, i, K6, T9):
    """Add ``−∂F/∂δ`` of the configuration-dependent loads on node i into the 6×6 block ``K6``:
    follower forces (generated ``follower_force_tangent``) and dead moments (``dead_moment_tangent``)."""
    for l in range(model.load_node.shape[0]):
        if model.load_node[l] != i:
            continue
        code = model.load_code[l]
        if code != 1 and code != 2:
            continue
        tf = model.load_tf[l]
        f = tf_value(model.tf_kind[tf], model.tf_par[tf], t)
        if code == 1:
            generated_tangents.follower_force_tangent(q[i], model.load_vec[l], T9)
            r0 = 0
        else:
            generated_tangents.dead_moment_tangent(q[i], model.load_vec[l], T9)
            r0 = 3
        for a in range(3):
            for b in range(3):
                K6[r0 + a, 3 + b] -= f * T9[3 * a + b]


_load_tangent = inlined(load_tangent)


@kernel
def tangent_values(model, x, q, w, psi, t, lam, cm, cc, ck, ce, values, w_, small, K12):
    """Block values of the Newton matrix (order of :func:`newton_pattern`) into ``values``.

    ``c_e`` multiplies the −ε diagonal (``1/c_k`` in Newton); with ``c_k = 0`` the
    stiffness blocks are zero and not computed (the mass matrix of the initial accelerations).
    ``psi`` (N,3): when the unknown rotation δ enters as ``q = q_n ⊗ exp(ψ + δ)`` (generalized-α),
    the configuration-dependent blocks are multiplied on the right by the tangent operator
    ``J_r(ψ)`` of each node (``exp(ψ + δ) = exp(ψ) exp(J_r(ψ) δ) + O(δ²)``); zeros for the
    static update ``q ⊗ exp(δ)``.  The force elements' blocks ``c_k K T + c_c C`` come last, at
    the velocities and angles of the last :func:`evaluate` (K with the actuator forces' tangent).
    """
    Jr = small[7, :9]
    J9 = small[6, :9]
    wts = small[5, :10]
    K144 = K12.reshape(144)
    N = x.shape[0]
    E = model.conn.shape[0]
    NJ = model.jt_i.shape[0]
    m = lam.shape[0]
    S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi, prim_B, fe, W = w_
    G, angle, fe_e, fe_B, fe_G, C12, fv, fw, fe_out = fe
    c = model.damping
    p = 0
    for i in range(N):
        blk = K12[:6, :6]
        for a in range(6):
            for b in range(6):
                blk[a, b] = 0.0
        _load_tangent(model, q, t, i, blk, A)
        J = model.inertia
        for a in range(6):
            for b in range(6):
                blk[a, b] *= ck
        _times_right_jacobian(blk, 3, psi[i], Jr)
        for a in range(3):
            blk[a, a] += model.mass[i] * (cm + cc * c)
        for a in range(3):
            for b in range(3):
                blk[3 + a, 3 + b] += (cm + cc * c) * J[i, a, b]
        if cc != 0.0:
            for a in range(3):
                for b in range(3):
                    J9[3 * a + b] = J[i, a, b]
            generated_tangents.gyroscopic_tangent(J9, w[i], A)
            for a in range(3):
                for b in range(3):
                    blk[3 + a, 3 + b] += cc * A[3 * a + b]
        for a in range(6):
            for b in range(6):
                values[p] = blk[a, b]
                p += 1
    for e in range(E):
        i, j = model.conn[e, 0], model.conn[e, 1]
        if ck != 0.0 and is_identity(model.offset[e, 0]) and is_identity(model.offset[e, 1]):
            # section frames are the node frames (straight beams): p_a = q_a and T = I exactly
            generated_tangents.beam2_tangent(x[i], x[j], q[i], q[j], model.L0[e], model.psi0[e], model.gamma0[e],
                                             model.stiff[e], s_el[:12], K144)
        elif ck != 0.0:
            # the element works in its section frames p_a = q_a ⊗ o_a; its tangent goes back to the nodes'
            p1, p2 = s_el[24:28], s_el[28:32]
            section_quaternion(q[i], model.offset[e, 0], p1)
            section_quaternion(q[j], model.offset[e, 1], p2)
            generated_tangents.beam2_tangent(x[i], x[j], p1, p2, model.L0[e], model.psi0[e], model.gamma0[e],
                                             model.stiff[e], s_el[:12], K144)
            tangent_to_node_frame(model.offset[e, 0], model.offset[e, 1], K12, s_el[32:35], s_el[35:38])
        else:
            K12[:, :] = 0.0
        _times_right_jacobian(K12, 3, psi[i], Jr)
        _times_right_jacobian(K12, 9, psi[j], Jr)
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b]
                p += 1
    for k in range(NJ):
        if ck != 0.0:
            neq = model.jt_neq[k]
            r0 = model.jt_row0[k]
            tf = model.jt_tf[k]
            joint_rows_hessian(x, q, model.jt_i[k], model.jt_j[k], model.jt_par[k], model.jt_rows[k],
                               model.jt_drive[k], model.tf_kind[tf], model.tf_par[tf], t, lam[r0:r0 + neq],
                               jphi[:neq], jB[:neq], jphit[:neq], K12, prim_phi, prim_B, wts)
        else:
            K12[:, :] = 0.0
        _times_right_jacobian(K12, 3, psi[model.jt_i[k]], Jr)
        if model.jt_j[k] >= 0:
            _times_right_jacobian(K12, 9, psi[model.jt_j[k]], Jr)
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b]
                p += 1
    Bs = small[5:7, :]
    for k in range(NJ):
        for rr in range(model.jt_row0[k], model.jt_row0[k] + model.jt_neq[k]):
            for b in range(12):
                Bs[0, b] = Bl[rr, b]
            _times_right_jacobian(Bs[:1], 3, psi[model.jt_i[k]], Jr)
            if model.jt_j[k] >= 0:
                _times_right_jacobian(Bs[:1], 9, psi[model.jt_j[k]], Jr)
            for b in range(12):
                values[p] = Bs[0, b]
                p += 1
    for rr in range(m):
        for b in range(12):
            values[p] = Bl[rr, b]
            p += 1
    for rr in range(m):
        values[p] = -model.row_eps[rr] * ce
        p += 1
    for k in range(model.fe_kind.shape[0]):
        force_element_tangent(model, x, q, fv, fw, angle, k, K12, C12, fe_e, fe_B, fe_G)
        tf = model.fe_tf[k]
        if tf >= 0:
            # a point-to-point actuator force f_a(t) (an external load −B_ℓᵀ f_a turning with the line):
            # its tangent f_a G_ℓ, G_ℓ the tangent of the length's Jacobian row that
            # force_element_tangent leaves in the first 144 entries of its work array
            fa = tf_value(model.tf_kind[tf], model.tf_par[tf], t)
            nc = 12 if model.fe_j[k] >= 0 else 6
            for a in range(nc):
                for b in range(nc):
                    K12[a, b] += fa * fe_G[12 * a + b]
        _times_right_jacobian(K12, 3, psi[model.fe_i[k]], Jr)
        if model.fe_j[k] >= 0:
            _times_right_jacobian(K12, 9, psi[model.fe_j[k]], Jr)
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b] + cc * C12[a, b]
                p += 1
    return p


@kernel
def _right_jacobian_columns(K, c0, psi, Jr):
    """``K[:, c0:c0+3] ← K[:, c0:c0+3] J_r(ψ)`` (skipped for ψ = 0)."""
    if psi[0] == 0.0 and psi[1] == 0.0 and psi[2] == 0.0:
        return
    rm.right_jacobian(psi, Jr)
    for a in range(K.shape[0]):
        k0, k1, k2 = K[a, c0], K[a, c0 + 1], K[a, c0 + 2]
        for b in range(3):
            K[a, c0 + b] = k0 * Jr[b] + k1 * Jr[3 + b] + k2 * Jr[6 + b]


_times_right_jacobian = inlined(_right_jacobian_columns)


def work_tuple(w: Work):
    fe = (w.G, w.angle, w.fe_e, w.fe_B, w.fe_G, w.C12, w.fe_v, w.fe_w, w.fe_out)
    return (w.S, w.F, w.r, w.PHI, w.PHIt, w.Bl, w.s_el, w.A, w.jphi, w.jB, w.jphit, w.prim_phi, w.prim_B, fe, w.W)


def newton_pattern(model) -> tuple[BlockPattern, np.ndarray]:
    """The block pattern of the Newton matrix and the unknown index of every node coordinate.

    Returns the :class:`~reference.linalg.BlockPattern` and ``dof`` (N,6): the
    unknown of each coordinate, −1 if fixed; the multipliers follow the free coordinates.
    """
    N, m = model.mass.shape[0], model.n_constraints
    free = model.free.reshape(-1) > 0.5
    dof = np.full(6 * N, -1, dtype=np.int64)
    dof[free] = np.arange(int(free.sum()))
    n_free = int(free.sum())
    dof6 = dof.reshape(N, 6)
    rows, cols = [], []

    def block(nodes_r, nodes_c):
        idx_r = np.concatenate([dof6[n] if n >= 0 else np.full(6, -1) for n in nodes_r])
        idx_c = np.concatenate([dof6[n] if n >= 0 else np.full(6, -1) for n in nodes_c])
        rows.append(np.repeat(idx_r, idx_c.size))
        cols.append(np.tile(idx_c, idx_r.size))

    for i in range(N):
        block([i], [i])
    for e in range(model.conn.shape[0]):
        block(list(model.conn[e]), list(model.conn[e]))
    for k in range(model.jt_i.shape[0]):
        nodes = [model.jt_i[k], model.jt_j[k]]
        block(nodes, nodes)
    row_dofs = jacobian_row_columns(model.jt_i, model.jt_j, model.jt_neq, dof6)
    for rr, idx in enumerate(row_dofs):
        rows.append(np.full(12, n_free + rr))
        cols.append(idx)
    for rr, idx in enumerate(row_dofs):
        rows.append(idx)
        cols.append(np.full(12, n_free + rr))
    rows.append(n_free + np.arange(m))
    cols.append(n_free + np.arange(m))
    for k in range(model.fe_kind.shape[0]):
        nodes = [model.fe_i[k], model.fe_j[k]]
        block(nodes, nodes)
    rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    cols = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
    return BlockPattern(rows, cols, n_free + m), dof6


OK, DIVERGED, SINGULAR, NO_CONVERGENCE = 0, 1, 2, 3
"""Status codes of the implicit algorithms' ``advance`` (OK, DIVERGED and SINGULAR as in the explicit scheme)."""


HISTORY_STEPS = 100
"""Newton residual histories kept (:attr:`ImplicitAlgorithm.history`, the last load steps'): a
static run of many steps keeps a bounded ~20 kB, not ~200 B a step."""


class ImplicitAlgorithm(Algorithm):
    """Base of the Newton-based algorithms: settings, the Newton system, records, failure messages.

    Subclasses provide ``name``, ``defaults`` (their deck keys) and
    ``advance(model, state, n_steps, record, scratch) → status``; they call
    :meth:`prepare` once per model and :meth:`solve_newton_system` per iteration.

    Parameters
    ----------
    dt : float
        Step [s] (or load-factor increment for the static algorithm).
    tolerance : float
        Newton stops when the largest correction is below ``tolerance`` times
        the model size (translations) or ``tolerance`` rad (rotations).
    max_iterations : int
        Newton iterations per step before the step counts as failed.
    """

    explicit = False

    def __init__(self, dt: float, tolerance: float, max_iterations: int):
        if not dt > 0.0:
            raise ValueError(f"step must be positive, got {dt!r}")
        self.dt = float(dt)
        self.tolerance = float(tolerance)
        self.max_iterations = int(max_iterations)
        self._model = None
        self.history: deque[list[float]] = deque(maxlen=HISTORY_STEPS)
        self.stopped_at: float | None = None

    @staticmethod
    def refusal(model) -> str | None:
        """Why this algorithm cannot run ``model`` (None if it can)."""
        if model.ms_master.shape[0] > 0:
            return ("master/slave joints are not available with the implicit algorithms; use "
                    "formulation = \"jacobian\" (Lagrange multipliers) for those joints")
        return None

    def prepare(self, model) -> None:
        """Symbolic work once per model: pattern, work arrays, length scale."""
        if self._model is model:
            return
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        self._model = model
        self.pattern, self.dof = newton_pattern(model)
        self.free = self.dof >= 0
        self.n_free = int(self.free.sum())
        self.work = Work(model)
        self.wt = work_tuple(self.work)
        self.zero_psi = np.zeros((model.mass.shape[0], 3))
        self.slu = SparseLU(self.pattern.n)

    def length_scale(self, x: np.ndarray) -> float:
        span = float(np.max(np.ptp(x, axis=0))) if x.shape[0] > 1 else 0.0
        return max(span, 1e-3)

    def evaluate(self, model, x, q, v, w, vd, lam, t, dynamic) -> float:
        return evaluate(model, x, q, v, w, vd, lam, t, dynamic, self.wt)

    def residual_norm(self, ck: float, lam) -> float:
        """‖[c_k r; Φ − ελ]‖ of the last :meth:`evaluate` (free coordinates only)."""
        model = self._model
        r = self.work.r[self.free]
        phi = self.work.PHI - model.row_eps * lam
        return float(math.sqrt(ck * ck * r @ r + phi @ phi))

    def factor(self, model, x, q, w, t, lam, cm, cc, ck, ce=None, psi=None):
        """Assemble and factor the Newton matrix at ``(x, q, ω, t, λ)``; returns the factor arrays
        (:class:`reference.linalg.SparseLU`: SuperLU once, compiled refactorisations after).

        Raises :class:`reference.linalg.SingularMatrix` when the matrix is singular.
        """
        wk = self.work
        ce = 1.0 / ck if ce is None else ce
        psi = self.zero_psi if psi is None else psi
        tangent_values(model, x, q, w, psi, t, lam, cm, cc, ck, ce, wk.values, self.wt, wk.small, wk.K12)
        return self.slu.factor(self.pattern.matrix(wk.values))

    def solve(self, lu, rhs_nodes: np.ndarray, rhs_rows: np.ndarray):
        """Solve with the factor arrays ``lu``: node part (N,6) and constraint part (m,) → (δ (N,6), μ (m,))."""
        rhs = np.empty(self.pattern.n)
        rhs[: self.n_free] = rhs_nodes[self.free]
        rhs[self.n_free:] = rhs_rows
        sol = np.empty_like(rhs)
        lu_solve(lu, rhs, self.slu.work, sol)
        if not np.all(np.isfinite(sol)):
            raise SingularMatrix("non-finite Newton correction")
        delta = np.zeros_like(rhs_nodes)
        delta[self.free] = sol[: self.n_free]
        return delta, sol[self.n_free:]

    def newton_correction(self, lu, model, ck, lam):
        """Correction from the last :meth:`evaluate`: right-hand side ``−[c_k r; Φ − ελ]``."""
        return self.solve(lu, -ck * self.work.r, -(self.work.PHI - model.row_eps * lam))

    def correction_size(self, delta: np.ndarray, L: float) -> float:
        """Largest correction: translations over the model size L, rotations in rad."""
        return max(float(np.max(np.abs(delta[:, :3]), initial=0.0)) / L, float(np.max(np.abs(delta[:, 3:]), initial=0.0)))

    def converged(self, delta: np.ndarray, L: float) -> bool:
        return self.correction_size(delta, L) <= self.tolerance

    def write_record(self, rec, model, x, q, v, w, U, energy_clock, lam) -> None:
        """Fill ``rec`` as the explicit scheme does (uses the last :meth:`evaluate` for Φ and B)."""
        write_record(model, x, q, v, w, U, energy_clock, lam, self.work.PHI, self.work.PHIt, self.work.Bl, rec)

    def constraint_rate(self, model, v, w) -> np.ndarray:
        """``B V`` (m,) from the last evaluation's local rows."""
        Bl = self.work.Bl
        out = np.zeros(Bl.shape[0])
        V = np.concatenate([v, w], axis=1)
        for k in range(model.jt_i.shape[0]):
            r0, neq = int(model.jt_row0[k]), int(model.jt_neq[k])
            i, j = int(model.jt_i[k]), int(model.jt_j[k])
            out[r0:r0 + neq] = Bl[r0:r0 + neq, :6] @ V[i]
            if j >= 0:
                out[r0:r0 + neq] += Bl[r0:r0 + neq, 6:] @ V[j]
        return out

    def failure(self, code: int, t_last: float, domain) -> tuple[str, str]:
        """``(status, message)`` for a failed ``advance`` after the record at ``t_last``."""
        t = self.stopped_at if self.stopped_at is not None else t_last
        where = f"{self.progress_name} {t:.6g}"
        if code == SINGULAR:
            return (f"singular tangent at {where}",
                    f"the Newton matrix became singular at {where} (a mechanism with an unconstrained "
                    "motion, redundant or degenerate joints, or a buckling point); results up to there are kept. "
                    "Constrain the free motion, regularise the joints (epsilon > 0) or stop before the limit point.")
        if code == NO_CONVERGENCE:
            return (f"Newton did not converge at {where}",
                    f"Newton did not converge beyond {where} within {self.max_iterations} iterations"
                    f"{' ' + self.cut_note if self.cut_note else ''}; results up to there are kept. "
                    f"{self.no_convergence_fix}")
        return (f"diverged after {where}",
                f"the solution became non-finite after {where}; results up to there are kept. Check the loads.")

    progress_name = "t ="
    cut_note = ""
    no_convergence_fix = "Reduce the step or raise max_iterations."


_exp_quaternion = inlined(rm.exp_quaternion)
_quat_product = inlined(rm.quat_product)


@kernel
def compose(q0, psi, out, tmp):
    """``out[n] = q0[n] ⊗ exp(ψ[n])`` for every node (normalised)."""
    for n in range(q0.shape[0]):
        _exp_quaternion(psi[n], tmp)
        _quat_product(q0[n], tmp, out[n])
        nrm = math.sqrt(out[n, 0] ** 2 + out[n, 1] ** 2 + out[n, 2] ** 2 + out[n, 3] ** 2)
        for a in range(4):
            out[n, a] /= nrm


@kernel
def relative_rotation(q0, q1, out, tmp):
    """``out[n] = log(q0[n]⁻¹ ⊗ q1[n])`` (shortest branch)."""
    conj = np.empty(4)
    for n in range(q0.shape[0]):
        conj[0] = q0[n, 0]
        for a in range(1, 4):
            conj[a] = -q0[n, a]
        rm.quat_product(conj, q1[n], tmp)
        rm.log_quaternion(tmp, out[n])


@kernel
def write_record(model, x, q, v, w, U, clock, lam, PHI, PHIt, Bl, rec):
    """Record: configuration, velocities, energies [T, U, W, D], ``‖Φ‖``, ``‖B V + Φ_t‖``, λ."""
    T = 0.0
    J, mass = model.inertia, model.mass
    rx, rq, rv, rw = rec.x, rec.q, rec.v, rec.w
    for i in range(x.shape[0]):
        for a in range(3):
            rx[i, a] = x[i, a]
            rv[i, a] = v[i, a]
            rw[i, a] = w[i, a]
            T += 0.5 * mass[i] * v[i, a] * v[i, a]
            for b in range(3):
                T += 0.5 * w[i, a] * J[i, a, b] * w[i, b]
        for a in range(4):
            rq[i, a] = q[i, a]
    rec.energy[0] = T
    rec.energy[1] = U
    rec.energy[2] = clock[2]
    rec.energy[3] = clock[3]
    c0 = 0.0
    c1 = 0.0
    jt_i, jt_j, jt_row0, jt_neq, rlam = model.jt_i, model.jt_j, model.jt_row0, model.jt_neq, rec.lam
    for k in range(jt_i.shape[0]):
        i, j = jt_i[k], jt_j[k]
        for r in range(jt_row0[k], jt_row0[k] + jt_neq[k]):
            acc = PHIt[r]
            for a in range(3):
                acc += Bl[r, a] * v[i, a] + Bl[r, 3 + a] * w[i, a]
                if j >= 0:
                    acc += Bl[r, 6 + a] * v[j, a] + Bl[r, 9 + a] * w[j, a]
            c0 += PHI[r] ** 2
            c1 += acc**2
            rlam[r] = lam[r]
    rec.constraint[0] = math.sqrt(c0)
    rec.constraint[1] = math.sqrt(c1)
