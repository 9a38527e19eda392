"""Any deck the reference accepts, built and run in Exudyn (1.13); the same results file.

The deck is read by the reference's deck reader (so both engines see exactly
the same data: nodes, triads, masses, joints, loads); :func:`build` then
translates the resulting :class:`~reference.domain.Domain` item by item:

============================  ==========================================================
deck                          Exudyn
============================  ==========================================================
node                          ``NodeRigidBodyEP`` (position, Euler parameters, velocities);
                              a beam node's Exudyn node carries the section frame of its
                              first element end (markers turn back to the node frame)
Beam2 element                 ``ObjectBeamGeometricallyExact`` (same length and section)
                              between Exudyn nodes in its own section frames; an end whose
                              section frame differs from the node's (a kink at a shared
                              node, the chords of an arc) gets its own Exudyn node, welded
                              to the node's by an ``ObjectJointGeneric`` locking all axes
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
revolute/translational joint, a joint attached to a beam node away from the
node (Exudyn's node markers have no offset; offsets below 1e-12 of the model
size are round-off and snapped to zero), point masses on beam nodes.  Any
error Exudyn raises while the model is built becomes :class:`Unsupported`
with its first line (:func:`preflight` builds it before either engine runs).

Kinked and curved references: Exudyn's ``ObjectBeamGeometricallyExact`` has
no reference-curvature parameter; it subtracts the strains of its nodes'
reference coordinates (tried: a single element whose node frames are turned
against each other is unstressed at rest), but a small end moment normal to a
90° kink turns the end by 0.8106 of the straight element's rotation — 1.234×
too stiff, the factor of ``K = (ψ − ψ0)/L0`` (Exudyn 1.13.6, measured).  The translation therefore
never gives Exudyn a kinked element: each element runs between Exudyn nodes in
the element's own (straight) section frames, exactly as the reference's
offsets ``o_a`` do, and the extra nodes are welded to the node.  The joint *formulation* (multipliers or master/slave) is a choice of
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

from reference.forces import BUSHING, POINT_TO_POINT, ROTATIONAL
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


def _qmul(a, b) -> np.ndarray:
    out = np.empty(4)
    rm.quat_product(np.asarray(a, dtype=float), np.asarray(b, dtype=float), out)
    return out


def _ht(R, p) -> list:
    ht = np.eye(4)
    ht[:3, :3], ht[:3, 3] = R, p
    return ht.tolist()


def _scale(domain) -> float:
    return max([1.0] + [float(np.max(np.abs(n.position))) for n in domain.nodes])


def _node_offset(domain, node, s):
    """A joint's body-fixed offset at a beam node, snapped to zero below round-off (else None)."""
    return np.zeros(3) if np.linalg.norm(s) <= 1e-12 * _scale(domain) else None


EXUDYN_ELEMENTS = {"beam2": "ObjectBeamGeometricallyExact"}
"""The element families with an Exudyn counterpart (:mod:`reference.elements.families`)."""


def check_supported(domain) -> None:
    """Raise :class:`Unsupported` naming the first feature Exudyn cannot express."""
    beam_nodes = {i for e in domain.elements for i in e.nodes}
    for e in domain.elements:
        if e.formulation.family not in EXUDYN_ELEMENTS:
            raise Unsupported(f"element {e.label!r} is of the family {e.formulation.family!r}, which has no Exudyn "
                              f"counterpart (translated: {', '.join(EXUDYN_ELEMENTS)}); compare converged meshes instead")
    for j in domain.joints:
        if j.formulation.epsilon > 0.0:
            raise Unsupported(f"joint {j.label!r} is regularised (epsilon = {j.formulation.epsilon:g}): redundant "
                              "constraints cannot be expressed in Exudyn, whose constraint Jacobian would be singular")
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
        par = j.body_fixed()
        for body, s in ((j.body_i, par[0:3]), (j.body_j, par[3:6])):
            if body is not None and body.id in beam_nodes and _node_offset(domain, body, s) is None:
                raise Unsupported(f"joint {j.label!r} attaches to beam node {body.label!r} at {np.linalg.norm(s):.3g} "
                                  "from it: Exudyn's node markers have no offset; put the joint point on the node")


