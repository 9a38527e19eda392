"""The force elements' compiled evaluation: measures, forces and energy, dissipation, tangents.

The elements themselves, their measures ``e(x, q)`` with Jacobian ``B_e``, and the
force ``f = −B_eᵀ (k (e − e_0) + c B_e V)`` are described in :mod:`reference.forces`;
their data is the Model's ``force_elements`` group (:class:`reference.state.ForceElements`).
:func:`force_element_forces` is part of every algorithm's generalised forces
(:func:`reference.evaluation.forces.generalized_forces`), :func:`force_element_dissipation`
of the explicit scheme's energy bookkeeping, :func:`force_element_tangent` of the
implicit algorithms' Newton matrix (:mod:`reference.evaluation.tangent`).
"""

from __future__ import annotations

import math

from reference.connector import body_fixed_parts
from reference.forces import POINT_TO_POINT, ROTATIONAL
from reference.generated import forces as generated
from reference.interactions import tf_value
from reference.jit import inlined, kernel
from reference.joints.assembly import GROUND_Q, GROUND_X


@inlined
def _measures(fe, x, q, k, e, B):
    """Measures ``e`` and Jacobian ``B`` (row-major, 12 columns) of element k; returns their number.

    A point-to-point element's generated d becomes ℓ = |d|, a rotational
    element's raw pair (r sin φ, r cos φ) the wrapped angle φ = atan2, with their
    Jacobians by the chain rule; the ground's columns are zeroed.  ``fe`` the Model's ``force_elements``
    group (not the Model: every array of an argument of an inlined function costs two atomic updates).
    """
    i, j = fe.i[k], fe.j[k]
    s_i, s_j, f_i, f_j = body_fixed_parts(fe.par[k])
    kind = fe.kind[k]
    xj, qj = GROUND_X, GROUND_Q
    if j >= 0:
        xj, qj = x[j], q[j]
    m = 6
    if kind == POINT_TO_POINT:
        # generated: d and its Jacobian; here ℓ = |d| and B_ℓ = (d/ℓ)ᵀ B_d
        generated.point_to_point_measures(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, e, B)
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        for col in range(12):
            B[col] = (e[0] * B[col] + e[1] * B[12 + col] + e[2] * B[24 + col]) / length if length > 0.0 else 0.0
        e[0] = length
        m = 1
    elif kind == ROTATIONAL:
        generated.rotational_measures(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, e, B)
        sn, cs = e[0], e[1]
        r2 = sn * sn + cs * cs
        e[0] = math.atan2(sn, cs)
        for col in range(12):
            B[col] = (cs * B[col] - sn * B[12 + col]) / r2
        m = 1
    else:
        generated.bushing_measures(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, e, B)
    if j < 0:
        for r in range(m):
            for col in range(6, 12):
                B[12 * r + col] = 0.0
    return m


@inlined
def _rate(B, r, v, w, i, j):
    """``(B V)_r`` with V = [v_i, ω_i, v_j, ω_j]."""
    acc = 0.0
    for a in range(3):
        acc += B[12 * r + a] * v[i, a] + B[12 * r + 3 + a] * w[i, a]
        if j >= 0:
            acc += B[12 * r + 6 + a] * v[j, a] + B[12 * r + 9 + a] * w[j, a]
    return acc


@inlined
def _spread(B, r, f, i, j, F):
    """``F −= B_rᵀ f`` on nodes i and j (inertial force, body moment)."""
    for a in range(6):
        F[i, a] -= f * B[12 * r + a]
        if j >= 0:
            F[j, a] -= f * B[12 * r + 6 + a]


@inlined
def _continuous(angle, k, raw):
    """The last angle plus the wrapped difference to ``raw``."""
    d = raw - angle[k]
    d -= 2.0 * math.pi * math.floor(d / (2.0 * math.pi) + 0.5)
    return angle[k] + d


