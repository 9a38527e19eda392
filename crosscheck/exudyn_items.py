"""The translation of a Domain into Exudyn (1.13), one translator per item kind.

:func:`crosscheck.exudyn_model.build` makes a :class:`Translation` (the Exudyn
system and the items made so far) and calls the translators of
:data:`TRANSLATORS` in this order, then :func:`step_function` and :func:`sensors`:

=============================  ==========================================================  ====================
deck item                      Exudyn item                                                 translator
=============================  ==========================================================  ====================
node                           ``NodeRigidBodyEP`` (position, Euler parameters,            :func:`nodes`
                               velocities); a beam node's Exudyn node carries the
                               section frame of its first element end (markers turn
                               back to the node frame)
rigid body / rigid bar         ``ObjectRigidBody`` (mass, body-frame inertia)              :func:`nodes`
Beam2 element                  ``ObjectBeamGeometricallyExact`` (same length and           :func:`beams`
                               section) between Exudyn nodes in its own section frames;
                               an end whose section frame differs from the node's (a
                               kink at a shared node, the chords of an arc) gets its own
                               Exudyn node, welded to the node's by an
                               ``ObjectJointGeneric`` locking all axes
joint (any kind)               ``ObjectJointGeneric`` between markers carrying the joint   :func:`joints`
                               frame; the locked axes of the kind
rotation / displacement drive  merged into the revolute / translational joint at the       :func:`joints`
                               same place: all axes locked, the motion as an offset user
                               function
clamp, fixed coordinates       ``ObjectJointGeneric`` to ground locking those coordinates  :func:`clamps`
dead / follower force, moment  ``LoadForceVector`` / ``LoadTorqueVector`` (``bodyFixed``),  :func:`loads`
                               scaled by the time function once per step (at the step's
                               end time, :func:`step_function`); a force at a point on a
                               marker at that body-fixed offset
line load                      its lumped nodal loads (``LineLoad.nodal_loads``), as above  :func:`loads`
gravity                        ``LoadMassProportional`` on every body and beam element     :func:`gravity`
mass-proportional damping      an ``ObjectConnectorRigidBodySpringDamper`` per node to     :func:`damping`
                               ground (Exudyn ignores the beam's own damping matrix)
point-to-point spring          ``ObjectConnectorSpringDamper`` (reference length,          :func:`force_elements`
                               stiffness, damping; the actuator as its ``force``, set
                               once per step)
rotational spring              ``ObjectConnectorTorsionalSpringDamper`` between markers    :func:`force_elements`
                               carrying the element frame (body j first), with a
                               ``NodeGenericData`` for the continuous angle; ``offset`` =
                               rest angle
bushing                        ``ObjectConnectorRigidBodySpringDamper`` (body i first,     :func:`force_elements`
                               diagonal stiffness and damping in the element frame;
                               Exudyn's rotation measure agrees with the reference's to
                               first order)
(outputs)                      ``SensorNode``, ``SensorObject``, ``SensorBody``            :func:`sensors`
=============================  ==========================================================  ====================

What cannot be translated is refused before any translator runs
(:func:`crosscheck.exudyn_model.check_supported`).
"""

from __future__ import annotations

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
"""Joint kind → the axes Exudyn's generic joint locks (x y z translations, then rotations)."""
MERGES = {"rotation_drive": "revolute", "displacement_drive": "translational"}
"""Drive kind → the joint kind it is merged into."""


def matrix(q) -> np.ndarray:
    """The rotation matrix of Euler parameters ``q``."""
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


def size(domain) -> float:
    """The model's size: the largest node coordinate (at least 1)."""
    return max([1.0] + [float(np.max(np.abs(n.position))) for n in domain.nodes])


def node_offset(domain, node, s):
    """A joint's body-fixed offset at a beam node, snapped to zero below round-off (else None)."""
    return np.zeros(3) if np.linalg.norm(s) <= 1e-12 * size(domain) else None


def partner(domain, drive):
    """The revolute (translational) joint a rotation (displacement) drive is merged into, or None."""
    for j in domain.joints:
        if j.kind == MERGES.get(drive.kind) and {id(j.body_i), id(j.body_j)} == {id(drive.body_i), id(drive.body_j)} \
                and np.allclose(j.point, drive.point, atol=1e-12) and np.allclose(j.frame[:, 2], drive.frame[:, 2]):
            return j
    return None


