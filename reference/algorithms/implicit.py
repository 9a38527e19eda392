"""What the implicit algorithms share: the residual, its tangent, the Newton system.

Unknowns.  Node n carries six coordinates: a displacement increment ``δx``
(inertial) and a rotation increment ``δθ`` in its body frame, applied as
``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (the left-trivialised update of
SO(3)×R³; Brüls, Cardona & Arnold 2012, §2).  Fixed coordinates are not
unknowns.  The constraints add one multiplier per row.

Residual (per node, the paper's eq. (5) written as ``M a + Bᵀλ = Q``)::

    r_u = m v̇ + c m v + S_u − F_u + (Bᵀλ)_u
    r_θ = J ω̇ + ω × J ω + c J ω + S_θ − F_θ + (Bᵀλ)_θ      (body frame)
    Φ(x, q, t) − c λ = 0

with ``S`` the internal forces of every element family and ``F`` the external
forces (:func:`reference.evaluation.forces.generalized_forces`), B the joint
Jacobian (:func:`reference.joints.assembly.joint_rows`) and c the rows'
compliance (``model.joints.compliance``: a regularised joint's ε, ``ε λ = Φ``, the
explicit scheme's meaning; 0 for an augmented-Lagrangian row, whose ε only regularises
the Newton matrix below, so that the multiplier estimate is updated at every iteration:
:mod:`reference.joints.augmented_lagrangian`).  The Static
algorithm uses ``v = v̇ = 0``.

Newton matrix with coefficients ``(c_m, c_c, c_k)`` (static: 0, 0, 1;
generalized-α: 1, γ'/β', 1/β')::

    [ c_m M + c_c C + c_k K    Bᵀ  ] [δ]      [c_k r]
    [ B                      −ε/c_k] [μ]  = − [Φ − cλ]      λ ← λ + μ / c_k

``C = ∂r/∂V`` (damping, the gyroscopic tangent and the force elements' dampers),
``K = ∂r/∂δ`` at fixed velocities: the element families' tangent stiffness (material +
geometric), the joints' λ-weighted constraint Hessian ``∂(Bᵀλ)/∂δ``, the
follower-load tangents and the force elements' stiffness — all sympy-derived
kernels (``reference/generated/tangents.py``, ``reference/joints/hessian.py``,
``reference/generated/forces.py`` through :func:`reference.evaluation.force_elements.force_element_tangent`;
docs/tangents.md), exact derivatives under the update above, so that Newton
converges quadratically.

Force elements (``[[springs]]``, :mod:`reference.forces`) enter like internal
forces: their spring and damper forces are subtracted from ``S`` and their
energy added to the strain energy, their actuator forces added to ``F``
(external work); the static algorithm evaluates them at zero velocity.  The
continuous angles of rotational springs live in the work arrays during a run
(copied from and back to ``State.angle`` by the algorithms); every evaluation
continues them from the last one, as the explicit scheme does.

The matrix is :mod:`reference.evaluation.tangent`'s: its values are written by
``tangent_values`` block by block in the order that ``newton_pattern`` lays out once per
model (:class:`reference.linalg.BlockPattern`).
"""

from __future__ import annotations

import math

import numpy as np

from reference.algorithms.base import Algorithm
from reference.elements.families import family_of
from reference.evaluation.forces import model_forces
from reference.evaluation.tangent import TangentWork, newton_pattern, tangent_values
from reference.generated import rotation_maps as rm
from reference.jit import boundary, inlined, kernel, named, parallel_kernel, prange
from reference.joints.assembly import joint_rows
from reference.linalg import SingularMatrix, SparseLU, lu_solve
from reference.parallel import CHUNK, PARALLEL_NODES, n_chunks
from reference.state import Model, Record, element_work
from reference.status import newton_failure