def preflight(domain) -> None:
    """Refuse what cannot be translated, then build the Exudyn model once, before anything runs.

    Raises :class:`Unsupported` (one line) for an untranslatable feature or any
    error Exudyn raises while the model is built and assembled.
    """
    check_supported(domain)
    build(domain, domain.solver.dt, 1)


def _partner(domain, drive):
    for j in domain.joints:
        if j.kind == MERGES.get(drive.kind) and {id(j.body_i), id(j.body_j)} == {id(drive.body_i), id(drive.body_j)} \
                and np.allclose(j.point, drive.point, atol=1e-12) and np.allclose(j.frame[:, 2], drive.frame[:, 2]):
            return j
    return None


def build(domain, dt: float, output_every: int, progress=None, t_end: float = 1.0):
    """Translate ``domain`` into an Exudyn system; return ``(SC, mbs, sensors, primary)``.

    ``primary`` (N,4): per node, the offset from the node frame to the frame of
    its Exudyn node (identity except at beam nodes whose first element end is
    kinked against the node frame).  Raises :class:`Unsupported` (one line) for
    anything untranslatable or refused by Exudyn.
    """
    check_supported(domain)
    try:
        return _build(domain, progress, t_end)
    except Unsupported:
        raise
    except Exception as exc:  # Exudyn's own errors (RuntimeError, ValueError, …): one line, before any run
        first = next((ln.strip() for ln in str(exc).splitlines() if ln.strip()), type(exc).__name__)
        raise Unsupported(f"Exudyn refused the translated model: {first}") from None


