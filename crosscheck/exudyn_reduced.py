"""A deck's reduced beams in Exudyn (1.13) as ``ObjectFFRFreducedOrder`` bodies, from flexmbs's own modes (issue 39).

flexmbs reduces a beam to a floating frame and a few modes (:mod:`reference.reduced`); Exudyn has the same
formulation, the floating frame of reference with modal reduction of Zwölfer & Gerstmayr (Acta Mech. 232 (2021)
1261), as ``ObjectFFRFreducedOrder``: a ``NodeRigidBodyEP`` for the frame, a ``NodeGenericODE2`` for the modal
coordinates, the modes' translational rows and a set of inertia constants.  :func:`exudyn_parameters` writes
flexmbs's :class:`~reference.reduced.invariants.Invariants` in Exudyn's layout (``ã`` the skew matrix of ``a``;
``φ_ik`` column k of node i's translational rows ``Φt_i``, ``m_i`` its lumped mass, ``x̄_i`` its rest position in
the frame; ``Σ`` over the nodes):

==========================  ==========================  =========================================================
Exudyn parameter            its definition              flexmbs's invariant
==========================  ==========================  =========================================================
``massMatrixReduced``       ``Ψᵀ M Ψ``                  ``modal_mass`` (``+ Σ Φr_iᵀ J_i Φr_i``: rotary inertia)
``stiffnessMatrixReduced``  ``Ψᵀ K Ψ``                  ``modal_stiffness``
``mass``, ``centerOfMass``  ``Σ m_i``, ``S₀ / m``       ``mass``, ``first_moment / mass``
``inertia``                 ``Σ m_i x̄̃_iᵀ x̄̃_i``       ``inertia`` (``+ Σ J_i``)
``mPhitTPsi``               ``Σ m_i Φt_i``              ``modal_first_moment`` ``S₁``
``mPhitTPsiTilde`` block k  ``Σ m_i φ̃_ik``             skew of ``S₁[:, k]``
``mXRefTildePsi``           ``Σ m_i x̄̃_iᵀ Φt_i``        ``−coupling`` (``C₀``, with ``Σ J_i Φr_i``)
``mPsiTildePsi`` block k    ``Σ m_i φ̃_ikᵀ Φt_i``       ``−coupling_linear[k]``
``mPsiTildePsiTilde`` k, l  ``Σ m_i φ̃_ikᵀ φ̃_il``       ``inertia_quadratic[k, l]``
``mXRefTildePsiTilde`` k    ``Σ m_i x̄̃_iᵀ φ̃_ik``        symmetric part ``½ inertia_linear[k]``; the matrix
                                                        from the nodal rows: :func:`x_ref_tilde_psi_tilde`
==========================  ==========================  =========================================================

Exudyn's mesh nodes carry no rotation: its mass matrix and quadratic-velocity vector are those of point masses.
The beam nodes' rotary inertias ``J_i`` (turning at ``ω + Φr_i q̇``) enter flexmbs's constants ``I₀``, ``C₀`` and
``M_ff`` above, where Exudyn takes them as given; they add no term that varies with ``q``, and one
quadratic-velocity term that Exudyn's constants do not carry, the moment ``ω × (Σ J_i Φr_i q̇)``, which
:func:`_rotary_force` adds as Exudyn's force user function (its effect is measured in docs/benchmarks.md).

Joints at an interface node attach to an ``MarkerSuperElementPosition`` of that mesh node: a position marker,
so a revolute joint there locks the position only (a spherical joint, Exudyn's ``ObjectJointSpherical``).
That is exact for a planar mechanism whose revolute axes are normal to its plane (the three-bar): its motion
leaves the pins' out-of-plane rotations at rest; :func:`check_reduced` refuses any other joint kind and any load,
clamp, spring or gravity on a reduced body.
"""

from __future__ import annotations

import time

import numpy as np

from crosscheck.exudyn_items import Translation, joints, nodes
from crosscheck.exudyn_model import Unsupported, solver_settings
from reference.interactions import Gravity

POSITION_KINDS = ("revolute", "spherical")
"""Joint kinds that may attach to a reduced body's interface node (module docstring)."""