class Translation:
    """The Exudyn system being built and the items made so far, shared by the translators.

    Attributes: ``nodes`` (the Exudyn node of each deck node), ``bodies`` (deck node id →
    Exudyn rigid body), ``beams`` (the Exudyn beam of each element), ``joints`` (id of a
    deck joint → its Exudyn joint), ``loads`` ((load, vector, time function), set per
    step), ``actuators`` ((connector, force function)), ``primary`` (N, 4): per node, the
    offset from the node frame to its Exudyn node's frame (identity except at beam nodes
    whose first element end is kinked against the node frame).  ``lie_group``: every node a
    ``NodeRigidBodyRotVecLG`` (position and rotation vector, six coordinates and no algebraic
    equation: Exudyn's sparse eigen-solve, :mod:`crosscheck.exudyn_modes`) in place of a
    ``NodeRigidBodyEP`` (seven coordinates, one normalisation equation).
    """

    def __init__(self, domain, exu, eii, lie_group: bool = False):
        self.domain, self.exu, self.eii, self.model = domain, exu, eii, domain.model
        self.lie_group = lie_group
        self.SC = exu.SystemContainer()
        self.mbs = self.SC.AddSystem()
        self.ground = self.mbs.AddObject(eii.ObjectGround())
        self.beam_nodes = {i for e in domain.elements for i in e.nodes}
        self.state = domain.initial_conditions()  # includes the consistent projection if the deck asks for it
        self.primary = np.tile([1.0, 0.0, 0.0, 0.0], (len(domain.nodes), 1))
        # each beam element's family data and row (beam2 only: exudyn_model.check_supported)
        self.element_rows = {int(e): (data, r) for data in self.model.elements for r, e in enumerate(data.index)}
        seen = set()
        for e, element in enumerate(domain.elements):
            data, r = self.element_rows[e]
            for a, i in enumerate(element.nodes):
                if i not in seen:
                    seen.add(i)
                    self.primary[i] = data.offset[r, a]
        self.nodes, self.bodies, self.beams, self.joints = [], {}, [], {}
        self.reduced = set()  # ids of nodes of reduced beams: no Exudyn node (crosscheck.exudyn_reduced)
        self.loads, self.actuators, self.user_functions = [], [], []

    def exudyn_node(self, i: int, o) -> int:
        """An Exudyn node at deck node ``i`` in the node frame turned by ``o``, with its velocities."""
        node = self.domain.nodes[i]
        p = _qmul(node.rotation, o)
        w = matrix(o).T @ self.state.w[i]
        if self.lie_group:  # rotation vector; the velocity coordinates carry the body-frame angular velocity
            return self.mbs.AddNode(self.eii.NodeRigidBodyRotVecLG(
                referenceCoordinates=list(node.position) + list(EulerParameters(p).log()),
                initialVelocities=list(self.state.v[i]) + list(w)))
        qd = EulerParameters(p).kinematic_rate(w)
        return self.mbs.AddNode(self.eii.NodeRigidBodyEP(referenceCoordinates=list(node.position) + list(p),
                                                         initialVelocities=list(self.state.v[i]) + list(qd)))

    def marker(self, node, R=np.eye(3), p=np.zeros(3)) -> int:
        """A marker on ``node`` (None: the ground) with the body-fixed frame ``R`` at offset ``p``."""
        eii, mbs = self.eii, self.mbs
        if node is None:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=self.ground, localHT=_ht(R, p)))
        if node.id in self.bodies:
            return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=self.bodies[node.id], localHT=_ht(R, p)))
        # a beam node: the Exudyn node's frame is the node frame turned by o_p; no offset (snapped)
        Op = matrix(self.primary[node.id])
        return mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=self.nodes[node.id], localHT=_ht(Op.T @ R, np.zeros(3))))


def nodes(t: Translation) -> None:
    """Every node, and a rigid body on each node that no element uses; none for a node of a reduced beam
    (``t.reduced``: :mod:`crosscheck.exudyn_reduced` makes the reduced body)."""
    for n in t.domain.nodes:
        if n.id in t.reduced:
            t.nodes.append(None)
            continue
        t.nodes.append(t.exudyn_node(n.id, t.primary[n.id]))
        if n.id not in t.beam_nodes:
            J = n.inertia
            t.bodies[n.id] = t.mbs.AddObject(t.eii.ObjectRigidBody(
                mass=n.mass, inertia=[J[0, 0], J[1, 1], J[2, 2], J[1, 2], J[0, 2], J[0, 1]], nodeNumber=t.nodes[-1]))


