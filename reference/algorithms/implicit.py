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

``C = ∂r/∂V`` (damping and gyroscopic, analytic), ``K = ∂r/∂δ`` at fixed
velocities: the Beam2 tangent stiffness, the joints' λ-weighted constraint
Hessian ``∂(Bᵀλ)/∂δ`` and the follower-load tangents.  The Beam2 and joint
parts are taken here by central differences of the generated kernels under
the update above (step ``FD_STEP`` relative; truncation and round-off both
≈ 1e-10 relative), the load tangents analytically:
``∂(f A b)/∂δθ = −f A b̃`` (follower force) and ``∂(f Aᵀ m)/∂δθ = f (Aᵀm)~``
(dead moment in the body frame).

Values are written by :func:`tangent_values` block by block in the order that
:func:`newton_pattern` lays out once per model (:class:`reference.linalg.BlockPattern`).
"""

from __future__ import annotations

import math

import numpy as np

from reference.algorithms.staggered import external_forces
from reference.elements.formulation import beam2_assemble, section_quaternion, tangent_to_node_frame
from reference.generated import beam2 as generated_beam2
from reference.generated import rotation_maps as rm
from reference.interactions import tf_value
from reference.jit import kernel
from reference.joints.assembly import joint_rows
from reference.algorithms.base import Algorithm
from reference.linalg import BlockPattern, SingularMatrix, factorize

FD_STEP = 6e-6
"""Central-difference step of the finite-difference tangents (relative to the model size for
translations, in radians for rotations): ≈ ε_machine^(1/3)."""


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
        self.A = np.zeros(9)
        self.jphi, self.jB, self.jphit = np.zeros(6), np.zeros((6, 12)), np.zeros(6)
        self.prim_phi, self.prim_B = np.zeros(10), np.zeros(120)
        self.small = np.zeros((8, 12))
        self.K12 = np.zeros((12, 12))
        self.values = np.zeros(36 * N + 144 * E + 144 * J + 24 * m + m)


@kernel
def evaluate(model, x, q, v, w, vd, lam, t, dynamic, w_):
    """Residual ``r`` (N,6), constraint rows ``Φ, Φ_t, B`` (local (m,12)) at time t; returns U.

    ``w_`` is a tuple of work arrays (S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi,
    prim_B).  With ``dynamic`` false the inertia, gyroscopic and damping terms are left out.
    """
    S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi, prim_B = w_
    U = beam2_assemble(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff, S, s_el)
    external_forces(model, x, q, t, F, A)
    N = x.shape[0]
    c = model.damping
    for i in range(N):
        for k in range(6):
            r[i, k] = S[i, k] - F[i, k]
        if dynamic:
            m = model.mass[i]
            J = model.inertia[i]
            for k in range(3):
                r[i, k] += m * (vd[i, k] + c * v[i, k])
            jw0 = J[0, 0] * w[i, 0] + J[0, 1] * w[i, 1] + J[0, 2] * w[i, 2]
            jw1 = J[1, 0] * w[i, 0] + J[1, 1] * w[i, 1] + J[1, 2] * w[i, 2]
            jw2 = J[2, 0] * w[i, 0] + J[2, 1] * w[i, 1] + J[2, 2] * w[i, 2]
            r[i, 3] += w[i, 1] * jw2 - w[i, 2] * jw1 + c * jw0
            r[i, 4] += w[i, 2] * jw0 - w[i, 0] * jw2 + c * jw1
            r[i, 5] += w[i, 0] * jw1 - w[i, 1] * jw0 + c * jw2
            for a in range(3):
                r[i, 3 + a] += J[a, 0] * vd[i, 3] + J[a, 1] * vd[i, 4] + J[a, 2] * vd[i, 5]
    for k in range(model.jt_i.shape[0]):
        neq = model.jt_neq[k]
        r0 = model.jt_row0[k]
        i, j = model.jt_i[k], model.jt_j[k]
        tf = model.jt_tf[k]
        joint_rows(x, q, i, j, model.jt_par[k], model.jt_rows[k], model.jt_drive[k], model.tf_kind[tf],
                   model.tf_par[tf], t, jphi[:neq], jB[:neq], jphit[:neq], prim_phi, prim_B)
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
def _perturb(x0, q0, k, h, x, q, dq):
    """``x = x0 + h e_k`` (k < 3) or ``q = q0 ⊗ exp(h e_{k−3})``."""
    for a in range(3):
        x[a] = x0[a]
    for a in range(4):
        q[a] = q0[a]
    if k < 3:
        x[k] += h
    else:
        half = 0.5 * h
        s, c = math.sin(half), math.cos(half)
        dq[0], dq[1], dq[2], dq[3] = c, 0.0, 0.0, 0.0
        dq[k - 2] = s
        rm.quat_product(q0, dq, q)


@kernel
def beam2_tangent_fd(x1, x2, q1, q2, L0, psi0, gamma0, stiff, hx, K, small, s_el):
    """Central-difference tangent ``K = ∂s/∂δ`` (12×12) of one Beam2 element's internal forces."""
    xp, qp = small[0, :3], small[1, :4]
    dq = small[2, :4]
    fp, fm = small[3, :12], small[4, :12]
    for col in range(12):
        node = col // 6
        k = col % 6
        h = hx if k < 3 else FD_STEP
        for sgn in range(2):
            step = h if sgn == 0 else -h
            out = fp if sgn == 0 else fm
            if node == 0:
                _perturb(x1, q1, k, step, xp, qp, dq)
                generated_beam2.internal_forces(xp, x2, qp, q2, L0, psi0, gamma0, stiff, s_el[:12], s_el[12:18],
                                                s_el[18:24])
            else:
                _perturb(x2, q2, k, step, xp, qp, dq)
                generated_beam2.internal_forces(x1, xp, q1, qp, L0, psi0, gamma0, stiff, s_el[:12], s_el[12:18],
                                                s_el[18:24])
            for a in range(12):
                out[a] = s_el[a]
        for a in range(12):
            K[a, col] = (fp[a] - fm[a]) / (2.0 * h)


