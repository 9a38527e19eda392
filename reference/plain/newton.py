"""The Newton system of the implicit algorithms on the reference path (plain NumPy and SciPy).

The twin of :class:`reference.algorithms.implicit.NewtonSystem`: the same residual, the same Newton
matrix and the same free coordinates, written from :class:`reference.plain.model.Evaluation` with no
compiled code.  The equations are those of :mod:`reference.algorithms.implicit` (stated there once):
the residual per node ::

    r = S − F + Bᵀλ  (+ m (v̇ + c v),  J ω̇ + ω × J ω + c J ω  when dynamic),     Φ − ε λ = 0,

and the Newton matrix with coefficients ``(c_m, c_c, c_k, c_e)`` ::

    [ c_m M + c_c C + c_k K T(ψ)    Bᵀ     ]
    [ B T(ψ)                      −c_e ε   ]

on the free coordinates (node-major, as ``reference.evaluation.tangent.newton_pattern`` numbers them),
solved by SuperLU (``scipy.sparse.linalg.splu``).  The configuration update is
``x ← x + δx``, ``q ← q ⊗ exp(δθ)`` (body-frame δθ).

The rotation maps (``exp``, ``log``, the quaternion product) are the generated ones
(``reference/generated/rotation_maps.py``) run on all nodes at once (:func:`reference.plain.vectorise.plain`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.generated import rotation_maps as rm
from reference.linalg import SingularMatrix
from reference.plain.model import Evaluation
from reference.plain.vectorise import plain

_exp_quaternion, _quat_product, _log_quaternion = (plain(f) for f in (rm.exp_quaternion, rm.quat_product,
                                                                        rm.log_quaternion))


def compose(q: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """``q[n] ⊗ exp(ψ[n])`` for every node, normalised (N,4): the body-frame rotation update."""
    e, out = np.empty((4, q.shape[0])), np.empty((4, q.shape[0]))
    _exp_quaternion(psi.T, e)
    _quat_product(q.T, e, out)
    return (out / np.linalg.norm(out, axis=0)).T.copy()


def relative_rotation(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """``log(q0[n]⁻¹ ⊗ q1[n])`` (N,3), the shortest branch [rad]."""
    tmp, out = np.empty((4, q0.shape[0])), np.empty((3, q0.shape[0]))
    _quat_product((q0 * np.array([1.0, -1.0, -1.0, -1.0])).T, q1.T, tmp)
    _log_quaternion(tmp, out)
    return out.T.copy()


@dataclass
class Residual:
    """One evaluation of the implicit residual at a configuration.

    ``r`` (N,6) the residual, ``S``, ``F`` (N,6) the internal and external forces, ``phi`` (m,) Φ,
    ``B`` (m, 6N) csr, ``phi_t`` (m,) Φ_t, ``U`` the strain energy [J], ``D`` the force elements'
    damper power [W]."""

    r: np.ndarray
    S: np.ndarray
    F: np.ndarray
    phi: np.ndarray
    B: sps.csr_matrix
    phi_t: np.ndarray
    U: float
    D: float


class Newton:
    """The reference path's Newton system for one model (:mod:`reference.algorithms.implicit`'s
    ``NewtonSystem``, in NumPy).

    Attributes
    ----------
    ev : Evaluation
    index : ndarray (n_free,)
        The free coordinates among the 6N, node-major (the unknowns' order).
    angle : ndarray (F,)
        The rotational force elements' continuous angles, continued by every :meth:`evaluate`.
    last : Residual or None
        The last evaluation.
    """

    def __init__(self, model):
        self.model = model
        self.ev = Evaluation(model)
        self.free = self.ev.free
        self.index = np.flatnonzero(self.free.ravel())
        self.n_free = int(self.index.size)
        self.m = int(model.n_constraints)
        self.eps = np.asarray(model.joints.eps, dtype=float)
        self.angle = np.zeros(model.force_elements.kind.shape[0])
        self.M = self.ev.mass_matrix()
        self.last: Residual | None = None

    def evaluate(self, x, q, v, w, vd, lam, t, dynamic) -> Residual:
        """The residual at ``(x, q, V, V̇, λ, t)``; a static evaluation (``dynamic`` false) has no inertia
        and gives the force elements zero velocities (the compiled ``evaluate``'s convention).  The r of
        :meth:`reference.plain.model.Evaluation.residual`, made here from its ``forces`` because the
        convergence tests and the work of the loads need S and F apart."""
        N = x.shape[0]
        zero = np.zeros((N, 3))
        S, F, U, D = self.ev.forces(x, q, v if dynamic else zero, w if dynamic else zero, t, self.angle)
        phi, B, phi_t = self.ev.constraints(x, q, t)
        r = S - F + (B.T @ lam).reshape(N, 6)
        if dynamic:
            m, J = self.ev.masses
            c = self.ev.damping
            Jw = np.einsum("nab,nb->na", J, w)
            r[:, :3] += m[:, None] * (vd[:, :3] + c * v)
            r[:, 3:] += np.einsum("nab,nb->na", J, vd[:, 3:]) + np.cross(w, Jw) + c * Jw
        self.last = Residual(r, S, F, phi, B, phi_t, float(U), float(D))
        return self.last

    def matrix(self, x, q, v, w, t, lam, coefficients, psi=None) -> sps.csc_matrix:
        """The Newton matrix (module docstring) on the free coordinates and the multipliers (CSC), at the
        configuration of the last :meth:`evaluate` (its B); ``coefficients`` ``(c_m, c_c, c_k, c_e)`` of the
        mass, damping and stiffness blocks and of the −ε diagonal; ``psi`` (N,3) the rotation of the iterate
        (generalized-α), None for the static update."""
        cm, cc, ck, ce = coefficients
        ev, idx = self.ev, self.index
        B = self.last.B
        A = cm * self.M if cm else sps.csr_matrix(self.M.shape)
        if cc:
            A = A + cc * ev.damping_matrix(x, q, v, w)
        BT = B
        if ck:
            K = ev.tangent(x, q, v, w, t, lam, self.angle)
            if psi is not None:
                T = ev.rotation_tangent(psi)
                K, BT = K @ T, B @ T
            A = A + ck * K
        elif psi is not None:
            BT = B @ ev.rotation_tangent(psi)
        A = sps.csr_matrix(A)[idx][:, idx]
        if self.m == 0:
            return A.tocsc()
        return sps.bmat([[A, B.tocsc()[:, idx].T], [sps.csr_matrix(BT)[:, idx], sps.diags(-ce * self.eps)]],
                        format="csc")

    def factor(self, A):
        """SuperLU of the Newton matrix; None when it is singular (SciPy's RuntimeError)."""
        try:
            return spla.splu(A)
        except RuntimeError:
            return None

    def solve(self, lu, rhs_nodes, rhs_rows):
        """``(δ (N,6), μ (m,))`` from the node part (N,6) and the constraint part (m,) of the right-hand side;
        None when not finite."""
        sol = lu.solve(np.concatenate([rhs_nodes.ravel()[self.index], rhs_rows]))
        if not np.all(np.isfinite(sol)):
            return None
        delta = np.zeros(6 * self.free.shape[0])
        delta[self.index] = sol[: self.n_free]
        return delta.reshape(-1, 6), sol[self.n_free:]

    def update(self, x, q, lam, delta, mu) -> None:
        """``x ← x + δx``, ``q ← q ⊗ exp(δθ)``, ``λ ← λ + μ``, in place."""
        x += delta[:, :3]
        q[:] = compose(q, delta[:, 3:])
        lam += mu

    def free_norm(self, r: np.ndarray) -> float:
        """``‖r‖`` over the free coordinates of ``r`` (N,6)."""
        rf = r.ravel()[self.index]
        return float(math.sqrt(rf @ rf))

    def consistent_accelerations(self, x, q, v, w, t, tau, ce=0.0):
        """``(V̇ (N,6), λ (m,))`` consistent with the state at t: ``M V̇ + Bᵀλ = −r(V̇ = 0, λ = 0)``,
        ``B V̇ − c_e ε λ = −d/dt(B V + Φ_t)``, the last by a central difference of step ``tau`` [s] along the
        motion (the compiled ``consistent_accelerations``); None when the matrix is singular."""
        N, m = x.shape[0], self.m
        V = np.hstack([v, w]).ravel()
        r0 = self.evaluate(x, q, v, w, np.zeros((N, 6)), np.zeros(m), t, True).r.copy()
        rate = np.zeros(m)
        if m:
            g = []
            for sgn in (1.0, -1.0):
                _, B, phi_t = self.ev.constraints(x + sgn * tau * v, compose(q, sgn * tau * w), t + sgn * tau)
                g.append(phi_t + B @ V)
            rate = (g[0] - g[1]) / (2.0 * tau)
            self.evaluate(x, q, v, w, np.zeros((N, 6)), np.zeros(m), t, True)
        lu = self.factor(self.matrix(x, q, v, w, t, np.zeros(m), (1.0, 0.0, 0.0, ce)))
        solved = self.solve(lu, -r0, -rate) if lu is not None else None
        return solved

    def write_record(self, rec, x, q, v, w, clock, lam, res: Residual) -> None:
        """Fill the output record as the compiled ``write_record`` does: configuration, velocities, energies
        ``[T, U, W, D]``, ``[‖Φ‖, ‖B V + Φ_t‖]`` and λ, from the evaluation ``res`` at the state."""
        m, J = self.ev.masses
        rec.x[:], rec.q[:], rec.v[:], rec.w[:] = x, q, v, w
        T = 0.5 * float(np.sum(m[:, None] * v * v)) + 0.5 * float(np.einsum("na,nab,nb->", w, J, w))
        rec.energy[:] = T, res.U, clock[0]["work"], clock[0]["dissipated"]
        rate = res.phi_t + res.B @ np.hstack([v, w]).ravel()
        rec.constraint[:] = np.linalg.norm(res.phi), np.linalg.norm(rate)
        rec.lam[:] = lam

    def joint_forces(self, res: Residual, lam) -> np.ndarray:
        """``Bᵀλ`` per node (N,6) of the evaluation ``res``."""
        return (res.B.T @ lam).reshape(-1, 6)


class EngineFace:
    """The face of :class:`reference.algorithms.implicit.NewtonSystem` that :mod:`reference.algorithms.linearization` and
    the linearised analyses (:mod:`reference.algorithms.linear`) read — ``evaluate``, ``matrix``,
    ``consistent_accelerations``, ``write_record``, ``work``, ``dof``, ``free`` — over a :class:`Newton`, so that
    they run on the reference path unchanged.  ``work`` holds the last evaluation's ``r``, ``S``, ``F``,
    ``PHI``, ``PHIt``, its joint rows ``Bl`` (m, 12) in the compiled layout (node i's six columns, then node
    j's) and the continuous ``angle`` (``G``, the force elements' forces apart, is zero: the evaluation folds
    them into S)."""

    def __init__(self, nw: Newton):
        self.newton, self.model, self.free, self.n_free = nw, nw.model, nw.free, nw.n_free
        self.dof = np.full(nw.free.size, -1, dtype=np.int64)
        self.dof[nw.index] = np.arange(nw.n_free)
        self.dof = self.dof.reshape(-1, 6)
        N = nw.free.shape[0]
        self.work = _Work(nw)
        self._v = np.zeros((N, 3))

    def mass(self, x=None, q=None) -> sps.csr_matrix:
        """The mass matrix on the free coordinates (constant: lumped masses and body-frame inertias)."""
        return sps.csr_matrix(self.newton.M)[self.newton.index][:, self.newton.index]

    def evaluate(self, x, q, v, w, vd, lam, t, dynamic) -> float:
        """:meth:`Newton.evaluate` into :attr:`work`; returns the strain energy."""
        self._v = v if dynamic else np.zeros_like(v)
        return self.newton.evaluate(x, q, v, w, vd, lam, t, dynamic).U

    def matrix(self, x, q, w, t, lam, cm, cc, ck, ce=None, psi=None):
        """:meth:`Newton.matrix` (the force elements at the velocities of the last :meth:`evaluate`)."""
        ce = 1.0 / ck if ce is None else ce
        return self.newton.matrix(x, q, self._v, w, t, lam, (cm, cc, ck, ce), psi)

    def consistent_accelerations(self, x, q, v, w, t, tau, ce=0.0):
        """:meth:`Newton.consistent_accelerations`; raises :class:`reference.linalg.SingularMatrix`."""
        solved = self.newton.consistent_accelerations(x, q, v, w, t, tau, ce)
        if solved is None:
            raise SingularMatrix("singular [M Bᵀ; B −ε]")
        return solved

    def write_record(self, rec, x, q, v, w, U, clock, lam) -> None:
        """:meth:`Newton.write_record` from the last evaluation (``U`` is its strain energy)."""
        self.newton.write_record(rec, x, q, v, w, clock, lam, self.newton.last)


class _Work:
    """:attr:`EngineFace.work`: the arrays of the Newton system's last evaluation (:attr:`Newton.last`, whoever
    made it), the continuous ``angle`` (the Newton system's own array) and ``G`` (zero)."""

    def __init__(self, nw: Newton):
        self._newton, self.angle = nw, nw.angle
        self.G = np.zeros((nw.free.shape[0], 6))

    r = property(lambda self: self._newton.last.r)
    S = property(lambda self: self._newton.last.S)
    F = property(lambda self: self._newton.last.F)
    PHI = property(lambda self: self._newton.last.phi)
    PHIt = property(lambda self: self._newton.last.phi_t)

    @property
    def Bl(self) -> np.ndarray:
        """The joint rows (m, 12) of the last evaluation: per row node i's six columns of B, then node j's."""
        nw = self._newton
        joints, B = nw.model.joints, nw.last.B.toarray().reshape(nw.m, nw.free.shape[0], 6)
        Bl = np.zeros((nw.m, 12))
        for k in range(joints.i.shape[0]):
            rows = slice(int(joints.row0[k]), int(joints.row0[k]) + int(joints.neq[k]))
            Bl[rows, :6] = B[rows, int(joints.i[k])]
            if joints.j[k] >= 0:
                Bl[rows, 6:] = B[rows, int(joints.j[k])]
        return Bl