def _build(domain, progress, t_end):
    import exudyn as exu
    import exudyn.itemInterface as eii

    model = domain.model
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())
    beam_nodes = {i for e in domain.elements for i in e.nodes}
    x0 = np.array([n.position for n in domain.nodes])
    q0 = np.array([n.rotation for n in domain.nodes])
    state = domain.initial_conditions()  # includes the consistent projection if the deck asks for it
    # each node's Exudyn node carries the section frame of the node's first element end: offset o_p
    primary = np.tile([1.0, 0.0, 0.0, 0.0], (len(domain.nodes), 1))
    beams = {int(e): (data, r) for data in model.elements for r, e in enumerate(data.index)}  # beam2 (preflight)
    seen = set()
    for e, element in enumerate(domain.elements):
        for a, i in enumerate(element.nodes):
            if i not in seen:
                seen.add(i)
                primary[i] = beams[e][0].offset[beams[e][1], a]

    def exudyn_node(i, o):
        p = _qmul(q0[i], o)
        w = _matrix(o).T @ state.w[i]
        qd = EulerParameters(p).kinematic_rate(w)
        return mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=list(x0[i]) + list(p),
                                               initialVelocities=list(state.v[i]) + list(qd)))

    nodes, bodies = [], {}
    for n in domain.nodes:
        nodes.append(exudyn_node(n.id, primary[n.id]))
        if n.id not in beam_nodes:
            J = n.inertia
            bodies[n.id] = mbs.AddObject(eii.ObjectRigidBody(
                mass=n.mass, inertia=[J[0, 0], J[1, 1], J[2, 2], J[1, 2], J[0, 2], J[0, 1]], nodeNumber=nodes[-1]))

    def marker(node, R=np.eye(3), p=np.zeros(3)):
        if node is None:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localHT=_ht(R, p)))
        if node.id in bodies:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=bodies[node.id], localHT=_ht(R, p)))
        # a beam node: the Exudyn node's frame is the node frame turned by o_p; no offset (snapped)
        Op = _matrix(primary[node.id])
        return mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[node.id], localHT=_ht(Op.T @ R, np.zeros(3))))

    beam_objects = []
    for e, element in enumerate(domain.elements):
        sec = element.formulation.section
        section = exu.BeamSection()
        section.stiffnessMatrix = np.diag(sec.stiffness).tolist()
        section.massPerLength = sec.rhoA
        section.inertia = np.diag(sec.rotary_inertia).tolist()
        ends = []
        data, r = beams[e]
        for a, i in enumerate(element.nodes):
            o = data.offset[r, a]
            if abs(abs(o @ primary[i]) - 1.0) < 1e-14:
                ends.append(nodes[i])
                continue
            ends.append(exudyn_node(i, o))
            weld = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=ends[-1]))
            mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[marker(domain.nodes[i], _matrix(o)), weld],
                                                 constrainedAxes=[1] * 6))
        beam_objects.append(mbs.AddObject(eii.ObjectBeamGeometricallyExact(
            nodeNumbers=ends, length=float(data.L0[r]), sectionData=section)))

    time_functions = []
    joint_objects = {}
    drives = {id(_partner(domain, j)): j for j in domain.joints if j.kind in MERGES}
    for j in domain.joints:
        if j.kind in MERGES:
            continue
        par = j.body_fixed()
        s_i, s_j, f_i, f_j = par[0:3], par[3:6], par[6:15].reshape(3, 3), par[15:24].reshape(3, 3)
        s_i = s_i if j.body_i is None or j.body_i.id in bodies else _node_offset(domain, j.body_i, s_i)
        s_j = s_j if j.body_j is None or j.body_j.id in bodies else _node_offset(domain, j.body_j, s_j)
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
        number = mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=order, constrainedAxes=axes, **options))
        joint_objects[id(j)] = number
        if drive is not None:
            joint_objects[id(drive)] = number

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
            d = np.zeros((6, 6))
            d[:3, :3] = c * model.nodes.mass[n.id] * np.eye(3)
            d[3:, 3:] = c * model.nodes.inertia[n.id]
            # the node as marker 0 (in the node frame): the connector damps the relative angular velocity
            # in marker 0's frame, i.e. the body frame, as the reference's −c J ω (full J at a kinked node;
            # translations: isotropic c m)
            mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                markerNumbers=[marker(n), marker(None, _matrix(n.rotation), n.position)],
                stiffness=np.zeros((6, 6)).tolist(), damping=d.tolist()))

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
    for kind, ov in (("joint_force", OV.ForceLocal), ("joint_torque", OV.TorqueLocal)):
        sensors[kind] = [mbs.AddSensor(eii.SensorObject(objectNumber=joint_objects[id(j)], storeInternal=True,
                                                        writeToFile=False, outputVariableType=ov))
                         for j in domain.joints]
    for kind, ov in (("section_force", OV.ForceLocal), ("section_moment", OV.TorqueLocal)):
        sensors[kind] = [mbs.AddSensor(eii.SensorBody(bodyNumber=obj, localPosition=[0.0, 0.0, 0.0], storeInternal=True,
                                                      writeToFile=False, outputVariableType=ov))
                         for obj in beam_objects]
    mbs.Assemble()
    return SC, mbs, sensors, primary


