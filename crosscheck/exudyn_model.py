"""Any deck the reference accepts, built and run in Exudyn (1.13); the same results file.

The deck is read by the reference's deck reader (so both engines see exactly
the same data: nodes, triads, masses, joints, loads); :func:`build` then
translates the resulting :class:`~reference.domain.Domain` item by item:

============================  ==========================================================
deck                          Exudyn
============================  ==========================================================
node                          ``NodeRigidBodyEP`` (position, Euler parameters, velocities)
Beam2 element                 ``ObjectBeamGeometricallyExact`` (same length and section)
rigid body / rigid bar        ``ObjectRigidBody`` (mass, body-frame inertia)
joint (any kind)              ``ObjectJointGeneric`` between markers carrying the joint
                              frame; the locked axes of the kind
rotation / displacement drive merged into the revolute / translational joint at the same
                              place: all axes locked, the motion as an offset user function
clamp, fixed coordinates      ``ObjectJointGeneric`` to ground locking those coordinates
dead / follower force, moment ``LoadForceVector`` / ``LoadTorqueVector`` (``bodyFixed``),
                              scaled by the time function once per step (at the step's end time);
                              a force at a point on a marker at that body-fixed offset
line load                     its lumped nodal loads (``LineLoad.nodal_loads``), as above
point-to-point spring         ``ObjectConnectorSpringDamper`` (reference length, stiffness,
                              damping; the actuator as its ``force``, set once per step)
rotational spring             ``ObjectConnectorTorsionalSpringDamper`` between markers carrying
                              the element frame (body j first), with a ``NodeGenericData`` for
                              the continuous angle; ``offset`` = rest angle
bushing                       ``ObjectConnectorRigidBodySpringDamper`` (body i first, diagonal
                              stiffness and damping in the element frame; Exudyn's rotation
                              measure agrees with the reference's to first order)
gravity                       ``LoadMassProportional`` on every body and beam element
mass-proportional damping     a ``ObjectConnectorRigidBodySpringDamper`` per node to
                              ground (Exudyn ignores the beam's own damping matrix)
============================  ==========================================================

A deck feature Exudyn cannot express is refused with :class:`Unsupported`,
naming it — never dropped or approximated: regularised redundant joints
(ε > 0: Exudyn's constraint Jacobian would be singular), a drive without its
revolute/translational joint, curved beam references, point masses on beam
nodes.  The joint *formulation* (multipliers or master/slave) is a choice of
the reference engine; Exudyn enforces every joint by its own multipliers.

The results file has ``engine = "exudyn"``.  Its constraint residuals and
energies are evaluated with the reference's own definitions on Exudyn's states
(the same Φ, B, lumped kinetic energy and Beam2 strain energy), so both
engines' drift and energies are measured by one yardstick; the external work
is the trapezoidal integral of the loads' power over the output times and does
not include the work of driving motions (Exudyn does not report its joint
reaction power).
"""

from __future__ import annotations

import time

import numpy as np

from reference.forces import BUSHING, POINT_TO_POINT, ROTATIONAL, force_element_forces
from reference.generated import rotation_maps as rm
from reference.interactions import Gravity, LineLoad, NodalLoad
from reference.rotation import EulerParameters

AXES = {
    "spherical": [1, 1, 1, 0, 0, 0],
    "revolute": [1, 1, 1, 1, 1, 0],
    "universal": [1, 1, 1, 0, 0, 1],
    "cylindrical": [1, 1, 0, 1, 1, 0],
    "translational": [1, 1, 0, 1, 1, 1],
    "fixed": [1, 1, 1, 1, 1, 1],
}
MERGES = {"rotation_drive": "revolute", "displacement_drive": "translational"}


class Unsupported(ValueError):
    """A deck feature the Exudyn translation cannot express."""


def _matrix(q) -> np.ndarray:
    out = np.empty(9)
    rm.rotation_matrix(np.asarray(q, dtype=float), out)
    return out.reshape(3, 3)


def _ht(R, p) -> list:
    ht = np.eye(4)
    ht[:3, :3], ht[:3, 3] = R, p
    return ht.tolist()