def _skews(vectors) -> np.ndarray:
    """Skew matrices (..., 3, 3) of vectors (..., 3) (``ã b = a × b``: column j is ``a × e_j``)."""
    return np.swapaxes(np.cross(np.asarray(vectors, dtype=float)[..., None, :], np.eye(3)), -1, -2)


def x_ref_tilde_psi_tilde(body) -> np.ndarray:
    """``Σ m_i x̄̃_iᵀ φ̃_ik`` (r, 3, 3) of a :class:`~reference.reduced.body.ReducedBody`: the one Exudyn constant
    that flexmbs keeps only as its symmetric part, ``I₁ₖ`` (module docstring)."""
    m = body.masses[0]
    return np.einsum("n,nba,nkbc->kac", m, _skews(body.rest), _skews(np.moveaxis(body.Pt, 2, 1)))


def rotary_coupling(body) -> np.ndarray:
    """``Σ J_i Φr_i`` (3, r): the part of ``C₀`` from the nodes' rotary inertias."""
    return np.einsum("nab,nbk->ak", body.masses[1], body.Pr)


def exudyn_parameters(body) -> dict:
    """The ``ObjectFFRFreducedOrder`` keyword arguments (less the nodes) of ``body``, a
    :class:`~reference.reduced.body.ReducedBody`, in Exudyn's layout (module docstring's table)."""
    inv, r = body.inv, body.n_modes
    psi_tilde_psi_tilde = np.asarray(inv.inertia_quadratic).transpose(0, 2, 1, 3).reshape(3 * r, 3 * r)
    return dict(
        massMatrixReduced=inv.modal_mass, stiffnessMatrixReduced=inv.modal_stiffness,
        dampingMatrixReduced=body.D if np.any(body.D) else [],
        modeBasis=body.Pt.reshape(-1, r), referencePositions=body.rest.reshape(-1),
        mass=inv.mass, inertia=inv.inertia, centerOfMass=inv.first_moment / inv.mass,
        mPhitTPsi=inv.modal_first_moment,
        mPhitTPsiTilde=np.hstack(list(_skews(inv.modal_first_moment.T))),
        mXRefTildePsi=-inv.coupling,
        mPsiTildePsi=-np.asarray(inv.coupling_linear).reshape(3 * r, r),
        mPsiTildePsiTilde=psi_tilde_psi_tilde,
        mXRefTildePsiTilde=np.hstack(list(x_ref_tilde_psi_tilde(body))))


def _g_local(p) -> np.ndarray:
    """``G`` (3, 4) with ``ω = G ṗ`` in body components, Euler parameters ``p`` scalar first."""
    return 2.0 * np.array([[-p[1], p[0], p[3], -p[2]], [-p[2], -p[3], p[0], p[1]], [-p[3], p[2], -p[1], p[0]]])


def _rotary_force(body, p0, spin_stiffness=None):
    """Exudyn's force user function adding to the frame's Euler-parameter rows ``−Gᵀ (ω × (Σ J_i Φr_i q̇))`` (the
    module docstring's missing quadratic-velocity term) and to the modal rows the stiffness flexmbs adds to the
    linear modes when the deck asks for it: the stress stiffness of a spin ``−K_G(ω) q``,
    ``K_G(ω) = Σ ω_a ω_b 𝕂_ab`` (``spin_stiffness`` 𝕂 (3, 3, r, r), default the body's ``spin_stiffness``,
    ``reduce.stiffening``) and the modes' second-order force ``−½ K₃ : q q`` (the body's ``cubic`` K₃ (r, r, r),
    ``reduce.second_order``) and third-order force ``−⅙ K₄ ⋮ q q q`` (its ``quartic`` K₄ (r, r, r, r),
    ``reduce.third_order``; :mod:`reference.reduced.stiffening`); ``p0`` the frame's reference Euler parameters
    (Exudyn's coordinates are displacements from them)."""
    coupling, r = rotary_coupling(body), body.n_modes
    spin = getattr(body, "spin_stiffness", None) if spin_stiffness is None else spin_stiffness
    cubic, quartic = getattr(body, "cubic", None), getattr(body, "quartic", None)

    def force(mbs, t, item, q, q_t):
        q, q_t = np.asarray(q), np.asarray(q_t)
        G = _g_local(q[3:7] + p0)
        w, eta = G @ q_t[3:7], q[7:]
        out = np.zeros(7 + r)
        out[3:7] = -G.T @ np.cross(w, coupling @ q_t[7:])
        if spin is not None:
            out[7:] -= np.einsum("a,b,abkl,l->k", w, w, spin, eta)
        if cubic is not None:
            out[7:] -= 0.5 * np.einsum("klm,l,m->k", cubic, eta, eta)
        if quartic is not None:
            out[7:] -= np.einsum("klmn,l,m,n->k", quartic, eta, eta, eta) / 6.0
        return out

    return force