def solve(domain, dt: float | None = None, t_end: float | None = None, results_path=None, progress=None) -> dict:
    """Build and run ``domain`` in Exudyn; return results and timing.

    The deck's algorithm is translated: ``static`` → Exudyn's static solver with the
    same number of load steps; ``generalized_alpha`` → Exudyn's generalized-α with the
    same ρ∞; the explicit scheme → Exudyn's generalized-α (its default ρ∞), fixed step.

    Returns a dict with ``results`` (:class:`reference.io.results.Results`, engine
    Exudyn), ``wall_time`` (the solve call only) and ``steps``.
    """
    import exudyn as exu

    from reference.io.results import ResultsWriter

    dt = float(dt or domain.solver.dt)
    t_end = float(t_end or domain.solver.t_end)
    every = max(int(round(domain.solver.output_every * domain.solver.dt / dt)), 1)
    SC, mbs, sensors, primary = build(domain, dt, every, progress, t_end)
    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = every * dt
    settings.timeIntegration.verboseMode = 0
    n_steps = int(round(t_end / dt))
    algorithm = domain.solver.algorithm
    if algorithm == "static":
        # Exudyn's static solver: the load factor is its time, in n equal load steps
        settings.staticSolver.verboseMode = 0
        settings.staticSolver.numberOfLoadSteps = n_steps
        settings.staticSolver.loadStepDuration = t_end
        settings.staticSolver.adaptiveStep = False
        settings.staticSolver.useLoadFactor = False  # the loads follow their time functions (pre-step)
        settings.staticSolver.newton.relativeTolerance = 1e-10
        settings.staticSolver.newton.absoluteTolerance = 1e-10
        solver = exu.MainSolverStatic()
        label = f"static solver, {n_steps} load steps"
    else:
        settings.timeIntegration.numberOfSteps = n_steps
        settings.timeIntegration.endTime = t_end
        settings.timeIntegration.newton.relativeTolerance = 1e-6
        settings.timeIntegration.newton.absoluteTolerance = 1e-6
        settings.timeIntegration.adaptiveStep = False
        if algorithm == "generalized_alpha":
            settings.timeIntegration.generalizedAlpha.spectralRadius = domain.solver.rho_inf
        label = f"generalized-alpha, rho_inf = {settings.timeIntegration.generalizedAlpha.spectralRadius:g}"
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
    # back from each Exudyn node's frame (the node frame turned by o_p) to the node frame
    Op = np.array([_matrix(o) for o in primary])
    omg = np.einsum("nab,tnb->tna", Op, np.transpose(data["angular_velocity"][:, :, 1:4], (1, 0, 2)))
    rot = np.array([[EulerParameters.from_matrix(R.reshape(3, 3) @ Op[n].T).q for R in data["rotation"][n, :, 1:10]]
                    for n in range(len(domain.nodes))]).transpose(1, 0, 2)
    results = measured(domain, times, pos, rot, vel, omg, wall, dt)
    results.joint_labels = [j.label for j in domain.joints]
    results.reaction_forces, results.reaction_moments = joint_reactions(
        domain, times, rot, np.array([[mbs.GetSensorStoredData(s)[:, 1:4] for s in sensors[k]]
                               for k in ("joint_force", "joint_torque")]).reshape(2, len(domain.joints), len(times), 3))
    results.element_labels = [e.label for e in domain.elements]
    section = {k: np.array([mbs.GetSensorStoredData(s)[:, 1:4] for s in sensors[k]]).reshape(-1, len(times), 3)
               for k in ("section_force", "section_moment")}
    results.section_forces = np.transpose(section["section_force"], (1, 0, 2))
    results.section_moments = np.transpose(section["section_moment"], (1, 0, 2))
    if results_path is not None:
        writer = ResultsWriter(results_path, labels=results.labels, ids=[n.id for n in domain.nodes],
                               items={"joints": results.joint_labels, "elements": results.element_labels}, attrs={
            "engine": "exudyn", "engine_version": exu.__version__, "deck": domain.deck_text,
            "deck_path": str(domain.deck_path), "algorithm": f"{label} (Exudyn)", "dt": dt,
            "energy_note": "evaluated with the reference's definitions on Exudyn's states; external work "
                           "excludes driving motions",
            "reaction_note": "joint reactions from Exudyn's joint sensors (ForceLocal, TorqueLocal of "
                             "ObjectJointGeneric), section resultants from the beams' own ForceLocal/TorqueLocal "
                             "output at the element midpoint; no multipliers (Exudyn's are another set)"})
        for i, t in enumerate(times):
            writer.append({"time": t, "position": pos[i], "rotation": rot[i], "velocity": vel[i],
                           "angular_velocity": omg[i], "violation_norm": results.constraint_violation[i],
                           "reaction_force": results.reaction_forces[i], "reaction_moment": results.reaction_moments[i],
                           "section_force": results.section_forces[i], "section_moment": results.section_moments[i],
                           "velocity_violation_norm": results.velocity_constraint_violation[i],
                           **{k: v[i] for k, v in results.energy.items()}})
        writer.close("completed")
    return {"results": results, "wall_time": wall, "steps": steps, "exudyn_version": exu.__version__,
            "algorithm": label}