def check_supported(domain) -> None:
    """Raise :class:`Unsupported` naming the first feature Exudyn cannot express."""
    beam_nodes = {i for e in domain.elements for i in e.nodes}
    model = domain.model
    for j in domain.joints:
        if j.formulation.epsilon > 0.0:
            raise Unsupported(f"joint {j.label!r} is regularised (epsilon = {j.formulation.epsilon:g}): redundant "
                              "constraints cannot be expressed in Exudyn, whose constraint Jacobian would be singular")
    for e, element in enumerate(domain.elements):
        if np.linalg.norm(model.psi0[e]) > 1e-12 or np.linalg.norm(model.gamma0[e] - [1.0, 0.0, 0.0]) > 1e-12:
            raise Unsupported(f"element {element.label!r} has a curved or kinked reference: the translation "
                              "supports straight beams whose node triads are the section triads")
    for n in domain.nodes:
        if n.id in beam_nodes and n.mass > 0.0:
            raise Unsupported(f"node {n.label!r} carries a point mass on a beam node")
    for fe in domain.force_elements:
        par = fe.body_fixed()
        for body, offset in ((fe.body_i, par[0:3]), (fe.body_j, par[3:6])):
            if body is not None and body.id in beam_nodes and np.linalg.norm(offset) > 1e-12 \
                    and fe.kind != ROTATIONAL:
                raise Unsupported(f"force element {fe.label!r} attaches to beam node {body.label!r} away from the "
                                  "node: Exudyn's node markers carry no offset")
    for ld in domain.loading:
        if isinstance(ld, NodalLoad) and ld.point is not None and not ld.moment \
                and domain.node(ld.node).id in beam_nodes \
                and np.linalg.norm(np.asarray(ld.point) - domain.node(ld.node).position) > 1e-12:
            raise Unsupported(f"a load at a point away from beam node {domain.node(ld.node).label!r}: Exudyn's node "
                              "markers carry no offset")
    for j in domain.joints:
        if j.kind in MERGES and _partner(domain, j) is None:
            raise Unsupported(f"joint {j.label!r} ({j.kind}) has no {MERGES[j.kind]} joint between the same bodies "
                              "at the same point and axis: Exudyn's generic joint drives a locked axis")


def _partner(domain, drive):
    for j in domain.joints:
        if j.kind == MERGES.get(drive.kind) and {id(j.body_i), id(j.body_j)} == {id(drive.body_i), id(drive.body_j)} \
                and np.allclose(j.point, drive.point, atol=1e-12) and np.allclose(j.frame[:, 2], drive.frame[:, 2]):
            return j
    return None