@kernel
def joint_hessian_fd(model, k, x, q, t, lam, hx, H, w_, small):
    """Central-difference ``H = ∂(Bᵀλ)/∂δ`` (12×12, nodes i then j) of joint k; x and q restored."""
    S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi, prim_B = w_
    neq = model.jt_neq[k]
    r0 = model.jt_row0[k]
    i, j = model.jt_i[k], model.jt_j[k]
    tf = model.jt_tf[k]
    xs, qs = small[0, :3], small[1, :4]
    dq = small[2, :4]
    fp, fm = small[3, :12], small[4, :12]
    xn, qn = small[5, :3], small[6, :4]
    for col in range(12):
        node = i if col < 6 else j
        kk = col % 6
        if node < 0:
            for a in range(12):
                H[a, col] = 0.0
            continue
        h = hx if kk < 3 else FD_STEP
        for a in range(3):
            xs[a] = x[node, a]
        for a in range(4):
            qs[a] = q[node, a]
        for sgn in range(2):
            step = h if sgn == 0 else -h
            out = fp if sgn == 0 else fm
            _perturb(xs, qs, kk, step, xn, qn, dq)
            for a in range(3):
                x[node, a] = xn[a]
            for a in range(4):
                q[node, a] = qn[a]
            joint_rows(x, q, i, j, model.jt_par[k], model.jt_rows[k], model.jt_drive[k], model.tf_kind[tf],
                       model.tf_par[tf], t, jphi[:neq], jB[:neq], jphit[:neq], prim_phi, prim_B)
            for a in range(12):
                acc = 0.0
                for rr in range(neq):
                    acc += jB[rr, a] * lam[r0 + rr]
                out[a] = acc
        for a in range(3):
            x[node, a] = xs[a]
        for a in range(4):
            q[node, a] = qs[a]
        for a in range(12):
            H[a, col] = (fp[a] - fm[a]) / (2.0 * h)


@kernel
def load_tangent(model, q, t, i, K6, A):
    """Add ``−∂F/∂δ`` of the loads on node i into the 6×6 block ``K6`` (follower force, dead moment)."""
    for l in range(model.load_node.shape[0]):
        if model.load_node[l] != i:
            continue
        code = model.load_code[l]
        if code != 1 and code != 2:
            continue
        tf = model.load_tf[l]
        f = tf_value(model.tf_kind[tf], model.tf_par[tf], t)
        b = model.load_vec[l]
        rm.rotation_matrix(q[i], A)
        if code == 1:
            # F_u = f A b: ∂/∂δθ = −f A b̃, so −∂F_u/∂δθ = f A b̃
            for a in range(3):
                a0, a1, a2 = A[3 * a], A[3 * a + 1], A[3 * a + 2]
                # row a of A b̃: (A b̃)_{a,c} = Σ_k A_{ak} b̃_{kc}
                K6[a, 3] += f * (a1 * b[2] - a2 * b[1])
                K6[a, 4] += f * (a2 * b[0] - a0 * b[2])
                K6[a, 5] += f * (a0 * b[1] - a1 * b[0])
        else:
            # F_θ = f Aᵀ m: ∂/∂δθ = f (Aᵀm)~, so −∂F_θ/∂δθ = −f (Aᵀm)~
            g0 = A[0] * b[0] + A[3] * b[1] + A[6] * b[2]
            g1 = A[1] * b[0] + A[4] * b[1] + A[7] * b[2]
            g2 = A[2] * b[0] + A[5] * b[1] + A[8] * b[2]
            K6[3, 4] += f * g2
            K6[3, 5] -= f * g1
            K6[4, 3] -= f * g2
            K6[4, 5] += f * g0
            K6[5, 3] += f * g1
            K6[5, 4] -= f * g0