def beams(t: Translation) -> None:
    """Every Beam2 element, between Exudyn nodes in its own section frames (welded where kinked)."""
    eii, mbs = t.eii, t.mbs
    for e, element in enumerate(t.domain.elements):
        sec = element.formulation.section
        section = t.exu.BeamSection()
        section.stiffnessMatrix = np.diag(sec.stiffness).tolist()
        section.massPerLength = sec.rhoA
        section.inertia = np.diag(sec.rotary_inertia).tolist()
        ends = []
        data, r = t.element_rows[e]
        for a, i in enumerate(element.nodes):
            o = data.offset[r, a]
            if abs(abs(o @ t.primary[i]) - 1.0) < 1e-14:
                ends.append(t.nodes[i])
                continue
            ends.append(t.exudyn_node(i, o))
            weld = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=ends[-1]))
            mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[t.marker(t.domain.nodes[i], matrix(o)), weld],
                                                 constrainedAxes=[1] * 6))
        t.beams.append(mbs.AddObject(eii.ObjectBeamGeometricallyExact(
            nodeNumbers=ends, length=float(data.L0[r]), sectionData=section)))


def _drive_offset(drive):
    """The offset user function of a joint carrying ``drive``: its prescribed angle or displacement."""
    tf, velocity, slot = drive.time_function, drive.mode == "velocity", 5 if drive.kind == "rotation_drive" else 2

    def offset(mbs_, time, item, parameters):
        out = [0.0] * 6
        out[slot] = tf.integral(time) if velocity else tf(time)
        return out

    return offset


def joints(t: Translation) -> None:
    """Every joint as a generic joint; a drive merged into its revolute / translational joint."""
    domain = t.domain
    drives = {id(partner(domain, j)): j for j in domain.joints if j.kind in MERGES}
    for j in domain.joints:
        if j.kind in MERGES:
            continue
        par = j.body_fixed()
        s_i, s_j, f_i, f_j = par[0:3], par[3:6], par[6:15].reshape(3, 3), par[15:24].reshape(3, 3)
        s_i = s_i if j.body_i is None or j.body_i.id in t.bodies else node_offset(domain, j.body_i, s_i)
        s_j = s_j if j.body_j is None or j.body_j.id in t.bodies else node_offset(domain, j.body_j, s_j)
        m1 = t.marker(j.body_i, f_i, s_i)
        m0 = t.marker(j.body_j, f_j, s_j)
        axes, options = list(AXES[j.kind]), {}
        drive = drives.get(id(j))
        if drive is not None:
            axes = [1] * 6
            options["offsetUserFunction"] = _drive_offset(drive)
            t.user_functions.append(options["offsetUserFunction"])
        # a universal joint's locked rotation pairs the pin of body i (u1) with the pin of body j (u2):
        # Exudyn's generic joint locks marker 0's x against marker 1's y, so body i goes first there
        order = [m1, m0] if j.kind == "universal" else [m0, m1]
        number = t.mbs.AddObject(t.eii.ObjectJointGeneric(markerNumbers=order, constrainedAxes=axes, **options))
        t.joints[id(j)] = number
        if drive is not None:
            t.joints[id(drive)] = number


def clamps(t: Translation) -> None:
    """Clamps and fixed coordinates: a generic joint to ground locking those coordinates."""
    for bc in t.domain.boundary_conditions:
        node = t.domain.node(bc.node)
        axes = [1 if k in bc.dofs else 0 for k in range(6)]
        t.mbs.AddObject(t.eii.ObjectJointGeneric(
            markerNumbers=[t.marker(None, matrix(node.rotation), node.position), t.marker(node)], constrainedAxes=axes))


def loads(t: Translation) -> None:
    """Nodal loads and line loads (as their lumped nodal loads), scaled per step by :func:`step_function`."""
    eii = t.eii
    for ld in t.domain.loading:
        if not isinstance(ld, (NodalLoad, LineLoad)):
            continue
        for nl in ld.nodal_loads() if isinstance(ld, LineLoad) else [ld]:
            node = t.domain.node(nl.node)
            arm = np.zeros(3)
            if nl.point is not None and not nl.moment:
                arm = matrix(node.rotation).T @ (np.asarray(nl.point, dtype=float) - node.position)
            cls = eii.LoadTorqueVector if nl.moment else eii.LoadForceVector
            number = t.mbs.AddLoad(cls(markerNumber=t.marker(node, np.eye(3), arm),
                                       loadVector=list(np.asarray(nl.vector) * nl.time_function(0.0)),
                                       bodyFixed=bool(nl.follower)))
            t.loads.append((number, np.asarray(nl.vector, dtype=float), nl.time_function))


def gravity(t: Translation) -> None:
    """Gravity: a mass-proportional load on every rigid body and beam element."""
    eii, mbs = t.eii, t.mbs
    for ld in t.domain.loading:
        if isinstance(ld, Gravity):
            for obj in list(t.bodies.values()) + t.beams:
                mbs.AddLoad(eii.LoadMassProportional(markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=obj)),
                                                     loadVector=list(np.asarray(ld.g, dtype=float))))