def build(domain, dt: float, output_every: int, progress=None, t_end: float = 1.0):
    """Translate ``domain`` into an Exudyn system; return ``(SC, mbs, sensors, pre_step_items)``."""
    import exudyn as exu
    import exudyn.itemInterface as eii

    check_supported(domain)
    model = domain.model
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())
    beam_nodes = {i for e in domain.elements for i in e.nodes}
    x0 = np.array([n.position for n in domain.nodes])
    q0 = np.array([n.rotation for n in domain.nodes])
    state = domain.initial_conditions()  # includes the consistent projection if the deck asks for it
    nodes, bodies = [], {}
    for n in domain.nodes:
        qd = EulerParameters(state.q[n.id]).kinematic_rate(state.w[n.id])
        nodes.append(mbs.AddNode(eii.NodeRigidBodyEP(
            referenceCoordinates=list(x0[n.id]) + list(q0[n.id]),
            initialVelocities=list(state.v[n.id]) + list(qd))))
        if n.id not in beam_nodes:
            J = n.inertia
            bodies[n.id] = mbs.AddObject(eii.ObjectRigidBody(
                mass=n.mass, inertia=[J[0, 0], J[1, 1], J[2, 2], J[1, 2], J[0, 2], J[0, 1]], nodeNumber=nodes[-1]))
    beam_objects = []
    for e, element in enumerate(domain.elements):
        sec = element.formulation.section
        section = exu.BeamSection()
        section.stiffnessMatrix = np.diag(sec.stiffness).tolist()
        section.massPerLength = sec.rhoA
        section.inertia = np.diag(sec.rotary_inertia).tolist()
        beam_objects.append(mbs.AddObject(eii.ObjectBeamGeometricallyExact(
            nodeNumbers=[nodes[i] for i in element.nodes], length=float(model.L0[e]), sectionData=section)))

    def marker(node, R=np.eye(3), p=np.zeros(3)):
        if node is None:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localHT=_ht(R, p)))
        if node.id in bodies:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=bodies[node.id], localHT=_ht(R, p)))
        return mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[node.id], localHT=_ht(R, p)))

    time_functions = []
    drives = {id(_partner(domain, j)): j for j in domain.joints if j.kind in MERGES}
    for j in domain.joints:
        if j.kind in MERGES:
            continue
        par = j.body_fixed()
        s_i, s_j, f_i, f_j = par[0:3], par[3:6], par[6:15].reshape(3, 3), par[15:24].reshape(3, 3)
        m1 = marker(j.body_i, f_i, s_i)
        m0 = marker(j.body_j, f_j, s_j)
        axes = list(AXES[j.kind])
        options = {}
        drive = drives.get(id(j))
        if drive is not None:
            axes = [1, 1, 1, 1, 1, 1]
            tf, velocity, slot = drive.time_function, drive.mode == "velocity", 5 if drive.kind == "rotation_drive" else 2

            def offset(mbs_, t, item, parameters, tf=tf, velocity=velocity, slot=slot):
                out = [0.0] * 6
                out[slot] = tf.integral(t) if velocity else tf(t)
                return out

            options["offsetUserFunction"] = offset
            time_functions.append(offset)
        # a universal joint's locked rotation pairs the pin of body i (u1) with the pin of body j (u2):
        # Exudyn's generic joint locks marker 0's x against marker 1's y, so body i goes first there
        order = [m1, m0] if j.kind == "universal" else [m0, m1]
        mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=order, constrainedAxes=axes, **options))

    for bc in domain.boundary_conditions:
        node = domain.node(bc.node)
        axes = [1 if k in bc.dofs else 0 for k in range(6)]
        R = _matrix(node.rotation)
        mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[marker(None, R, node.position), marker(node)],
                                             constrainedAxes=axes))

    loads = []
    for ld in domain.loading:
        if isinstance(ld, (NodalLoad, LineLoad)):
            for nl in ld.nodal_loads() if isinstance(ld, LineLoad) else [ld]:
                node = domain.node(nl.node)
                arm = np.zeros(3)
                if nl.point is not None and not nl.moment:
                    arm = _matrix(node.rotation).T @ (np.asarray(nl.point, dtype=float) - node.position)
                cls = eii.LoadTorqueVector if nl.moment else eii.LoadForceVector
                number = mbs.AddLoad(cls(markerNumber=marker(node, np.eye(3), arm),
                                         loadVector=list(np.asarray(nl.vector) * nl.time_function(0.0)),
                                         bodyFixed=bool(nl.follower)))
                loads.append((number, np.asarray(nl.vector, dtype=float), nl.time_function))
        elif isinstance(ld, Gravity):
            for obj in list(bodies.values()) + beam_objects:
                mbs.AddLoad(eii.LoadMassProportional(markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=obj)),
                                                     loadVector=list(np.asarray(ld.g, dtype=float))))
    if domain.solver.damping > 0.0:
        c = domain.solver.damping
        for n in domain.nodes:
            d = [c * model.mass[n.id]] * 3 + [c * model.inertia[n.id, k, k] for k in range(3)]
            # the node as marker 0: the connector damps the relative angular velocity in marker 0's
            # frame, i.e. the body frame, as the reference's −c J ω (translations: isotropic c m)
            mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                markerNumbers=[marker(n), marker(None, _matrix(n.rotation), n.position)],
                stiffness=np.zeros((6, 6)).tolist(), damping=np.diag(d).tolist()))

    actuators = []
    for fe in domain.force_elements:
        par = fe.body_fixed()
        s_i, s_j, f_i, f_j = par[0:3], par[3:6], par[6:15].reshape(3, 3), par[15:24].reshape(3, 3)
        k, c = fe.stiffness_damping()
        if fe.kind == POINT_TO_POINT:
            number = mbs.AddObject(eii.ObjectConnectorSpringDamper(
                markerNumbers=[marker(fe.body_j, np.eye(3), s_j), marker(fe.body_i, np.eye(3), s_i)],
                referenceLength=float(fe.rest()), stiffness=float(k[0]), damping=float(c[0])))
            if fe.force_function is not None:
                actuators.append((number, fe.force_function))
        elif fe.kind == ROTATIONAL:  # (the markers' position does not matter)
            angle = mbs.AddNode(eii.NodeGenericData(numberOfDataCoordinates=1, initialCoordinates=[0.0]))
            mbs.AddObject(eii.ObjectConnectorTorsionalSpringDamper(
                markerNumbers=[marker(fe.body_j, f_j), marker(fe.body_i, f_i)], nodeNumber=angle,
                stiffness=float(k[0]), damping=float(c[0]), offset=float(fe.rest())))
        elif fe.kind == BUSHING:
            mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                markerNumbers=[marker(fe.body_i, f_i, s_i), marker(fe.body_j, f_j, s_j)],
                stiffness=np.diag(k).tolist(), damping=np.diag(c).tolist()))

    def pre_step(mbs_, t):
        # Exudyn passes the step's end time (the implicit solver's equilibrium time): the loads are
        # set to their value there, once per step
        for number, vec, tf in loads:
            mbs_.SetLoadParameter(number, "loadVector", list(vec * tf(t)))
        for number, tf in actuators:
            mbs_.SetObjectParameter(number, "force", float(tf(t)))
        if progress is not None:
            progress(min(t / t_end, 1.0), t)
        return True

    if loads or actuators or progress is not None:
        mbs.SetPreStepUserFunction(pre_step)
    OV = exu.OutputVariableType
    sensors = {kind: [mbs.AddSensor(eii.SensorNode(nodeNumber=nd, storeInternal=True, writeToFile=False,
                                                   outputVariableType=ov)) for nd in nodes]
               for kind, ov in (("position", OV.Position), ("velocity", OV.Velocity),
                                ("angular_velocity", OV.AngularVelocityLocal), ("rotation", OV.RotationMatrix))}
    mbs.Assemble()
    return SC, mbs, sensors


