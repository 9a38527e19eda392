"""Gravity, loads and force elements in NumPy: the external forces and the springs of the reference path.

The twin of :func:`reference.evaluation.forces.external_forces` and
:mod:`reference.evaluation.force_elements`, with the same generated physics
(``reference/generated/forces.py``, ``tangents.py``, ``rotation_maps.py``, derived in
``derivations/forces.py``, ``derivations/tangents.py``) called on all items at once through
:func:`reference.plain.vectorise.plain` (structure-of-arrays: an argument ``x`` of shape
(3, K) holds the K items' vectors, ``x[0]`` their first components).

Conventions: :mod:`reference.plain.model`.  A force element's generalised force is
``f = −B_eᵀ (k (e − e_0) + c B_e V)`` on ``[v_i, ω_i, v_j, ω_j]`` (:mod:`reference.forces`);
its spring and damper forces act like internal forces (the caller subtracts them from S), its
actuator force ``−B_ℓᵀ f_a(t)`` is an external load.
"""

from __future__ import annotations


import numpy as np

from reference.connector import body_fixed_parts
from reference.forces import POINT_TO_POINT, ROTATIONAL
from reference.generated import forces as generated_forces
from reference.generated import rotation_maps as rm
from reference.generated import tangents as generated_tangents
from reference.interactions import tf_value
from reference.plain.vectorise import plain
from reference.scalar import scalar_twin

DEAD_FORCE, FOLLOWER_FORCE, DEAD_MOMENT, FOLLOWER_MOMENT = 0, 1, 2, 3
"""Load codes (:class:`reference.state.Loads`)."""

_MEASURES = {POINT_TO_POINT: generated_forces.point_to_point_measures,
             ROTATIONAL: generated_forces.rotational_measures}
_TANGENTS = {POINT_TO_POINT: generated_forces.point_to_point_tangent,
             ROTATIONAL: generated_forces.rotational_tangent}
_ROWS = {POINT_TO_POINT: 3, ROTATIONAL: 2}
"""Rows of the generated measures of each kind (the bushing's six otherwise)."""


def time_functions_at(time_functions, t, which=tf_value):
    """The values (T,) at time t [s] of every time function (``which``: :func:`~reference.interactions.tf_value`,
    ``tf_derivative`` or ``tf_integral``), one :func:`scalar_twin` call each (they branch on the kind)."""
    f = scalar_twin(which)
    return np.array([f(kind, par, float(t)) for kind, par in zip(time_functions.kind, time_functions.par)],
                    dtype=float)


def rotation_matrices(q):
    """``A(q)`` (K,3,3) body → inertial of the Euler parameters ``q`` (K,4) (generated ``rotation_matrix``)."""
    out = np.empty((9, q.shape[0]))
    plain(rm.rotation_matrix)(q.T, out)
    return out.T.reshape(-1, 3, 3)


def external_forces(model, q, t):
    """Gravity and the loads at time t: ``F`` (N,6) [inertial force, body moment], as
    :func:`reference.evaluation.forces.external_forces` (actuators: :func:`force_element_forces`).

    A load's vector times its time function is a force's inertial components (a dead force), or its
    body-frame ones (a follower force: ``A f``); a moment's body-frame components (a follower moment), or
    its inertial ones (a dead moment: ``Aᵀ M``).  A force at a body-fixed arm adds ``arm × f_body``."""
    mass = model.nodes.mass
    F = np.zeros((mass.shape[0], 6))
    F[:, :3] = mass[:, None] * model.gravity
    loads = model.loads
    if loads.node.shape[0] == 0:
        return F
    code = loads.code[:, None]
    f = time_functions_at(model.time_functions, t)[loads.tf][:, None] * loads.vec
    A = rotation_matrices(q[loads.node])
    A_f, At_f = np.einsum("kab,kb->ka", A, f), np.einsum("kba,kb->ka", A, f)
    force = np.where(code == FOLLOWER_FORCE, A_f, f)
    arm_moment = np.cross(loads.arm, np.where(code == DEAD_FORCE, At_f, f))
    moment = np.where(code == DEAD_MOMENT, At_f, f)
    is_force = code <= FOLLOWER_FORCE
    per_load = np.concatenate([np.where(is_force, force, 0.0), np.where(is_force, arm_moment, moment)], axis=1)
    np.add.at(F, loads.node, per_load)  # load after load, in the deck's order (two may act on one node)
    return F