def damping(t: Translation) -> None:
    """Mass-proportional damping: a damper from each node to ground."""
    c = t.domain.solver.damping
    if c <= 0.0:
        return
    for n in t.domain.nodes:
        d = np.zeros((6, 6))
        d[:3, :3] = c * t.model.nodes.mass[n.id] * np.eye(3)
        d[3:, 3:] = c * t.model.nodes.inertia[n.id]
        # the node as marker 0 (in the node frame): the connector damps the relative angular velocity
        # in marker 0's frame, i.e. the body frame, as the reference's −c J ω (full J at a kinked node;
        # translations: isotropic c m)
        t.mbs.AddObject(t.eii.ObjectConnectorRigidBodySpringDamper(
            markerNumbers=[t.marker(n), t.marker(None, matrix(n.rotation), n.position)],
            stiffness=np.zeros((6, 6)).tolist(), damping=d.tolist()))


def force_elements(t: Translation) -> None:
    """Point-to-point springs (with their actuators), rotational springs and bushings."""
    eii, mbs = t.eii, t.mbs
    for fe in t.domain.force_elements:
        par = fe.body_fixed()
        s_i, s_j, f_i, f_j = par[0:3], par[3:6], par[6:15].reshape(3, 3), par[15:24].reshape(3, 3)
        k, c = fe.stiffness_damping()
        if fe.kind == POINT_TO_POINT:
            number = mbs.AddObject(eii.ObjectConnectorSpringDamper(
                markerNumbers=[t.marker(fe.body_j, np.eye(3), s_j), t.marker(fe.body_i, np.eye(3), s_i)],
                referenceLength=float(fe.rest()), stiffness=float(k[0]), damping=float(c[0])))
            if fe.force_function is not None:
                t.actuators.append((number, fe.force_function))
        elif fe.kind == ROTATIONAL:  # (the markers' position does not matter)
            angle = mbs.AddNode(eii.NodeGenericData(numberOfDataCoordinates=1, initialCoordinates=[0.0]))
            mbs.AddObject(eii.ObjectConnectorTorsionalSpringDamper(
                markerNumbers=[t.marker(fe.body_j, f_j), t.marker(fe.body_i, f_i)], nodeNumber=angle,
                stiffness=float(k[0]), damping=float(c[0]), offset=float(fe.rest())))
        elif fe.kind == BUSHING:
            mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                markerNumbers=[t.marker(fe.body_i, f_i, s_i), t.marker(fe.body_j, f_j, s_j)],
                stiffness=np.diag(k).tolist(), damping=np.diag(c).tolist()))


TRANSLATORS = (nodes, beams, joints, clamps, loads, gravity, damping, force_elements)
"""The translators, in the order :func:`crosscheck.exudyn_model.build` calls them (the module docstring's table)."""


def step_function(t: Translation, progress=None, t_end: float = 1.0) -> None:
    """Once per step, the loads and actuator forces at the step's time, and the progress."""

    def pre_step(mbs_, time):
        # Exudyn passes the step's end time (the implicit solver's equilibrium time): the loads are
        # set to their value there, once per step
        for number, vec, tf in t.loads:
            mbs_.SetLoadParameter(number, "loadVector", list(vec * tf(time)))
        for number, tf in t.actuators:
            mbs_.SetObjectParameter(number, "force", float(tf(time)))
        if progress is not None:
            progress(min(time / t_end, 1.0), time)
        return True

    if t.loads or t.actuators or progress is not None:
        t.user_functions.append(pre_step)
        t.mbs.SetPreStepUserFunction(pre_step)


def sensors(t: Translation) -> dict:
    """The sensors the results are read from: kind → one sensor per node, joint or element."""
    eii, mbs, OV = t.eii, t.mbs, t.exu.OutputVariableType
    out = {kind: [mbs.AddSensor(eii.SensorNode(nodeNumber=nd, storeInternal=True, writeToFile=False,
                                               outputVariableType=ov)) for nd in t.nodes]
           for kind, ov in (("position", OV.Position), ("velocity", OV.Velocity),
                            ("angular_velocity", OV.AngularVelocityLocal), ("rotation", OV.RotationMatrix))}
    for kind, ov in (("joint_force", OV.ForceLocal), ("joint_torque", OV.TorqueLocal)):
        out[kind] = [mbs.AddSensor(eii.SensorObject(objectNumber=t.joints[id(j)], storeInternal=True,
                                                    writeToFile=False, outputVariableType=ov))
                     for j in t.domain.joints]
    for kind, ov in (("section_force", OV.ForceLocal), ("section_moment", OV.TorqueLocal)):
        out[kind] = [mbs.AddSensor(eii.SensorBody(bodyNumber=obj, localPosition=[0.0, 0.0, 0.0], storeInternal=True,
                                                  writeToFile=False, outputVariableType=ov))
                     for obj in t.beams]
    return out