def solve(domain, dt: float | None = None, t_end: float | None = None, results_path=None, progress=None) -> dict:
    """Build and run ``domain`` in Exudyn (generalized-α, fixed step); return results and timing.

    Returns a dict with ``results`` (:class:`reference.domain.Results`, engine
    Exudyn), ``wall_time`` (the solve call only) and ``steps``.
    """
    import exudyn as exu

    from reference.io.results import ResultsWriter

    dt = float(dt or domain.solver.dt)
    t_end = float(t_end or domain.solver.t_end)
    every = max(int(round(domain.solver.output_every * domain.solver.dt / dt)), 1)
    SC, mbs, sensors = build(domain, dt, every, progress, t_end)
    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = every * dt
    settings.timeIntegration.verboseMode = 0
    n_steps = int(round(t_end / dt))
    settings.timeIntegration.numberOfSteps = n_steps
    settings.timeIntegration.endTime = t_end
    settings.timeIntegration.newton.relativeTolerance = 1e-6
    settings.timeIntegration.newton.absoluteTolerance = 1e-6
    settings.timeIntegration.adaptiveStep = False
    solver = exu.MainSolverImplicitSecondOrder()
    t0 = time.perf_counter()
    ok = solver.SolveSystem(mbs, settings)
    wall = time.perf_counter() - t0
    steps = int(solver.it.currentStepIndex) - 1
    if not ok or steps != n_steps:
        raise RuntimeError(f"Exudyn's solver {'did not converge' if not ok else f'took {steps} steps instead of {n_steps}'}")
    data = {k: np.array([mbs.GetSensorStoredData(s) for s in v]) for k, v in sensors.items()}
    times = data["position"][0, :, 0]
    pos = np.transpose(data["position"][:, :, 1:4], (1, 0, 2))
    vel = np.transpose(data["velocity"][:, :, 1:4], (1, 0, 2))
    omg = np.transpose(data["angular_velocity"][:, :, 1:4], (1, 0, 2))
    rot = np.array([[EulerParameters.from_matrix(R.reshape(3, 3)).q for R in data["rotation"][n, :, 1:10]]
                    for n in range(len(domain.nodes))]).transpose(1, 0, 2)
    results = measured(domain, times, pos, rot, vel, omg, wall, dt)
    if results_path is not None:
        writer = ResultsWriter(results_path, labels=results.labels, ids=[n.id for n in domain.nodes], attrs={
            "engine": "exudyn", "engine_version": exu.__version__, "deck": domain.deck_text,
            "deck_path": str(domain.deck_path), "algorithm": "generalized-alpha (Exudyn)", "dt": dt,
            "energy_note": "evaluated with the reference's definitions on Exudyn's states; external work "
                           "excludes driving motions"})
        for i, t in enumerate(times):
            writer.append({"time": t, "position": pos[i], "rotation": rot[i], "velocity": vel[i],
                           "angular_velocity": omg[i], "violation_norm": results.constraint_violation[i],
                           "velocity_violation_norm": results.velocity_constraint_violation[i],
                           **{k: v[i] for k, v in results.energy.items()}})
        writer.close("completed")
    return {"results": results, "wall_time": wall, "steps": steps, "exudyn_version": exu.__version__}