class Work:
    """Work arrays of the implicit algorithms for one model (allocated once)."""

    def __init__(self, model):
        N, m, J = model.nodes.mass.shape[0], model.n_constraints, model.joints.i.shape[0]
        self.S = np.zeros((N, 6))
        self.F = np.zeros((N, 6))
        self.r = np.zeros((N, 6))
        self.PHI = np.zeros(m)
        self.PHIt = np.zeros(m)
        self.Bl = np.zeros((m, 12))
        self.elements = element_work(model)  # the element families' work arrays
        self.A = np.zeros(9)
        self.jphi, self.jB, self.jphit = np.zeros(6), np.zeros((6, 12)), np.zeros(6)
        self.prim_phi, self.prim_B = np.zeros(10), np.zeros(120)
        sizes = [6 * family_of(data).n_nodes for data in model.elements]
        self.tangent = TangentWork.for_sizes(max(sizes + [12]) ** 2)
        nF = model.force_elements.kind.shape[0]
        blocks = sum(size * size * data.conn.shape[0] for size, data in zip(sizes, model.elements))
        self.values = np.zeros(36 * N + blocks + 144 * J + 24 * m + m + 144 * nF)
        # force elements: their spring/damper forces G, continuous angles, work arrays of
        # reference.forces, the damping matrix, the velocities of the last evaluation (zero for a
        # static one; the tangent is taken there) and [damper power] of the last evaluation
        self.G = np.zeros((N, 6))
        self.angle = np.zeros(nF)
        self.fe_e, self.fe_B, self.fe_G = np.zeros(6), np.zeros(72), np.zeros(864)
        self.C12 = np.zeros((12, 12))
        self.fe_v, self.fe_w = np.zeros((N, 3)), np.zeros((N, 3))
        self.fe_out = np.zeros(1)


@inlined
def _residual_rows(lo, hi, S, F, r, mass, J, c, v, w, vd, dynamic):
    """Rows ``lo … hi − 1`` of the residual without the constraint forces: ``S − F`` and, if ``dynamic``,
    the inertia ``m (v̇ + c v)``, ``J ω̇ + ω × J ω + c J ω``.

    Takes 12 parameters: a row range, called by the serial and the parallel loop with the node arrays bound once
    (not the Model: each array of an argument costs updates per call, :mod:`reference.jit`).
    """
    for i in range(lo, hi):
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


@parallel_kernel
def _residual_parallel(S, F, r, mass, J, c, v, w, vd, dynamic):
    N = S.shape[0]
    for k in prange(n_chunks(N)):
        _residual_rows(k * CHUNK, min(N, (k + 1) * CHUNK), S, F, r, mass, J, c, v, w, vd, dynamic)


@kernel
def evaluate(model, x, q, v, w, vd, lam, t, dynamic, w_):
    """Residual ``r`` (N,6), constraint rows ``Φ, Φ_t, B`` (local (m,12)) at time t; returns U.

    ``w_`` is a tuple of work arrays (S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi,
    prim_B, fe, elements) with ``fe`` those of the force elements and ``elements`` the element
    families' (:func:`work_tuple`); the forces are :func:`reference.evaluation.forces.generalized_forces`.  With ``dynamic``
    false the inertia, gyroscopic and damping terms are left out and the force elements see
    zero velocities.  U includes the springs' energy; the dampers' power ``Σ c (B_e V)²`` [W]
    goes to ``fe_out[0]``.
    """
    return evaluate_named(named(model, Model), x, q, v, w, vd, lam, t, dynamic, w_)