@kernel
def tangent_values(model, x, q, w, t, lam, cm, cc, ck, ce, hx, values, w_, small, K12):
    """Block values of the Newton matrix (order of :func:`newton_pattern`) into ``values``.

    ``c_e`` multiplies the −ε diagonal (``1/c_k`` in Newton); with ``c_k = 0`` the
    stiffness blocks are zero and not computed (the mass matrix of the initial accelerations).
    """
    N = x.shape[0]
    E = model.conn.shape[0]
    NJ = model.jt_i.shape[0]
    m = lam.shape[0]
    S, F, r, PHI, PHIt, Bl, s_el, A, jphi, jB, jphit, prim_phi, prim_B = w_
    c = model.damping
    p = 0
    for i in range(N):
        blk = K12[:6, :6]
        for a in range(6):
            for b in range(6):
                blk[a, b] = 0.0
        load_tangent(model, q, t, i, blk, A)
        J = model.inertia[i]
        for a in range(6):
            for b in range(6):
                blk[a, b] *= ck
        for a in range(3):
            blk[a, a] += model.mass[i] * (cm + cc * c)
        jw0 = J[0, 0] * w[i, 0] + J[0, 1] * w[i, 1] + J[0, 2] * w[i, 2]
        jw1 = J[1, 0] * w[i, 0] + J[1, 1] * w[i, 1] + J[1, 2] * w[i, 2]
        jw2 = J[2, 0] * w[i, 0] + J[2, 1] * w[i, 1] + J[2, 2] * w[i, 2]
        for a in range(3):
            for b in range(3):
                blk[3 + a, 3 + b] += (cm + cc * c) * J[a, b]
        if cc != 0.0:
            # ∂(ω × Jω)/∂ω = ω̃ J − (Jω)~
            for b in range(3):
                y0, y1, y2 = J[0, b], J[1, b], J[2, b]
                blk[3, 3 + b] += cc * (w[i, 1] * y2 - w[i, 2] * y1)
                blk[4, 3 + b] += cc * (w[i, 2] * y0 - w[i, 0] * y2)
                blk[5, 3 + b] += cc * (w[i, 0] * y1 - w[i, 1] * y0)
            blk[3, 4] -= cc * (-jw2)
            blk[3, 5] -= cc * jw1
            blk[4, 3] -= cc * jw2
            blk[4, 5] -= cc * (-jw0)
            blk[5, 3] -= cc * (-jw1)
            blk[5, 4] -= cc * jw0
        for a in range(6):
            for b in range(6):
                values[p] = blk[a, b]
                p += 1
    for e in range(E):
        i, j = model.conn[e, 0], model.conn[e, 1]
        if ck != 0.0:
            # the element works in its section frames p_a = q_a ⊗ o_a; its tangent goes back to the nodes'
            p1, p2 = s_el[24:28], s_el[28:32]
            section_quaternion(q[i], model.offset[e, 0], p1)
            section_quaternion(q[j], model.offset[e, 1], p2)
            beam2_tangent_fd(x[i], x[j], p1, p2, model.L0[e], model.psi0[e], model.gamma0[e], model.stiff[e],
                             hx, K12, small, s_el)
            tangent_to_node_frame(model.offset[e, 0], model.offset[e, 1], K12, s_el[32:35], s_el[35:38])
        else:
            K12[:, :] = 0.0
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b]
                p += 1
    for k in range(NJ):
        if ck != 0.0:
            joint_hessian_fd(model, k, x, q, t, lam, hx, K12, w_, small)
        else:
            K12[:, :] = 0.0
        for a in range(12):
            for b in range(12):
                values[p] = ck * K12[a, b]
                p += 1
    for rr in range(m):
        for b in range(12):
            values[p] = Bl[rr, b]
            p += 1
    for rr in range(m):
        for b in range(12):
            values[p] = Bl[rr, b]
            p += 1
    for rr in range(m):
        values[p] = -model.row_eps[rr] * ce
        p += 1
    return p