def load_tangent(model, q, t):
    """``−∂F/∂δθ`` (N,6,6) per node of the configuration-dependent loads: follower forces (generated
    ``follower_force_tangent``) and dead moments (``dead_moment_tangent``), as
    :func:`reference.evaluation.tangent.load_tangent`."""
    loads = model.loads
    K = np.zeros((model.nodes.mass.shape[0], 6, 6))
    turning = np.flatnonzero((loads.code == FOLLOWER_FORCE) | (loads.code == DEAD_MOMENT))
    if turning.size == 0:
        return K
    f = time_functions_at(model.time_functions, t)[loads.tf[turning]]
    T9 = np.empty((2, 9, turning.size))
    nodes = loads.node[turning]
    plain(generated_tangents.follower_force_tangent)(q[nodes].T, loads.vec[turning].T, T9[0])
    plain(generated_tangents.dead_moment_tangent)(q[nodes].T, loads.vec[turning].T, T9[1])
    for k, load in enumerate(turning):
        moment = loads.code[load] == DEAD_MOMENT
        r0 = 3 if moment else 0
        K[nodes[k], r0:r0 + 3, 3:] -= f[k] * T9[int(moment), :, k].reshape(3, 3)
    return K


def gyroscopic_tangents(J, w):
    """``∂(ω × J ω)/∂ω`` (N,3,3) per node, ω (N,3) body frame (generated ``gyroscopic_tangent``)."""
    out = np.empty((9, w.shape[0]))
    plain(generated_tangents.gyroscopic_tangent)(J.reshape(-1, 9).T, w.T, out)
    return out.T.reshape(-1, 3, 3)


def _ends(fe, x, q, ks):
    """The generated measures' first eight arguments for the force elements ``ks`` (structure of arrays,
    the ground's position and identity rotation where ``j = −1``)."""
    j = fe.j[ks]
    ground = (j < 0)[:, None]
    xj = np.where(ground, 0.0, x[np.maximum(j, 0)])
    qj = np.where(ground, np.array([1.0, 0.0, 0.0, 0.0]), q[np.maximum(j, 0)])
    par = fe.par[ks]
    return (x[fe.i[ks]].T, q[fe.i[ks]].T, xj.T, qj.T, *plain(body_fixed_parts)(par.T))


def measures(fe, x, q, angle):
    """Every force element's measures and their Jacobian, kind by kind.

    Returns a list of ``(ks, e, B)``: the elements ``ks`` of one kind, their measures e (K, m) and
    Jacobians B (K, m, 12) on ``[v_i, ω_i, v_j, ω_j]`` (the ground's columns zero), as
    :func:`reference.evaluation.force_elements._measures`: a point-to-point element's distance
    ``ℓ = |d|`` with ``B_ℓ = (d/ℓ)ᵀ B_d``, a rotational element's angle ``φ = atan2(s, c)``
    continued from ``angle`` (written back in place), a bushing's six measures as generated.
    """
    groups = []
    for kind in np.unique(fe.kind):
        ks = np.flatnonzero(fe.kind == kind)
        rows = _ROWS.get(int(kind), 6)
        e, B = np.empty((rows, ks.size)), np.empty((12 * rows, ks.size))
        plain(_MEASURES.get(int(kind), generated_forces.bushing_measures))(*_ends(fe, x, q, ks), e, B)
        e, B = e.T, B.T.reshape(ks.size, rows, 12)
        if kind == POINT_TO_POINT:
            length = np.sqrt(np.sum(e * e, axis=1))
            unit = np.divide(e, length[:, None], out=np.zeros_like(e), where=length[:, None] > 0.0)
            e, B = length[:, None], np.einsum("ka,kac->kc", unit, B)[:, None, :]
        elif kind == ROTATIONAL:
            sn, cs = e[:, 0], e[:, 1]
            r2 = (sn * sn + cs * cs)[:, None]
            B = ((cs[:, None] * B[:, 0] - sn[:, None] * B[:, 1]) / r2)[:, None, :]
            raw = np.arctan2(sn, cs)
            d = raw - angle[ks]
            d -= 2.0 * np.pi * np.floor(d / (2.0 * np.pi) + 0.5)
            angle[ks] += d
            e = angle[ks][:, None].copy()
        B[fe.j[ks] < 0, :, 6:] = 0.0
        groups.append((ks, e, B))
    return groups