@inlined
def evaluate_named(model, x, q, v, w, vd, lam, t, dynamic, w_):
    """:func:`evaluate` of a Model that is a named tuple already: the form a kernel that has named the Model
    once inlines (:func:`named` at every evaluation would incref every array of the Model again)."""
    S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi, prim_B, fe, elements = w_
    G, angle, fe_e, fe_B, fe_G, C12, fv, fw, fe_out = fe
    N = x.shape[0]
    if model.force_elements.kind.shape[0] > 0:
        # the force elements' dampers see the velocities (none in a static evaluation)
        for i in range(N):
            for k in range(3):
                fv[i, k] = v[i, k] if dynamic else 0.0
                fw[i, k] = w[i, k] if dynamic else 0.0
    U, D_fe = model_forces(model.nodes.mass, model.gravity, model.loads, model.time_functions, model.elements,
                           model.force_elements, elements, x, q, fv, fw, t, S, F, G, angle, A, fe_e, fe_B)
    fe_out[0] = D_fe
    # the model's arrays are taken out once: each access of a Model field in a loop costs two
    # atomic reference-count updates
    c = model.damping
    mass, J = model.nodes.mass, model.nodes.inertia
    jt_i, jt_j, jt_neq, jt_row0, jt_tf = model.joints.i, model.joints.j, model.joints.neq, model.joints.row0, model.joints.tf
    jt_par, jt_rows, jt_drive, tf_kind, tf_par = model.joints.par, model.joints.rows, model.joints.drive, model.time_functions.kind, model.time_functions.par
    if N >= PARALLEL_NODES:
        _residual_parallel(S, F, r, mass, J, c, v, w, vd, dynamic)
    else:
        _residual_rows(0, N, S, F, r, mass, J, c, v, w, vd, dynamic)
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


def work_tuple(w: Work):
    fe = (w.G, w.angle, w.fe_e, w.fe_B, w.fe_G, w.C12, w.fe_v, w.fe_w, w.fe_out)
    return (w.S, w.F, w.r, w.PHI, w.PHIt, w.Bl, w.A, w.jphi, w.jB, w.jphit, w.prim_phi, w.prim_B, fe, w.elements)