@kernel
def force_element_forces(fe, time_functions, x, q, v, w, t, angle, F, F_ext, e, B):
    """Forces of all force elements at one configuration; returns ``(energy, dissipation rate)``.

    Parameters
    ----------
    fe, time_functions : ForceElements, TimeFunctions
        The Model's ``force_elements`` and ``time_functions`` groups (:class:`reference.state.Model`).
    x, q, v, w : arrays (N,3), (N,4), (N,3), (N,3)
        Positions, Euler parameters, inertial and body-frame velocities.
    t : float
        Time [s] (actuator force functions).
    angle : array (F,)
        Continuous angles of the rotational springs, updated in place.
    F : array (N,6)
        The spring and damper forces are **added** (inertial force, body moment).
    F_ext : array (N,6)
        The actuator forces are added here (external loads; may be ``F`` itself).
    e, B : arrays (≥ 6,), (≥ 72,)
        Work arrays.

    Returns
    -------
    energy : float
        ``Σ ½ k (e − e_0)²`` [J].
    dissipation : float
        ``Σ c (B_e V)²`` [W], ≥ 0 (an explicit step books
        :func:`force_element_dissipation` instead).

    Takes 12 parameters: the two Model groups it reads, the configuration and velocities, two outputs and two
    scratch arrays, as :func:`reference.evaluation.forces.model_forces` calls it.
    """
    energy = 0.0
    dissipation = 0.0
    for k in range(fe.kind.shape[0]):
        i, j = fe.i[k], fe.j[k]
        kind = fe.kind[k]
        m = _measures(fe, x, q, k, e, B)
        if kind == ROTATIONAL:
            e[0] = _continuous(angle, k, e[0])
            angle[k] = e[0]
        elif kind == POINT_TO_POINT and e[0] <= 0.0:
            continue  # coincident points: no direction (the deck refuses a zero rest length)
        for r in range(m):
            stretch = e[r] - (fe.rest[k] if m == 1 else 0.0)
            rate = _rate(B, r, v, w, i, j)
            energy += 0.5 * fe.k[k, r] * stretch * stretch
            dissipation += fe.c[k, r] * rate * rate
            _spread(B, r, fe.k[k, r] * stretch + fe.c[k, r] * rate, i, j, F)
        tf = fe.tf[k]
        if tf >= 0:
            _spread(B, 0, tf_value(time_functions.kind[tf], time_functions.par[tf], t), i, j, F_ext)
    return energy, dissipation


@inlined
def force_element_dissipation(model, x, q, v, w, v_new, w_new, e, B):
    """Work rate of the dampers over a kick: ``Σ c (B_e V⁻)·(B_e V̄)``, ``V̄ = ½(V⁻ + V⁺)`` [W].

    The damper force of an explicit step is evaluated at the old velocity V⁻;
    the kinetic energy changes by the kick length times the force times the
    mean velocity V̄, so this is the energy the dampers remove in that step
    (exact for the scheme).
    """
    total = 0.0
    for k in range(model.force_elements.kind.shape[0]):
        damped = False
        for r in range(6):
            damped = damped or model.force_elements.c[k, r] != 0.0
        if not damped:
            continue
        i, j = model.force_elements.i[k], model.force_elements.j[k]
        m = _measures(model.force_elements, x, q, k, e, B)
        for r in range(m):
            old = _rate(B, r, v, w, i, j)
            new = _rate(B, r, v_new, w_new, i, j)
            total += model.force_elements.c[k, r] * old * 0.5 * (old + new)
    return total