PAIRS_ALL = ((2, 1), (2, 0), (0, 1))
"""Exudyn's generic joint with all three rotations locked: its rotation equations are
``t_z0·t_y1``, ``t_z0·t_x1``, ``t_x0·t_y1`` (axes of the marker frames J0, J1)."""
PAIRS_ONE = {0: (1, 2), 1: (2, 0), 2: (0, 1)}
"""One rotation k locked: the equation ``t_a0·t_b1`` with (a, b) = PAIRS_ONE[k]."""


def _marker_torque(locked, lam, J0, J1) -> np.ndarray:
    """Torque on marker 1 (inertial) from the multipliers ``lam`` of Exudyn's rotation equations.

    Each equation ``g = t_a0 · t_b1 = 0`` contributes ``λ (t_a0 × t_b1)`` to the torque on
    marker 1 (δg = δθ₁ · (t_b1 × t_a0), and the constraint force is −λ ∂g).  With two rotations
    locked and f free the equations are ``t_f0·t_k1`` for the locked k; with one, PAIRS_ONE;
    with three, PAIRS_ALL (Exudyn's ObjectJointGeneric documentation).
    """
    ks = [k for k in range(3) if locked[k]]
    if len(ks) == 3:
        pairs = {k: PAIRS_ALL[k] for k in ks}
    elif len(ks) == 2:
        free = next(k for k in range(3) if not locked[k])
        pairs = {k: (free, k) for k in ks}
    else:
        pairs = {k: PAIRS_ONE[k] for k in ks}
    torque = np.zeros(3)
    for k, (a, b) in pairs.items():
        torque += lam[k] * np.cross(J0[:, a], J1[:, b])
    return torque


def joint_reactions(domain, times, rot, local) -> tuple[np.ndarray, np.ndarray]:
    """Reactions on each joint's body_i, inertial, from Exudyn's joint sensors.

    ``local`` (2, J, n, 3): ``ForceLocal`` and ``TorqueLocal`` of the generic joint
    carrying each deck joint.  ``ForceLocal`` holds the multipliers of the
    translational equations, in the joint frame J0 of marker 0 (``A_0(t) f_0``): the
    force on marker 1 is ``−J0 F_local``.  ``TorqueLocal`` holds the multipliers of
    the rotation equations, which are not torque components in general (Exudyn's
    documentation says so): the torque is rebuilt by :func:`_marker_torque` from
    the current marker frames.  Marker 1 is body_i for every kind but the universal
    joint, whose markers are swapped (then the reactions on body_i are the
    opposite).  Checked against the reference for every joint kind on a tilted,
    spinning bar (``tests/test_crosscheck.py``) and on a held bar against the closed
    form (``tests/test_observables.py``).  A drive merged into its revolute
    (translational) joint takes the torque (force) along the axis; the joint keeps
    the rest — the reference's split between a joint and its drive.  Both act at the
    joint point (the markers coincide there).
    """
    J, n = local.shape[1], local.shape[2]
    force, moment = np.zeros((n, J, 3)), np.zeros((n, J, 3))
    drives = {id(_partner(domain, j)): j for j in domain.joints if j.kind in MERGES}
    for k, j in enumerate(domain.joints):
        carrier = _partner(domain, j) if j.kind in MERGES else j  # the Exudyn joint (and its markers)
        swapped = carrier.kind == "universal"
        locked = [1] * 6 if id(carrier) in drives else AXES[carrier.kind]
        par = carrier.body_fixed()
        frames = {"i": (carrier.body_i, par[6:15].reshape(3, 3)), "j": (carrier.body_j, par[15:24].reshape(3, 3))}
        m0, m1 = (frames["i"], frames["j"]) if swapped else (frames["j"], frames["i"])
        sign = -1.0 if swapped else 1.0  # marker 1 is body_i unless swapped
        drive = drives.get(id(carrier))
        for t in range(n):
            J0, J1 = ((np.eye(3) if body is None else _matrix(rot[t, body.id])) @ f for body, f in (m0, m1))
            F = -sign * J0 @ local[0, k, t]
            J0_rot = J0
            if drive is not None and drive.kind == "rotation_drive":
                # the offset user function turns J0 about its z axis by the prescribed angle: the
                # rotation equations use the turned axes
                tf = drive.time_function
                th = tf.integral(times[t]) if drive.mode == "velocity" else tf(times[t])
                c, s_ = np.cos(th), np.sin(th)
                J0_rot = J0 @ np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
            M = sign * _marker_torque(locked[3:], local[1, k, t], J0_rot, J1)
            axis = J0[:, 2]
            if j.kind == "rotation_drive":
                F, M = np.zeros(3), np.dot(M, axis) * axis
            elif j.kind == "displacement_drive":
                F, M = np.dot(F, axis) * axis, np.zeros(3)
            elif id(j) in drives:
                if drives[id(j)].kind == "rotation_drive":
                    M = M - np.dot(M, axis) * axis
                else:
                    F = F - np.dot(F, axis) * axis
            force[t, k], moment[t, k] = F, M
    return force, moment