class NewtonSystem:
    """The Newton system of one model, built once per run: its block pattern, the unknown of every
    node coordinate, the work arrays, the sparse LU, and the evaluations that fill them.

    Parameters
    ----------
    model : Model

    Attributes
    ----------
    pattern : BlockPattern
        The Newton matrix's blocks (:func:`reference.evaluation.tangent.newton_pattern`).
    dof : ndarray (N, 6)
        The unknown of each node coordinate, −1 where fixed; ``free`` the mask, ``n_free`` the count.
    work : Work
        The arrays every evaluation writes (``work.r`` the residual, ``work.PHI`` the constraints, …).
    """

    def __init__(self, model):
        self.model = model
        self.arg = boundary(model)  # what the kernels are called with (reference.jit.boundary)
        self.pattern, self.dof = newton_pattern(model)
        self.free = self.dof >= 0
        self.n_free = int(self.free.sum())
        self.work = Work(model)
        self.wt = work_tuple(self.work)
        self.tangent_arg = boundary(self.work.tangent)  # a plain tuple: numba types a named one slower per call
        self.zero_psi = np.zeros((model.nodes.mass.shape[0], 3))
        self.slu = SparseLU(self.pattern.n)
        self._mass = None
        self._record = (None, None)  # the last output record and its plain copy (record_arg)

    def evaluate(self, x, q, v, w, vd, lam, t, dynamic) -> float:
        """:func:`evaluate` into :attr:`work`; returns the strain energy."""
        return evaluate(self.arg, x, q, v, w, vd, lam, t, dynamic, self.wt)

    def residual_norm(self, ck: float, lam) -> float:
        """‖[c_k r; Φ − cλ]‖ of the last :meth:`evaluate` (free coordinates only)."""
        r = self.work.r[self.free]
        phi = self.work.PHI - self.model.joints.compliance * lam
        return float(math.sqrt(ck * ck * r @ r + phi @ phi))

    def matrix(self, x, q, w, t, lam, cm, cc, ck, ce=None, psi=None):
        """The Newton matrix ``[c_m M + c_c C + c_k K, Bᵀ; B, −c_e ε]`` at ``(x, q, ω, t, λ)`` (CSC, the
        pattern's one matrix object, overwritten by the next call; ``c_e = 1/c_k`` by default).  The
        force elements' blocks are taken at the velocities of the last :meth:`evaluate`."""
        wk = self.work
        ce = 1.0 / ck if ce is None else ce
        psi = self.zero_psi if psi is None else psi
        tangent_values(self.arg, x, q, w, psi, t, lam, cm, cc, ck, ce, wk.values, self.wt, self.tangent_arg)
        return self.pattern.matrix(wk.values)

    def mass(self, x, q):
        """The mass matrix on the free coordinates (CSR; constant, lumped masses and body-frame inertias:
        assembled at the first call, at a configuration ``(x, q)`` where the force elements are defined)."""
        if self._mass is None:
            zero = np.zeros_like(x)
            A = self.matrix(x, q, zero, 0.0, np.zeros(self.model.n_constraints), 1.0, 0.0, 0.0, ce=0.0).tocsr()
            self._mass = A[: self.n_free, : self.n_free]
        return self._mass

    def factor(self, x, q, w, t, lam, cm, cc, ck, ce=None, psi=None):
        """Assemble (:meth:`matrix`) and factor the Newton matrix; returns the factor arrays
        (:class:`reference.linalg.SparseLU`: SuperLU once, compiled refactorisations after).

        Raises :class:`reference.linalg.SingularMatrix` when the matrix is singular.
        """
        return self.slu.factor(self.matrix(x, q, w, t, lam, cm, cc, ck, ce, psi))

    def consistent_accelerations(self, x, q, v, w, t, tau, ce=0.0):
        """Accelerations ``V̇`` (N, 6) and multipliers λ (m,) consistent with the state at t:
        ``M V̇ + Bᵀλ = −r(V̇ = 0, λ = 0)``, ``B V̇ − c_e ε λ = −d/dt(B V + Φ_t)``, the last by a central
        difference of step ``tau`` [s] along the motion.  Raises :class:`reference.linalg.SingularMatrix`."""
        model = self.model
        N, m = x.shape[0], model.n_constraints
        vd = np.zeros((N, 6))
        lam = np.zeros(m)
        self.evaluate(x, q, v, w, vd, lam, t, True)
        r0 = self.work.r.copy()
        rate = np.zeros(m)
        if m:
            g = []
            for sgn in (1.0, -1.0):
                xs = x + sgn * tau * v
                qs = np.empty_like(q)
                compose(q, sgn * tau * w, qs, np.empty(4))
                self.evaluate(xs, qs, v, w, vd, lam, t + sgn * tau, True)
                g.append(self.work.PHIt + self.constraint_rate(v, w))
            rate = (g[0] - g[1]) / (2.0 * tau)
            self.evaluate(x, q, v, w, vd, lam, t, True)
        lu = self.factor(x, q, w, t, lam, 1.0, 0.0, 0.0, ce=ce)
        return self.solve(lu, -r0, -rate)

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

    def newton_correction(self, lu, ck, lam):
        """Correction from the last :meth:`evaluate`: right-hand side ``−[c_k r; Φ − cλ]``."""
        return self.solve(lu, -ck * self.work.r, -(self.work.PHI - self.model.joints.compliance * lam))

    def write_record(self, rec, x, q, v, w, U, clock, lam) -> None:
        """Fill ``rec`` as the explicit scheme does (uses the last :meth:`evaluate` for Φ and B; ``clock`` the
        state's, :data:`reference.state.CLOCK` (1,))."""
        write_record(self.arg, x, q, v, w, U, clock, lam, self.work.PHI, self.work.PHIt, self.work.Bl,
                     self.record_arg(rec))

    def record_arg(self, rec):
        """``rec`` (:class:`~reference.state.Record`) as the kernels take it (:func:`reference.jit.boundary`),
        made once for the record a run passes again and again."""
        if self._record[0] is not rec:
            self._record = (rec, boundary(rec))
        return self._record[1]

    def constraint_rate(self, v, w) -> np.ndarray:
        """``B V`` (m,) from the last evaluation's local rows."""
        model, Bl = self.model, self.work.Bl
        out = np.zeros(Bl.shape[0])
        V = np.concatenate([v, w], axis=1)
        for k in range(model.joints.i.shape[0]):
            r0, neq = int(model.joints.row0[k]), int(model.joints.neq[k])
            i, j = int(model.joints.i[k]), int(model.joints.j[k])
            out[r0:r0 + neq] = Bl[r0:r0 + neq, :6] @ V[i]
            if j >= 0:
                out[r0:r0 + neq] += Bl[r0:r0 + neq, 6:] @ V[j]
        return out