def _velocities(fe, v, w, ks):
    """``V = [v_i, ω_i, v_j, ω_j]`` (K,12) of the force elements ``ks`` (zero for the ground)."""
    j = fe.j[ks]
    Vj = np.where((j < 0)[:, None], 0.0, np.concatenate([v, w], axis=1)[np.maximum(j, 0)])
    return np.concatenate([v[fe.i[ks]], w[fe.i[ks]], Vj], axis=1)


def _spread(fe, ks, f, out):
    """``out −= B_eᵀ s`` given ``f = B_eᵀ s`` (K,12): add the elements' ``−f`` to nodes i and j, element by
    element in order (as the compiled evaluation)."""
    for k, e in enumerate(ks):
        out[fe.i[e]] -= f[k, :6]
        if fe.j[e] >= 0:
            out[fe.j[e]] -= f[k, 6:]


def force_element_forces(model, x, q, v, w, t, angle):
    """The force elements' forces, as :func:`reference.evaluation.force_elements.force_element_forces`.

    Returns
    -------
    G : ndarray (N,6)
        The spring and damper forces ``−B_eᵀ (k (e − e_0) + c B_e V)`` (the caller subtracts G from S).
    Fa : ndarray (N,6)
        The actuator forces ``−B_ℓᵀ f_a(t)`` (external loads).
    U, D : float
        ``Σ ½ k (e − e_0)²`` [J] and ``Σ c (B_e V)²`` [W].

    ``angle`` (F,): the rotational elements' continuous angles, continued in place.
    """
    fe = model.force_elements
    N = x.shape[0]
    G, Fa = np.zeros((N, 6)), np.zeros((N, 6))
    U = D = 0.0
    tf_values = time_functions_at(model.time_functions, t)
    for ks, e, B in measures(fe, x, q, angle):
        live = ~((fe.kind[ks] == POINT_TO_POINT) & (e[:, 0] <= 0.0))  # coincident points: no direction
        ks, e, B = ks[live], e[live], B[live]
        m = e.shape[1]
        stretch = e - (fe.rest[ks][:, None] if m == 1 else 0.0)
        rate = np.einsum("krc,kc->kr", B, _velocities(fe, v, w, ks))
        k, c = fe.k[ks, :m], fe.c[ks, :m]
        U += float(np.sum(0.5 * k * stretch * stretch))
        D += float(np.sum(c * rate * rate))
        _spread(fe, ks, np.einsum("krc,kr->kc", B, k * stretch + c * rate), G)
        acting = fe.tf[ks] >= 0
        _spread(fe, ks[acting], B[acting, 0] * tf_values[fe.tf[ks[acting]]][:, None], Fa)
    return G, Fa, U, D


def force_element_dissipation(model, x, q, v, w, v_new, w_new):
    """``Σ c (B_e V⁻)·(B_e V̄)``, ``V̄ = ½(V⁻ + V⁺)`` [W] over the damped force elements (the energy their
    dampers remove in an explicit kick, :func:`reference.evaluation.force_elements.force_element_dissipation`)."""
    fe = model.force_elements
    total = 0.0
    for ks, e, B in measures(fe, x, q, np.zeros(fe.kind.shape[0])):  # B does not depend on the angles
        m = e.shape[1]
        c = fe.c[ks, :m]
        old = np.einsum("krc,kc->kr", B, _velocities(fe, v, w, ks))
        new = np.einsum("krc,kc->kr", B, _velocities(fe, v_new, w_new, ks))
        total += float(np.sum(c * old * 0.5 * (old + new)))
    return total


