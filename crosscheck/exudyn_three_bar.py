"""The three-bar mechanism built in Exudyn (1.13), for the benchmark and the cross-check.

Same data as ``models/three_bar.toml`` (BENCHMARKS.md §2): rigid crank and
rocker as ``ObjectRigidBody`` on Euler-parameter nodes (inertia of the uniform
bar about its centre), the coupler as ``n_coupler``
``ObjectBeamGeometricallyExact`` elements, revolute joints as
``ObjectJointGeneric`` with the rotation about z free; the crank drive is a
generic joint to ground with all axes locked and an offset user function on
the rotation about z (EXUDYN_NOTES.md).  Generalized-α at a fixed step with
Newton tolerances 1e-6.  Only Exudyn's documented Python interface is used.
"""

from __future__ import annotations

import time

import numpy as np


def crank_rotation(t: float, omega: float = np.pi / 2, t_ramp: float = 2.0) -> float:
    """Crank rotation from the initial 90° assembly: ∫ Ω (3x² − 2x³), x = t/T_r, then Ω (BENCHMARKS §2)."""
    x = min(t / t_ramp, 1.0)
    return omega * t_ramp * (x**3 - x**4 / 2) + omega * max(t - t_ramp, 0.0)


def solve_three_bar_exudyn(dt=2e-4, t_end=10.0, output_every=50, n_coupler=4, EA=1e5, GA=1e5, GJ=1e3, EI=1e3,
                           rhoA=1.0, rhoJ=(0.02, 0.01, 0.01)) -> dict:
    """Solve the three-bar in Exudyn; return time histories and the solver's wall time.

    Returns
    -------
    dict
        ``time`` (n,), ``crank`` and ``rocker`` centre positions (n,3),
        ``coupler`` node positions (n, n_coupler+1, 3), ``wall_time`` [s] of the
        solve call only, ``steps``, ``exudyn_version``.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())

    def bar(centre, length, along_y):
        m = rhoA * length
        axial, transverse = rhoJ[0] * length, rhoJ[1] * length + m * length**2 / 12
        inertia = [transverse, axial, transverse, 0.0, 0.0, 0.0] if along_y else [axial, transverse, transverse, 0, 0, 0]
        node = mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=list(centre) + [1.0, 0.0, 0.0, 0.0]))
        body = mbs.AddObject(eii.ObjectRigidBody(mass=m, inertia=inertia, nodeNumber=node))
        return node, body

    crank_node, crank = bar([0.0, 0.5, 0.0], 1.0, True)
    rocker_node, rocker = bar([4.0, 2.0, 0.0], 4.0, True)

    A, B = np.array([0.0, 1.0, 0.0]), np.array([4.0, 4.0, 0.0])
    phi = np.arctan2(B[1] - A[1], B[0] - A[0])
    ep = [np.cos(phi / 2), 0.0, 0.0, np.sin(phi / 2)]
    section = exu.BeamSection()
    section.stiffnessMatrix = np.diag([EA, GA, GA, GJ, EI, EI]).tolist()
    section.massPerLength = rhoA
    section.inertia = np.diag(rhoJ).tolist()
    L0 = np.linalg.norm(B - A) / n_coupler
    coupler = [mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=list(A + (B - A) * k / n_coupler) + ep))
               for k in range(n_coupler + 1)]
    for k in range(n_coupler):
        mbs.AddObject(eii.ObjectBeamGeometricallyExact(nodeNumbers=[coupler[k], coupler[k + 1]], length=L0,
                                                       sectionData=section))

    def body_marker(body, local):
        return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body, localPosition=list(local)))

    # the coupler's node frames are turned by phi about z: give their markers the inverse turn,
    # so that every joint frame is the inertial one at t = 0
    ht = np.eye(4)
    ht[:3, :3] = np.array([[np.cos(phi), np.sin(phi), 0.0], [-np.sin(phi), np.cos(phi), 0.0], [0.0, 0.0, 1.0]])
    coupler_start = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=coupler[0], localHT=ht.tolist()))
    coupler_end = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=coupler[-1], localHT=ht.tolist()))
    revolute = [1, 1, 1, 1, 1, 0]
    theta_0 = 0.0

    def drive(mbs_, t, item, parameters):
        return [0.0, 0.0, 0.0, 0.0, 0.0, crank_rotation(t) + theta_0]

    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[body_marker(ground, [0, 0, 0]), body_marker(crank, [0, -0.5, 0])],
                                         constrainedAxes=[1, 1, 1, 1, 1, 1], offsetUserFunction=drive))
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[body_marker(crank, [0, 0.5, 0]), coupler_start],
                                         constrainedAxes=revolute))
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[coupler_end, body_marker(rocker, [0, 2.0, 0])],
                                         constrainedAxes=revolute))
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[body_marker(ground, [4, 0, 0]), body_marker(rocker, [0, -2.0, 0])],
                                         constrainedAxes=revolute))

    def sensor(node):
        return mbs.AddSensor(eii.SensorNode(nodeNumber=node, storeInternal=True, writeToFile=False,
                                            outputVariableType=exu.OutputVariableType.Position))

    s_crank, s_rocker = sensor(crank_node), sensor(rocker_node)
    s_coupler = [sensor(n) for n in coupler]
    mbs.Assemble()

    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = output_every * dt
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
    if not ok:
        raise RuntimeError("Exudyn's solver did not converge on the three-bar mechanism")
    if steps != n_steps:
        raise RuntimeError(f"Exudyn took {steps} steps instead of {n_steps}: it reduced the step")
    data = {name: mbs.GetSensorStoredData(s) for name, s in (("crank", s_crank), ("rocker", s_rocker))}
    return {
        "time": data["crank"][:, 0], "crank": data["crank"][:, 1:4], "rocker": data["rocker"][:, 1:4],
        "coupler": np.transpose(np.array([mbs.GetSensorStoredData(s)[:, 1:4] for s in s_coupler]), (1, 0, 2)),
        "wall_time": wall, "steps": steps, "exudyn_version": exu.__version__,
    }