def check_reduced(domain, bodies: dict) -> None:
    """Raise :class:`~crosscheck.exudyn_model.Unsupported` (one line) for what this translation cannot express
    on a reduced body (module docstring)."""
    reduced = {int(i) for body in bodies.values() for i in body_nodes(domain, body)}
    for j in domain.joints:
        touches = [b for b in (j.body_i, j.body_j) if b is not None and b.id in reduced]
        if touches and j.kind not in POSITION_KINDS:
            raise Unsupported(f"joint {j.label!r} ({j.kind}) attaches to reduced node {touches[0].label!r}: only "
                              f"{', '.join(POSITION_KINDS)} joints are translated there (position markers)")
    if domain.solver.damping > 0.0 or any(isinstance(ld, Gravity) for ld in domain.loading):
        raise Unsupported("mass-proportional damping or gravity with a reduced body: not translated")
    held = [bc.node for bc in domain.boundary_conditions] + [getattr(ld, "node", None) for ld in domain.loading]
    held += [b.label for fe in domain.force_elements for b in (fe.body_i, fe.body_j) if b is not None]
    for ref in held:
        if ref is not None and domain.node(ref).id in reduced:
            raise Unsupported(f"a clamp, load or spring on reduced node {domain.node(ref).label!r}: not translated")


def body_nodes(domain, body) -> np.ndarray:
    """The model's node ids of a reduced body's beam, in its order."""
    return np.array([n.id for n in domain.beams[body.label]], dtype=np.int64)


class _Without:
    """The domain seen without some joints (those :func:`reduced_joints` translates), for
    :func:`crosscheck.exudyn_items.joints`."""

    def __init__(self, domain, kept):
        self._domain, self.joints = domain, kept

    def __getattr__(self, name):
        return getattr(self._domain, name)


def reduced_body(t: Translation, body, spin_stiffness=None) -> tuple[int, dict]:
    """``body`` as an ``ObjectFFRFreducedOrder`` of ``t``'s system, its frame at the invariants' origin and at rest
    (the decks start the reduced beams at rest), with the stress stiffness ``spin_stiffness`` (default the body's;
    :func:`_rotary_force`); returns the object and, by node id, its mesh index."""
    eii, mbs, r = t.eii, t.mbs, body.n_modes
    p0 = np.array([1.0, 0.0, 0.0, 0.0])
    frame = mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=list(body.inv.origin) + list(p0)))
    modal = mbs.AddNode(eii.NodeGenericODE2(numberOfODE2Coordinates=r, referenceCoordinates=[0.0] * r,
                                            initialCoordinates=[0.0] * r, initialCoordinates_t=[0.0] * r))
    force = _rotary_force(body, p0, spin_stiffness)
    t.user_functions.append(force)
    obj = mbs.AddObject(eii.ObjectFFRFreducedOrder(nodeNumbers=[frame, modal], forceUserFunction=force,
                                                   computeFFRFterms=True, **exudyn_parameters(body)))
    return obj, {int(i): k for k, i in enumerate(body_nodes(t.domain, body))}


