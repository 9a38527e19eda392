"""Generalised forces of the model at a configuration and time (the right-hand side of eq. (5)).

Per node (N, 6): an inertial force and a body-frame moment.  The internal forces
``S`` are those of every element family (:func:`reference.elements.families.assemble_forces`)
and of the force elements' springs and dampers (:mod:`reference.forces`, subtracted:
they act on the bodies like internal forces and their energy is strain energy); the
external forces ``F`` are the loads (dead and follower forces and moments, times their
time functions), gravity and the force elements' actuators (their work is external work).
"""

from __future__ import annotations

from reference.elements.families import assemble_forces
from reference.evaluation.force_elements import force_element_forces
from reference.generated import rotation_maps as rm
from reference.interactions import tf_value
from reference.jit import inlined, kernel
from reference.parallel import PARALLEL_NODES, reset_forces


@inlined
def external_forces(model, x, q, t, F, A):
    """External generalised forces at time t into ``F`` (N,6): inertial force, body moment.

    A force applied at a body-fixed point (``model.loads.arm`` ≠ 0) adds its
    moment ``arm × force`` (body frame) about the node.
    """
    _gravity(model.nodes.mass, model.gravity, F)
    add_loads(model.loads, model.time_functions, q, t, F, A)


@inlined
def _gravity(mass, gravity, F):
    """``F`` = the nodes' weights ``m g`` (inertial forces, no moments)."""
    g0, g1, g2 = gravity[0], gravity[1], gravity[2]
    for i in range(F.shape[0]):
        F[i, 0], F[i, 1], F[i, 2] = mass[i] * g0, mass[i] * g1, mass[i] * g2
        F[i, 3], F[i, 4], F[i, 5] = 0.0, 0.0, 0.0


@inlined
def add_loads(loads, time_functions, q, t, F, A):
    """Add the loads at time t into ``F`` (N, 6) (:func:`external_forces` without gravity; one load after
    the other, serial: two may act on one node).  ``loads``, ``time_functions``: the Model's groups."""
    for l in range(loads.node.shape[0]):
        i = loads.node[l]
        j = loads.tf[l]
        f = tf_value(time_functions.kind[j], time_functions.par[j], t)
        code = loads.code[l]
        vec = loads.vec[l]
        if code == 0:
            for k in range(3):
                F[i, k] += f * vec[k]
        elif code == 3:
            for k in range(3):
                F[i, 3 + k] += f * vec[k]
        else:
            rm.rotation_matrix(q[i], A)
            if code == 1:  # follower force: inertial = A f_body
                for k in range(3):
                    F[i, k] += f * (A[3 * k] * vec[0] + A[3 * k + 1] * vec[1] + A[3 * k + 2] * vec[2])
            else:  # dead moment: body = A^T M
                for k in range(3):
                    F[i, 3 + k] += f * (A[k] * vec[0] + A[3 + k] * vec[1] + A[6 + k] * vec[2])
        arm = loads.arm[l]
        if code <= 1 and (arm[0] != 0.0 or arm[1] != 0.0 or arm[2] != 0.0):
            if code == 0:  # body components of the dead force
                rm.rotation_matrix(q[i], A)
                b0 = f * (A[0] * vec[0] + A[3] * vec[1] + A[6] * vec[2])
                b1 = f * (A[1] * vec[0] + A[4] * vec[1] + A[7] * vec[2])
                b2 = f * (A[2] * vec[0] + A[5] * vec[1] + A[8] * vec[2])
            else:
                b0, b1, b2 = f * vec[0], f * vec[1], f * vec[2]
            F[i, 3] += arm[1] * b2 - arm[2] * b1
            F[i, 4] += arm[2] * b0 - arm[0] * b2
            F[i, 5] += arm[0] * b1 - arm[1] * b0


@kernel
def generalized_forces(model, element_work, x, q, v, w, t, S, F, G, angle, A, fe_phi, fe_B):
    """Internal forces into ``S`` and external forces into ``F`` (N, 6) at time t; returns
    ``(U, D)``: the strain energy of the elements and springs [J] and the power of the force
    elements' dampers ``Σ c (B_e V)²`` [W] at the velocities ``v``, ``w`` (N, 3; ω body frame).

    ``element_work`` the element families' work arrays (:func:`reference.state.element_work`);
    ``G`` (N, 6) receives the force elements' forces; ``angle`` (F,) the rotational springs'
    continuous angles, carried on (:mod:`reference.forces`); ``A`` (9,), ``fe_phi``, ``fe_B``
    scratch (at least 6 and 72 entries).  The algorithms' kernels inline :func:`model_forces`.

    Takes 14 parameters: the compiled entry from Python of :func:`model_forces`, given the Model, the state's
    arrays, three outputs and the scratch.
    """
    return model_forces(model.nodes.mass, model.gravity, model.loads, model.time_functions, model.elements,
                        model.force_elements, element_work, x, q, v, w, t, S, F, G, angle, A, fe_phi, fe_B)


@inlined
def model_forces(mass, gravity, loads, time_functions, elements, force_elements, element_work, x, q, v, w, t, S, F,
                 G, angle, A, fe_phi, fe_B):
    """:func:`generalized_forces` of the Model's groups (``model.nodes.mass``, ``model.gravity``, ``model.loads``,
    ``model.time_functions``, ``model.elements``, ``model.force_elements``): the form an algorithm's kernel
    inlines.  Not the Model itself: an inlined function's argument costs two atomic reference-count updates
    per array in it, each call (:mod:`reference.jit`), and the Model has some seventy arrays.

    Takes 19 parameters: the six Model groups it reads (not the Model, above), the state's arrays, three outputs and
    the scratch.
    """
    N = x.shape[0]
    if N >= PARALLEL_NODES:  # the same numbers, node by node in parallel
        reset_forces(S, F, mass, gravity[0], gravity[1], gravity[2])
    else:
        for i in range(N):
            for a in range(6):
                S[i, a] = 0.0
        _gravity(mass, gravity, F)
    if loads.node.shape[0] > 0:
        add_loads(loads, time_functions, q, t, F, A)
    U = assemble_forces(elements, element_work, x, q, S)
    D = 0.0
    if force_elements.kind.shape[0] > 0:
        # springs and dampers act like internal forces (S −= their force; energy in U), their
        # actuators like external loads (into F)
        for i in range(N):
            for a in range(6):
                G[i, a] = 0.0
        U_fe, D = force_element_forces(force_elements, time_functions, x, q, v, w, t, angle, G, F, fe_phi, fe_B)
        U += U_fe
        for i in range(N):
            for a in range(6):
                S[i, a] -= G[i, a]
    return U, D