def _measure_tangents(fe, x, q, ks, kind, e_raw, B_raw):
    """``G`` (K, m, 12, 12): ``G[k, r, a, c] = ∂(B_e)_{ra}/∂δ_c`` of the elements ``ks`` of one kind, by the
    chain rule through ``ℓ = |d|`` or ``φ = atan2(s, c)`` from the generated tangents of the raw measures
    ``e_raw`` (K, rows), ``B_raw`` (K, rows, 12) (:func:`reference.evaluation.force_elements.force_element_tangent`)."""
    rows = B_raw.shape[1]
    G = np.empty((144 * rows, ks.size))
    plain(_TANGENTS.get(int(kind), generated_forces.bushing_tangent))(*_ends(fe, x, q, ks), G)
    G = G.T.reshape(ks.size, rows, 12, 12)
    if kind == POINT_TO_POINT:
        length = np.sqrt(np.sum(e_raw * e_raw, axis=1))[:, None, None]
        bl = np.einsum("kr,kra->ka", e_raw, B_raw) / length[:, :, 0]
        g = np.einsum("kr,krac->kac", e_raw, G) + np.einsum("kra,krc->kac", B_raw, B_raw)
        return ((g - bl[:, :, None] * bl[:, None, :]) / length)[:, None]
    if kind == ROTATIONAL:
        sn, cs = e_raw[:, 0, None, None], e_raw[:, 1, None, None]
        B0, B1 = B_raw[:, 0], B_raw[:, 1]
        r2 = sn * sn + cs * cs
        bphi = (cs[:, :, 0] * B0 - sn[:, :, 0] * B1) / r2[:, :, 0]
        g = (B0[:, :, None] * B1[:, None, :] + cs * G[:, 0] - B1[:, :, None] * B0[:, None, :] - sn * G[:, 1]) / r2
        return (g - bphi[:, :, None] * 2.0 * (sn * B0[:, None, :] + cs * B1[:, None, :]) / r2)[:, None]
    return G


def force_element_tangents(model, x, q, v, w, t, angle):
    """Tangent stiffness and damping of every force element, as
    :func:`reference.evaluation.force_elements.force_element_tangent` plus the actuator term of
    :func:`reference.evaluation.tangent._force_element_blocks`.

    ``K = −∂f/∂δ = Bᵀ diag(k) B + Bᵀ diag(c) (G·V) + Σ_r s_r G_r + f_a(t) G_ℓ`` and
    ``C = −∂f/∂V = Bᵀ diag(c) B``
    at the velocities ``v``, ``w`` and the angles continued from ``angle`` (read, not updated).

    Returns
    -------
    nodes : ndarray (F, 2)
        ``[i, j]`` of each element (−1 the ground: its rows and columns of K and C are zero).
    K, C : ndarray (F, 12, 12)
        On ``[δx_i, δθ_i, δx_j, δθ_j]``.
    """
    fe = model.force_elements
    nF = fe.kind.shape[0]
    K, C = np.zeros((nF, 12, 12)), np.zeros((nF, 12, 12))
    tf_values = time_functions_at(model.time_functions, t)
    for ks, e, B in measures(fe, x, q, angle.copy()):
        kind = int(fe.kind[ks[0]])
        rows = _ROWS.get(kind, 6)
        e_raw, B_raw = np.empty((rows, ks.size)), np.empty((12 * rows, ks.size))
        plain(_MEASURES.get(kind, generated_forces.bushing_measures))(*_ends(fe, x, q, ks), e_raw, B_raw)
        G = _measure_tangents(fe, x, q, ks, kind, e_raw.T, B_raw.T.reshape(ks.size, rows, 12))
        m = e.shape[1]
        k, c = fe.k[ks, :m], fe.c[ks, :m]
        V = _velocities(fe, v, w, ks)
        s = k * (e - (fe.rest[ks][:, None] if m == 1 else 0.0)) + c * np.einsum("krc,kc->kr", B, V)
        gv = np.einsum("krac,ka->krc", G, V)
        K[ks] = (np.einsum("kra,krc->kac", B, k[:, :, None] * B + c[:, :, None] * gv)
                 + np.einsum("kr,krac->kac", s, G))
        C[ks] = np.einsum("kra,kr,krc->kac", B, c, B)
        acting = np.flatnonzero(fe.tf[ks] >= 0)
        K[ks[acting]] += tf_values[fe.tf[ks[acting]]][:, None, None] * G[acting, 0]
    ground = fe.j < 0
    K[ground, 6:, :] = 0.0
    K[ground, :, 6:] = 0.0
    return np.stack([fe.i, fe.j], axis=1), K, C