class ImplicitAlgorithm(Algorithm):
    """Base of the Newton-based algorithms: settings, convergence test, failure messages.

    Subclasses provide ``name``, their deck keys, ``start`` (a run state holding a
    :class:`NewtonSystem` built by :meth:`newton_system`) and ``advance``.  The run
    state has ``stopped_at`` (the time or load factor where a failed step stopped, or
    None) and ``history`` (the residual norms of the last step's Newton iterations).

    Parameters
    ----------
    dt : float
        Step [s] (or load-factor increment for the static algorithm).
    tolerance : float
        Newton's tolerance, in each algorithm's test: the static one's (a balanced residual, or
        :meth:`converged`: the largest correction below ``tolerance`` times the model size for
        translations, ``tolerance`` rad for rotations), generalized-α's (the imbalance left,
        relative to the step's forces, :mod:`reference.algorithms.generalized_alpha`).
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

    @staticmethod
    def refusal(model) -> str | None:
        """Why this algorithm cannot run ``model`` (None if it can)."""
        if model.master_slave.master.shape[0] > 0:
            return ("master/slave joints are not available with the implicit algorithms; use "
                    "formulation = \"jacobian\" (Lagrange multipliers) for those joints")
        return None

    def newton_system(self, model) -> NewtonSystem:
        """The model's :class:`NewtonSystem`, after :meth:`refusal` (raises ValueError with its reason)."""
        problem = self.refusal(model)
        if problem:
            raise ValueError(problem)
        return NewtonSystem(model)

    @staticmethod
    def length_scale(x: np.ndarray) -> float:
        span = float(np.max(np.ptp(x, axis=0))) if x.shape[0] > 1 else 0.0
        return max(span, 1e-3)

    def correction_size(self, delta: np.ndarray, L: float) -> float:
        """Largest correction: translations over the model size L, rotations in rad."""
        return max(float(np.max(np.abs(delta[:, :3]), initial=0.0)) / L, float(np.max(np.abs(delta[:, 3:]), initial=0.0)))

    def converged(self, delta: np.ndarray, L: float) -> bool:
        return self.correction_size(delta, L) <= self.tolerance

    def failure(self, code: int, state, run) -> tuple[str, str]:
        """``(status, message)`` for a failed ``advance`` (:func:`reference.status.newton_failure`)."""
        t = run.stopped_at if run.stopped_at is not None else state.t
        return newton_failure(code, f"{self.progress_name} {t:.6g}", self.max_iterations, self.cut_note,
                              self.no_convergence_fix)

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
    """Record: configuration, velocities, energies [T, U, W, D] (W and D from ``clock``, the state's
    :data:`reference.state.CLOCK` (1,)), ``‖Φ‖``, ``‖B V + Φ_t‖``, λ.

    Takes 12 parameters: the compiled entry from Python, given the State's and the last evaluation's arrays one by
    one (a record would recompile every implicit kernel).
    """
    write_record_named(named(model, Model), x, q, v, w, U, clock[0], lam, PHI, PHIt, Bl, named(rec, Record))


@inlined
def write_record_named(model, x, q, v, w, U, clock, lam, PHI, PHIt, Bl, rec):
    """:func:`write_record` of a Model and Record that are named tuples already and of the clock's record (the
    form a kernel inlines).

    Takes 12 parameters: those of :func:`write_record`, whose inlined form it is.
    """
    T = 0.0
    J, mass = model.nodes.inertia, model.nodes.mass
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
    rec.energy[2] = clock["work"]
    rec.energy[3] = clock["dissipated"]
    c0 = 0.0
    c1 = 0.0
    jt_i, jt_j, jt_row0, jt_neq, rlam = model.joints.i, model.joints.j, model.joints.row0, model.joints.neq, rec.lam
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