@kernel
def force_element_tangent(model, x, q, v, w, angle, k, K, C, e, B, G):
    """Tangent stiffness and damping matrices of force element k (for implicit algorithms).

    ``K`` (12,12) ``= −∂f/∂δ`` and ``C`` (12,12) ``= −∂f/∂V`` of the element's
    generalised force ``f = −Bᵀ s``, ``s = k (e − e0) + c B V``, with respect to
    body-frame increments ``δ = [δx_i, δθ_i, δx_j, δθ_j]`` and velocities
    ``V = [v_i, ω_i, v_j, ω_j]``: ``K = Bᵀ diag(k) B + Bᵀ diag(c) (G·V) + Σ_r s_r G_r``,
    ``C = Bᵀ diag(c) B`` (``G`` the derived tangent of B, derivations/forces.py).
    The ground's rows and columns are zero.  ``e``, ``B``, ``G`` are work arrays
    (≥ 6, ≥ 72, ≥ 864); ``angle`` is read, not updated.

    Takes 12 parameters: the configuration, the element k, the outputs K and C and three scratch arrays the tangent
    assembly allocates once for every force element.
    """
    i, j = model.force_elements.i[k], model.force_elements.j[k]
    s_i, s_j, f_i, f_j = body_fixed_parts(model.force_elements.par[k])
    kind = model.force_elements.kind[k]
    xj, qj = GROUND_X, GROUND_Q
    if j >= 0:
        xj, qj = x[j], q[j]
    if kind == POINT_TO_POINT:
        # chain rule through ℓ = |d|: G_ℓ = (Σ d_k G_k + Σ B_k ⊗ B_k)/ℓ − B_ℓ ⊗ B_ℓ/ℓ
        generated.point_to_point_tangent(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, G)
        generated.point_to_point_measures(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, e, B)
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        for a in range(12):
            bl_a = (e[0] * B[a] + e[1] * B[12 + a] + e[2] * B[24 + a]) / length
            for c in range(12):
                bl_c = (e[0] * B[c] + e[1] * B[12 + c] + e[2] * B[24 + c]) / length
                g = 0.0
                for kk in range(3):
                    g += e[kk] * G[144 * kk + 12 * a + c] + B[12 * kk + a] * B[12 * kk + c]
                G[12 * a + c] = (g - bl_a * bl_c) / length
    elif kind == ROTATIONAL:
        # chain rule through φ = atan2(s, c): G_φ from the tangents of s and c
        generated.rotational_tangent(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, G)
        generated.rotational_measures(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, e, B)
        sn, cs = e[0], e[1]
        r2 = sn * sn + cs * cs
        for a in range(12):
            bphi = (cs * B[a] - sn * B[12 + a]) / r2
            for c in range(12):
                g = (B[12 + c] * B[a] + cs * G[12 * a + c] - B[c] * B[12 + a] - sn * G[144 + 12 * a + c]) / r2
                G[12 * a + c] = g - bphi * 2.0 * (sn * B[c] + cs * B[12 + c]) / r2
    else:
        generated.bushing_tangent(x[i], q[i], xj, qj, s_i, s_j, f_i, f_j, G)
    m = _measures(model.force_elements, x, q, k, e, B)
    if kind == ROTATIONAL:
        e[0] = _continuous(angle, k, e[0])
    K[:, :] = 0.0
    C[:, :] = 0.0
    for r in range(m):
        stretch = e[r] - (model.force_elements.rest[k] if m == 1 else 0.0)
        sr = model.force_elements.k[k, r] * stretch + model.force_elements.c[k, r] * _rate(B, r, v, w, i, j)
        for c in range(12):
            # ∂(B V)_r/∂δ_c = Σ_a G[r, a, c] V_a: the damper force changes with the configuration too
            gv = 0.0
            for a in range(3):
                gv += G[144 * r + 12 * a + c] * v[i, a] + G[144 * r + 12 * (3 + a) + c] * w[i, a]
                if j >= 0:
                    gv += G[144 * r + 12 * (6 + a) + c] * v[j, a] + G[144 * r + 12 * (9 + a) + c] * w[j, a]
            for a in range(12):
                K[a, c] += B[12 * r + a] * (model.force_elements.k[k, r] * B[12 * r + c] + model.force_elements.c[k, r] * gv) \
                    + sr * G[144 * r + 12 * a + c]
                C[a, c] += model.force_elements.c[k, r] * B[12 * r + a] * B[12 * r + c]
    if j < 0:
        for a in range(6, 12):
            for c in range(12):
                K[a, c] = 0.0
                K[c, a] = 0.0
    return m