def measured(domain, times, pos, rot, vel, omg, wall, dt):
    """Constraint residuals and energies of a trajectory, by the reference's definitions."""
    from reference.domain import Results
    from reference.elements.formulation import beam2_assemble
    from reference.algorithms.staggered import external_forces

    model = domain.model
    n, N = len(times), len(domain.nodes)
    phi = np.zeros(n)
    phid = np.zeros(n)
    kinetic, strain, work = np.zeros(n), np.zeros(n), np.zeros(n)
    S, F, s_el, A = np.zeros((N, 6)), np.zeros((N, 6)), np.zeros(24), np.zeros(9)
    G, angle, prim_phi, prim_B = np.zeros((N, 6)), np.zeros(model.fe_kind.shape[0]), np.zeros(10), np.zeros(120)
    power = np.zeros(n)
    for i in range(n):
        if model.n_constraints:
            PHI, PHIt, Bg, _ = domain.constraint_matrices(model, pos[i], rot[i], times[i])
            V = np.concatenate([vel[i], omg[i]], axis=1).reshape(-1)
            phi[i], phid[i] = np.linalg.norm(PHI), np.linalg.norm(Bg @ V + PHIt)
        kinetic[i] = 0.5 * np.sum(model.mass[:, None] * vel[i] ** 2) + 0.5 * np.einsum("ni,nij,nj->", omg[i], model.inertia, omg[i])
        strain[i] = beam2_assemble(pos[i], rot[i], model.conn, model.L0, model.psi0, model.gamma0, model.stiff, S, s_el)
        external_forces(model, pos[i], rot[i], times[i], F, A)
        # springs: their energy is strain energy, their actuators external loads
        strain[i] += force_element_forces(model, pos[i], rot[i], vel[i], omg[i], times[i], angle, G, F, prim_phi,
                                          prim_B)[0]
        power[i] = np.sum(F[:, :3] * vel[i]) + np.sum(F[:, 3:] * omg[i])
        if i > 0:
            work[i] = work[i - 1] + 0.5 * (power[i] + power[i - 1]) * (times[i] - times[i - 1])
    return Results(time=times, labels=[nd.label for nd in domain.nodes], positions=pos, rotations=rot, velocities=vel,
                   angular_velocities=omg, energy={"kinetic": kinetic, "strain": strain, "external_work": work,
                                                   "dissipated": np.full(n, np.nan)},
                   constraint_violation=phi, velocity_constraint_violation=phid, wall_time=wall,
                   attrs={"engine": "exudyn", "dt": dt})