def reduced_joints(t: Translation, mesh: dict) -> None:
    """The joints at the reduced bodies' interface nodes as ``ObjectJointSpherical`` (module docstring);
    ``mesh`` maps node id → ``(object, mesh index)``."""
    eii, mbs = t.eii, t.mbs
    for j in t.domain.joints:
        if not any(b is not None and b.id in mesh for b in (j.body_i, j.body_j)):
            continue
        par = j.body_fixed()
        markers = []
        for body, s, f in ((j.body_j, par[3:6], par[15:24]), (j.body_i, par[0:3], par[6:15])):
            if body is not None and body.id in mesh:
                obj, k = mesh[body.id]
                markers.append(mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=obj, meshNodeNumbers=[k],
                                                                            weightingFactors=[1.0])))
            else:
                markers.append(t.marker(body, f.reshape(3, 3), s))
        t.joints[id(j)] = mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=markers))


def build(domain, bodies: dict):
    """The Exudyn system of ``domain`` with the beams of ``bodies`` (label →
    :class:`~reference.reduced.body.ReducedBody`) reduced: returns ``(translation, sensors)``, the sensors the
    reduced beams' mesh-node positions, by label, (n,) each."""
    import exudyn as exu
    import exudyn.itemInterface as eii

    check_reduced(domain, bodies)
    t = Translation(domain, exu, eii)
    t.reduced = {int(i) for body in bodies.values() for i in body_nodes(domain, body)}
    nodes(t)
    mesh, objects = {}, {}
    for label, body in bodies.items():
        obj, index = reduced_body(t, body)
        objects[label] = obj
        mesh.update({i: (obj, k) for i, k in index.items()})
    t.domain = _Without(domain, [j for j in domain.joints
                                 if not any(b is not None and b.id in mesh for b in (j.body_i, j.body_j))])
    joints(t)
    t.domain = domain
    reduced_joints(t, mesh)
    OV = exu.OutputVariableType
    sensors = {label: [t.mbs.AddSensor(eii.SensorSuperElement(bodyNumber=obj, meshNodeNumber=k, storeInternal=True,
                                                              writeToFile=False, outputVariableType=OV.Position))
                       for k in range(len(bodies[label].rest))] for label, obj in objects.items()}
    t.mbs.Assemble()
    return t, sensors


def solve(domain, bodies: dict, dt: float | None = None, t_end: float | None = None) -> dict:
    """Run :func:`build`'s system with Exudyn's implicit solver at the deck's step and output interval
    (:func:`crosscheck.exudyn_model.solver_settings`); returns ``time`` (n_t,), ``positions`` (label → (n_t, n, 3),
    the reduced beams' mesh nodes, inertial [m]), ``wall_time`` [s] and ``algorithm``.

    Raises
    ------
    crosscheck.exudyn_model.Unsupported
        One line: Exudyn's solver did not reach the end.
    """
    dt = float(dt or domain.solver.dt)
    t_end = float(t_end or domain.solver.t_end)
    every = max(int(round(domain.solver.output_every * domain.solver.dt / dt)), 1)
    t, sensors = build(domain, bodies)
    solver, settings, label = solver_settings(domain, dt, t_end, every)
    t0 = time.perf_counter()
    ok = solver.SolveSystem(t.mbs, settings)
    wall = time.perf_counter() - t0
    if ok is not True or solver.it.currentTime < t_end * (1.0 - 1e-9):
        raise Unsupported(f"Exudyn's {label} stopped at t = {solver.it.currentTime:g} of {t_end:g} with the reduced "
                          "bodies; try a smaller step")
    data = {k: np.array([t.mbs.GetSensorStoredData(s) for s in v]) for k, v in sensors.items()}
    first = next(iter(data.values()))
    return {"time": first[0, :, 0], "positions": {k: np.transpose(v[:, :, 1:4], (1, 0, 2)) for k, v in data.items()},
            "wall_time": wall, "algorithm": label}


def midspan_deflection(positions) -> np.ndarray:
    """The middle node's deflection (n_t, 3) from the chord of the ends, of mesh positions (n_t, n, 3) with n odd:
    :mod:`reference.observables`' ``midspan_deflection`` on Exudyn's mesh."""
    n = positions.shape[1]
    m, p, q = positions[:, n // 2], positions[:, 0], positions[:, -1]
    c = (q - p) / np.linalg.norm(q - p, axis=1)[:, None]
    d = m - p
    return d - np.sum(d * c, axis=1)[:, None] * c
