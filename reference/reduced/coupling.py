"""Reduced bodies coupled into a model: generalised coordinates, the velocity map, mass, forces and joint rows.

A beam marked ``reduce`` (:mod:`reference.io.deck_reduce`) keeps its nodes in the model and in the
:class:`~reference.state.State` (what every output, joint, load and the section resultants read), but they are
no longer coordinates: each is placed by its body (:meth:`CoupledModel.place`), from the frame's origin ``r``
[m], Euler parameters ``p`` and modal coordinates ``η`` (:class:`BodyState`),

    x_i = r + A (x̄_i + Φt_i η),     q_i = p ⊗ exp(Φr_i η) ⊗ q_i⁰,

with velocities ``V_b = [ṙ (inertial), ω (frame), η̇]``.  The generalised coordinates of the coupled model are the
six of every other node (``[δx, δθ]`` of :mod:`reference.plain.model`) and the ``6 + r`` of each body; the
velocity map ``T`` (6N × n) gives every node's ``[ẋ_i, ω_i]`` (inertial, node frame) from them,

    ẋ_i = ṙ − A ũ_i ω + A Φt_i η̇,     ω_i = A_i⁰ᵀ (ω + Φr_i η̇),     u_i = x̄_i + Φt_i η,

the rows ``G_i`` of :mod:`reference.reduced.invariants` (the node's rotation rate linear in the small relative
rotation, as the linear modes are; ``A_i⁰`` the node's rest rotation, frame to node).  By the chain rule a
joint's rows are ``B T`` and nodal forces ``f`` act as ``Tᵀ f`` (virtual work); the body's inertia is its own
``M_b(p, η)`` with the quadratic-velocity vector ``Q_v`` (:class:`~reference.reduced.body.ReducedBody`), its
elasticity the modal ``K η + D η̇``: the beam's elements are kept in the model for the section resultants only,
with zero stiffness in the evaluation of forces (:func:`stripped`).  A fixed coordinate of a reduced node (a
clamp) becomes a constraint row, ``Φ`` its displacement (translations) or rotation vector (rotations).

:meth:`reference.reduced.registry.Reduced.twin` builds the coupled model of a model whose Domain has reduced
beams.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from reference.generated import rotation_maps as rm
from reference.plain.model import Evaluation
from reference.plain.newton import compose, relative_rotation
from reference.plain.park import cross
from reference.plain.vectorise import plain
from reference.reduced.craig_bampton import rotation_matrices
from reference.rotation import skew

_quat_product = plain(rm.quat_product)


def products(a, b) -> np.ndarray:
    """Row-wise quaternion products ``a[n] ⊗ b[n]`` (n, 4)."""
    out = np.empty((4, a.shape[0]))
    _quat_product(np.ascontiguousarray(a.T), np.ascontiguousarray(b.T), out)
    return out.T.copy()


def stripped(model, nodes) -> object:
    """``model`` with the elements whose nodes are all in ``nodes`` (the reduced beams') given zero stiffness:
    their forces, strain energy and tangent vanish; the modal stiffness stands for them."""
    families = []
    member = np.zeros(model.nodes.mass.shape[0], dtype=bool)
    member[nodes] = True
    for data in model.elements:
        inside = member[data.conn].all(axis=1)
        if inside.any():
            if not hasattr(data, "stiff"):
                raise ValueError(f"reduce: element family {type(data).__name__} has no section stiffness to "
                                 "replace by modes; reduce a beam of another family")
            data = data._replace(stiff=np.where(inside[:, None], 0.0, data.stiff))
        families.append(data)
    return model._replace(elements=tuple(families))


@dataclass
class BodyState:
    """One reduced body's configuration and velocities: ``r`` (3,) [m], ``p`` (4,) Euler parameters, ``eta``
    (r,) modal coordinates, ``V`` (6 + r,) ``[ṙ, ω, η̇]`` (the half-step velocities of the explicit scheme)."""

    r: np.ndarray
    p: np.ndarray
    eta: np.ndarray
    V: np.ndarray

    def copy(self) -> "BodyState":
        return BodyState(self.r.copy(), self.p.copy(), self.eta.copy(), self.V.copy())


class CoupledModel:
    """A model whose reduced beams move as reduced bodies (module docstring).

    Attributes
    ----------
    model : Model
    bodies : list of ReducedBody
    members : list of ndarray
        Each body's node ids, in the beam's order.
    others : ndarray
        The ids of the nodes that keep their own six coordinates.
    ev : Evaluation
        The forces, joints and tangent of the :func:`stripped` model.
    size : int
        The number of generalised coordinates.
    offsets : list of int
        Where each body's ``6 + r`` coordinates start.
    free : ndarray of bool (size,)
        False at a fixed coordinate of another node (a reduced body's coordinates are all free).
    """

    def __init__(self, model, domain, bodies: dict) -> None:
        self.model, self.labels = model, tuple(bodies)
        self.bodies = [b for b, _ in bodies.values()]
        self.members = [np.asarray(n, dtype=np.int64) for _, n in bodies.values()]
        N = model.nodes.mass.shape[0]
        reduced = np.concatenate(self.members)
        mask = np.zeros(N, dtype=bool)
        mask[reduced] = True
        self.others = np.flatnonzero(~mask)
        self.ev = Evaluation(stripped(model, reduced))
        self.x0 = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3)
        self.q0 = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4)
        self.rest_rotations = [rotation_matrices(self.q0[ids]) for ids in self.members]
        self.offsets, start = [], 6 * self.others.size
        for body in self.bodies:
            self.offsets.append(start)
            start += 6 + body.n_modes
        self.size = start
        self.free = np.ones(self.size, dtype=bool)
        self.free[:6 * self.others.size] = model.nodes.free[self.others].ravel() > 0.5
        fixed = model.nodes.free[reduced] < 0.5
        self.supports = np.argwhere(fixed)  # (k, 2): position in `reduced`, coordinate
        self.support_nodes = reduced[self.supports[:, 0]] if len(self.supports) else np.zeros(0, dtype=np.int64)

    def initial(self, state) -> list[BodyState]:
        """Each body at rest shape (η = 0), its frame at the beam's centre of mass with the inertial axes, its
        velocities the nearest to the nodes' initial ones (:func:`reference.reduced.body.nearest_velocities`)."""
        from reference.reduced.body import nearest_velocities

        out = []
        for body, ids, R0 in zip(self.bodies, self.members, self.rest_rotations):
            V = np.hstack([state.v[ids], np.einsum("nab,nb->na", R0, state.w[ids])])
            out.append(BodyState(body.inv.origin.copy(), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(body.n_modes),
                                 nearest_velocities(body, V)))
        return out

    def place(self, bodies: list[BodyState], state, velocities: bool = True) -> None:
        """Set the reduced nodes' ``x``, ``q`` (and ``v``, ``w``) in ``state`` from the bodies (module
        docstring), in place."""
        for body, ids, R0, b in zip(self.bodies, self.members, self.rest_rotations, bodies):
            A = rotation_matrices(b.p[None])[0]
            u = body.rest + body.Pt @ b.eta
            state.x[ids] = b.r + u @ A.T
            turned = compose(np.repeat(b.p[None], len(ids), axis=0), body.Pr @ b.eta)
            state.q[ids] = products(turned, self.q0[ids])
            if velocities:
                rd, w, ed = b.V[:3], b.V[3:6], b.V[6:]
                state.v[ids] = rd + (cross(np.broadcast_to(w, u.shape), u) + body.Pt @ ed) @ A.T
                state.w[ids] = np.einsum("nba,nb->na", R0, w + body.Pr @ ed)

    def velocity_map(self, bodies: list[BodyState]) -> sp.csr_matrix:
        """``T`` (6N, size): every node's ``[ẋ, ω]`` from the generalised velocities (module docstring)."""
        N = self.model.nodes.mass.shape[0]
        rows, cols, vals = [], [], []
        k = 6 * self.others.size
        rows.append((6 * self.others[:, None] + np.arange(6)).ravel())
        cols.append(np.arange(k))
        vals.append(np.ones(k))
        for body, ids, R0, b, start in zip(self.bodies, self.members, self.rest_rotations, bodies, self.offsets):
            A = rotation_matrices(b.p[None])[0]
            u = body.rest + body.Pt @ b.eta
            for a, node in enumerate(ids):
                G = np.zeros((6, 6 + body.n_modes))
                G[:3, :3] = np.eye(3)
                G[:3, 3:6] = -A @ skew(u[a])
                G[:3, 6:] = A @ body.Pt[a]
                G[3:, 3:6] = R0[a].T
                G[3:, 6:] = R0[a].T @ body.Pr[a]
                r, c = np.nonzero(G)
                rows.append(6 * node + r)
                cols.append(start + c)
                vals.append(G[r, c])
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(6 * N, self.size))

    def gather(self, state, bodies: list[BodyState]) -> np.ndarray:
        """The generalised velocities (size,) of ``state`` (other nodes) and ``bodies``."""
        V = [np.hstack([state.v[self.others], state.w[self.others]]).ravel()]
        return np.concatenate(V + [b.V for b in bodies])

    def scatter(self, V, state, bodies: list[BodyState]) -> None:
        """Put the generalised velocities ``V`` back into ``state`` (other nodes) and ``bodies``, in place."""
        k = 6 * self.others.size
        own = V[:k].reshape(-1, 6)
        state.v[self.others], state.w[self.others] = own[:, :3], own[:, 3:]
        for b, start in zip(bodies, self.offsets):
            b.V[:] = V[start:start + b.V.size]

    def mass(self, bodies: list[BodyState]) -> sp.csr_matrix:
        """The generalised mass matrix (size, size): ``m I``, ``J`` per other node, ``M_b(p, η)`` per body."""
        m, J = self.ev.masses
        blocks = []
        for n in self.others:
            block = np.zeros((6, 6))
            block[:3, :3] = m[n] * np.eye(3)
            block[3:, 3:] = J[n]
            blocks.append(block)
        blocks += [body.mass_matrix(b.p, b.eta) for body, b in zip(self.bodies, bodies)]
        return sp.block_diag(blocks, format="csr") if blocks else sp.csr_matrix((0, 0))

    def _linear_stiffness(self, k: int, b: BodyState) -> np.ndarray:
        """``K_ff``, plus with ``stiffening`` the stress stiffness ``Σ ω_a ω_b 𝕂_ab`` at the frame's spin ω
        (:func:`reference.reduced.stiffening.spin_stiffness`)."""
        body = self.bodies[k]
        if body.spin_stiffness is None:
            return body.K
        w = b.V[3:6]
        return body.K + np.einsum("a,b,abkl->kl", w, w, body.spin_stiffness)

    def elastic(self, k: int, b: BodyState) -> np.ndarray:
        """Body ``k``'s modal elastic force in state ``b``: ``K η`` (:meth:`_linear_stiffness`), plus with
        ``second_order`` ``½ K₃ : η η`` (:func:`reference.reduced.stiffening.modal_third_derivatives`) and with
        ``third_order`` ``⅙ K₄ ⋮ η η η`` (:func:`reference.reduced.stiffening.modal_fourth_derivatives`)."""
        f = self._linear_stiffness(k, b) @ b.eta
        body = self.bodies[k]
        if body.cubic is not None:
            f = f + 0.5 * np.einsum("ijk,j,k->i", body.cubic, b.eta, b.eta)
        if body.quartic is not None:
            f = f + np.einsum("ijkl,j,k,l->i", body.quartic, b.eta, b.eta, b.eta) / 6.0
        return f

    def modal_stiffness(self, k: int, b: BodyState) -> np.ndarray:
        """The tangent of :meth:`elastic` in η: ``K (+ K₃ · η) (+ ½ K₄ : η η)``."""
        K = self._linear_stiffness(k, b)
        body = self.bodies[k]
        if body.cubic is not None:
            K = K + np.einsum("ijk,k->ij", body.cubic, b.eta)
        if body.quartic is not None:
            K = K + 0.5 * np.einsum("ijkl,k,l->ij", body.quartic, b.eta, b.eta)
        return K

    def inertial(self, bodies: list[BodyState], V) -> np.ndarray:
        """The velocity-dependent forces (size,) that the generalised accelerations balance, with their sign
        in ``M V̇ = Q − inertial``: the other nodes' gyroscopic ``ω × J ω`` and each body's ``Q_v`` and modal
        ``K η + D η̇``, all at the velocities ``V``; plus the mass-proportional damping ``c M V``."""
        out = np.zeros(self.size)
        J = self.ev.masses[1]
        k = 6 * self.others.size
        w = V[:k].reshape(-1, 6)[:, 3:]
        out[:k].reshape(-1, 6)[:, 3:] = cross(w, np.einsum("nab,nb->na", J[self.others], w))
        for i, (body, b, start) in enumerate(zip(self.bodies, bodies, self.offsets)):
            Vb = V[start:start + 6 + body.n_modes]
            Q = body.quadratic_velocity(b.p, b.eta, Vb[3:6], Vb[6:])
            Q[6:] += self.elastic(i, b) + body.D @ Vb[6:]
            out[start:start + Q.size] = Q
        if self.ev.damping:
            out += self.ev.damping * (self.mass(bodies) @ V)
        return out

    def strain(self, bodies: list[BodyState]) -> float:
        """The bodies' modal strain energy ``Σ ½ ηᵀ K η (+ ⅙ K₃ ⋮ η η η) (+ ¹⁄₂₄ K₄ ⋮ η η η η)`` [J] (the stripped
        model's elements give the rest)."""
        total = 0.0
        for i, b in enumerate(bodies):
            total += 0.5 * b.eta @ self._linear_stiffness(i, b) @ b.eta
            if self.bodies[i].cubic is not None:
                total += np.einsum("ijk,i,j,k->", self.bodies[i].cubic, b.eta, b.eta, b.eta) / 6.0
            if self.bodies[i].quartic is not None:
                total += np.einsum("ijkl,i,j,k,l->", self.bodies[i].quartic, b.eta, b.eta, b.eta, b.eta) / 24.0
        return float(total)

    def constraints(self, state, bodies: list[BodyState], T) -> tuple:
        """``(Φ, B T, Φ_t, ε)`` of the joints (the model's m rows first) and of the fixed coordinates of the
        reduced nodes (module docstring), ``T`` the :meth:`velocity_map`."""
        m = self.ev.n_constraints
        if m:
            phi, B, phi_t = self.ev.constraints(state.x, state.q, state.t)
        else:
            phi, B, phi_t = np.zeros(0), sp.csr_matrix((0, T.shape[0])), np.zeros(0)
        eps = self.ev.eps
        if len(self.supports):
            nodes, coord = self.support_nodes, self.supports[:, 1]
            moved = np.hstack([state.x[nodes] - self.x0[nodes], relative_rotation(self.q0[nodes], state.q[nodes])])
            phi = np.concatenate([phi, moved[np.arange(len(nodes)), coord]])
            rows = sp.csr_matrix((np.ones(len(nodes)), (np.arange(len(nodes)), 6 * nodes + coord)),
                                 shape=(len(nodes), T.shape[0]))
            B = sp.vstack([B, rows]).tocsr()
            phi_t = np.concatenate([phi_t, np.zeros(len(nodes))])
            eps = np.concatenate([eps, np.zeros(len(nodes))])
        return phi, (B @ T).tocsr(), phi_t, eps

    def recorded(self, bodies: list[BodyState]) -> dict:
        """The record's datasets of the bodies: ``reduced/<label>/modal_coordinates`` (r,) and
        ``reduced/<label>/frame_position`` (3,) [m], ``reduced/<label>/frame_rotation`` (4,)."""
        out = {}
        for label, b in zip(self.labels, bodies):
            out[f"reduced/{label}/modal_coordinates"] = b.eta.copy()
            out[f"reduced/{label}/frame_position"] = b.r.copy()
            out[f"reduced/{label}/frame_rotation"] = b.p.copy()
        return out