def work_tuple(w: Work):
    return (w.S, w.F, w.r, w.PHI, w.PHIt, w.Bl, w.s_el, w.A, w.jphi, w.jB, w.jphit, w.prim_phi, w.prim_B)


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
    row_dofs = []
    for k in range(model.jt_i.shape[0]):
        nodes = [model.jt_i[k], model.jt_j[k]]
        idx = np.concatenate([dof6[n] if n >= 0 else np.full(6, -1) for n in nodes])
        row_dofs += [idx] * int(model.jt_neq[k])
    for rr, idx in enumerate(row_dofs):
        rows.append(np.full(12, n_free + rr))
        cols.append(idx)
    for rr, idx in enumerate(row_dofs):
        rows.append(idx)
        cols.append(np.full(12, n_free + rr))
    rows.append(n_free + np.arange(m))
    cols.append(n_free + np.arange(m))
    rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    cols = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
    return BlockPattern(rows, cols, n_free + m), dof6


OK, DIVERGED, SINGULAR, NO_CONVERGENCE = 0, 1, 2, 3
"""Status codes of the implicit algorithms' ``advance`` (OK, DIVERGED and SINGULAR as in the explicit scheme)."""


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
        self.history: list[list[float]] = []
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

    def factor(self, model, x, q, w, t, lam, cm, cc, ck, hx, ce=None):
        """Assemble and factor the Newton matrix at ``(x, q, ω, t, λ)``.

        Raises :class:`reference.linalg.SingularMatrix` when the matrix is singular.
        """
        wk = self.work
        ce = 1.0 / ck if ce is None else ce
        tangent_values(model, x, q, w, t, lam, cm, cc, ck, ce, hx, wk.values, self.wt, wk.small, wk.K12)
        return factorize(self.pattern.matrix(wk.values))

    def solve(self, lu, rhs_nodes: np.ndarray, rhs_rows: np.ndarray):
        """Solve with a factor: node part (N,6) and constraint part (m,) → (δ (N,6), μ (m,))."""
        rhs = np.empty(self.pattern.n)
        rhs[: self.n_free] = rhs_nodes[self.free]
        rhs[self.n_free:] = rhs_rows
        sol = lu.solve(rhs)
        if not np.all(np.isfinite(sol)):
            raise SingularMatrix("non-finite Newton correction")
        delta = np.zeros_like(rhs_nodes)
        delta[self.free] = sol[: self.n_free]
        return delta, sol[self.n_free:]

    def newton_correction(self, lu, model, ck, lam):
        """Correction from the last :meth:`evaluate`: right-hand side ``−[c_k r; Φ − ελ]``."""
        return self.solve(lu, -ck * self.work.r, -(self.work.PHI - model.row_eps * lam))

    def converged(self, delta: np.ndarray, L: float) -> bool:
        return (float(np.max(np.abs(delta[:, :3]), initial=0.0)) <= self.tolerance * L
                and float(np.max(np.abs(delta[:, 3:]), initial=0.0)) <= self.tolerance)

    def write_record(self, rec, model, x, q, v, w, U, energy_clock, lam) -> None:
        """Fill ``rec`` as the explicit scheme does (uses the last :meth:`evaluate` for Φ and B)."""
        rec.x[:] = x
        rec.q[:] = q
        rec.v[:] = v
        rec.w[:] = w
        J = model.inertia
        T = 0.5 * float(np.sum(model.mass[:, None] * v * v)) + 0.5 * float(np.einsum("na,nab,nb->", w, J, w))
        rec.energy[:] = (T, U, energy_clock[2], energy_clock[3])
        rec.constraint[0] = float(np.linalg.norm(self.work.PHI))
        rec.constraint[1] = float(np.linalg.norm(self.work.PHIt + self.constraint_rate(model, v, w)))
        rec.lam[:] = lam

    def constraint_rate(self, model, v, w) -> np.ndarray:
        """``B V`` from the last evaluation's local rows."""
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
                    f"Newton did not converge beyond {where} within {self.max_iterations} iterations "
                    f"{self.cut_note}; results up to there are kept. {self.no_convergence_fix}")
        return (f"diverged after {where}",
                f"the solution became non-finite after {where}; results up to there are kept. Check the loads.")

    progress_name = "t ="
    cut_note = ""
    no_convergence_fix = "Reduce the step or raise max_iterations."


@kernel
def compose(q0, psi, out, tmp):
    """``out[n] = q0[n] ⊗ exp(ψ[n])`` for every node (normalised)."""
    for n in range(q0.shape[0]):
        rm.exp_quaternion(psi[n], tmp)
        rm.quat_product(q0[n], tmp, out[n])
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