def measured(domain, times, pos, rot, vel, omg, wall, dt):
    """Constraint residuals and energies of a trajectory, by the reference's definitions."""
    from reference.evaluation.forces import generalized_forces
    from reference.io.results import Results
    from reference.state import element_work

    model = domain.model
    n, N = len(times), len(domain.nodes)
    phi = np.zeros(n)
    phid = np.zeros(n)
    kinetic, strain, work = np.zeros(n), np.zeros(n), np.zeros(n)
    S, F, A, ework = np.zeros((N, 6)), np.zeros((N, 6)), np.zeros(9), element_work(model)
    G, angle, prim_phi, prim_B = np.zeros((N, 6)), np.zeros(model.force_elements.kind.shape[0]), np.zeros(10), np.zeros(120)
    power = np.zeros(n)
    for i in range(n):
        if model.n_constraints:
            PHI, PHIt, Bg, _ = domain.constraint_matrices(model, pos[i], rot[i], times[i])
            V = np.concatenate([vel[i], omg[i]], axis=1).reshape(-1)
            phi[i], phid[i] = np.linalg.norm(PHI), np.linalg.norm(Bg @ V + PHIt)
        kinetic[i] = 0.5 * np.sum(model.nodes.mass[:, None] * vel[i] ** 2) + 0.5 * np.einsum("ni,nij,nj->", omg[i], model.nodes.inertia, omg[i])
        # the elements' and springs' energy is strain energy, the actuators external loads
        strain[i] = generalized_forces(model, ework, pos[i], rot[i], vel[i], omg[i], times[i], S, F, G, angle, A,
                                       prim_phi, prim_B)[0]
        power[i] = np.sum(F[:, :3] * vel[i]) + np.sum(F[:, 3:] * omg[i])
        if i > 0:
            work[i] = work[i - 1] + 0.5 * (power[i] + power[i - 1]) * (times[i] - times[i - 1])
    return Results(time=times, labels=[nd.label for nd in domain.nodes], positions=pos, rotations=rot, velocities=vel,
                   angular_velocities=omg, energy={"kinetic": kinetic, "strain": strain, "external_work": work,
                                                   "dissipated": np.full(n, np.nan)},
                   constraint_violation=phi, velocity_constraint_violation=phid, wall_time=wall,
                   attrs={"engine": "exudyn", "dt": dt})
