"""The embedded-beam roll-up built in Exudyn (1.13), for the benchmark and the cross-check.

Same data as ``models/embedded_beam.toml``: a cantilever along +x meshed with
``ObjectBeamGeometricallyExact`` elements on Euler-parameter nodes, clamped at
x = 0 by a generic joint to ground, a tip torque about −y growing as
``M(t) = t π EI/L``; mass-proportional damping built from one
``ObjectConnectorRigidBodySpringDamper`` per node to ground with zero stiffness
and damping ``c·m_i`` (translations) and ``c·J_i`` (rotations) — Exudyn ignores
the beam's own damping matrix (EXUDYN_NOTES.md).  Solved by Exudyn's
generalized-α at a fixed step with Newton tolerances 1e-6 (its default 1e-8
stalls and makes the step adapt).

Only Exudyn's documented Python interface is used; nothing is copied from it.
"""

from __future__ import annotations

import time

import numpy as np


def solve_rollup_exudyn(L=10.0, n_elements=12, EA=4.0, GA=4.0, GJ=100.0, EI=100.0, rhoA=6.4e-7,
                        rhoJ=(1.6e-5, 1.6e-5, 1.6e-5), damping=25.0, dt=2e-4, t_end=2.0, output_every=50,
                        static=False) -> dict:
    """Solve the roll-up in Exudyn; return time histories and the solver's wall time.

    Returns
    -------
    dict
        ``time`` (n,), ``tip_position`` (n,3), ``tip_rotation`` (n,3,3) rotation
        matrices, ``node_positions`` (n,N,3), ``wall_time`` [s] of the solve call
        only, ``steps`` taken by the solver, ``exudyn_version``.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    L0 = L / n_elements
    section = exu.BeamSection()
    section.stiffnessMatrix = np.diag([EA, GA, GA, GJ, EI, EI]).tolist()
    section.massPerLength = rhoA
    section.inertia = np.diag(rhoJ).tolist()

    ground = mbs.AddObject(eii.ObjectGround())
    m_ground = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    nodes, markers = [], []
    for i in range(n_elements + 1):
        ref = [i * L0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
        nodes.append(mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=ref)))
        markers.append(mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[-1])))
    for i in range(n_elements):
        mbs.AddObject(eii.ObjectBeamGeometricallyExact(nodeNumbers=[nodes[i], nodes[i + 1]], length=L0,
                                                       sectionData=section))
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[m_ground, markers[0]], constrainedAxes=[1, 1, 1, 1, 1, 1]))
    if damping > 0.0 and not static:
        for i in range(1, n_elements + 1):
            share = L0 if i < n_elements else L0 / 2
            d = [damping * rhoA * share] * 3 + [damping * share * j for j in rhoJ]
            mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                markerNumbers=[m_ground, markers[i]], stiffness=np.zeros((6, 6)).tolist(),
                damping=np.diag(d).tolist()))
    m_full = 2.0 * np.pi * EI / L
    # at t = 0 the torque is zero (Exudyn computes its initial accelerations with this value)
    load = mbs.AddLoad(eii.LoadTorqueVector(markerNumber=markers[-1],
                                            loadVector=[0.0, -m_full if static else 0.0, 0.0]))
    if not static:
        # the load history M(t) = t π EI/L, set once per step: as the reference engine evaluates its
        # loads once per step, and far cheaper than a Python load user function called at every
        # Newton evaluation
        def pre_step(mbs_, t):
            mbs_.SetLoadParameter(load, "loadVector", [0.0, -m_full * min(t + dt, 2.0) / 2.0, 0.0])
            return True

        mbs.SetPreStepUserFunction(pre_step)
    sensors = [mbs.AddSensor(eii.SensorNode(nodeNumber=n, storeInternal=True, writeToFile=False,
                                            outputVariableType=exu.OutputVariableType.Position)) for n in nodes]
    tip_rot = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[-1], storeInternal=True, writeToFile=False,
                                           outputVariableType=exu.OutputVariableType.RotationMatrix))
    mbs.Assemble()

    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = output_every * dt
    settings.timeIntegration.verboseMode = 0
    settings.staticSolver.verboseMode = 0
    n_steps = int(round(t_end / dt))
    t0 = time.perf_counter()
    if static:
        settings.staticSolver.numberOfLoadSteps = 40
        settings.staticSolver.newton.relativeTolerance = 1e-10
        ok = exu.SolveStatic(mbs, settings)
        steps = 40
    else:
        settings.timeIntegration.numberOfSteps = n_steps
        settings.timeIntegration.endTime = t_end
        settings.timeIntegration.newton.relativeTolerance = 1e-6
        settings.timeIntegration.newton.absoluteTolerance = 1e-6
        settings.timeIntegration.adaptiveStep = False
        solver = exu.MainSolverImplicitSecondOrder()
        ok = solver.SolveSystem(mbs, settings)
        steps = int(solver.it.currentStepIndex) - 1  # the index has moved past the last step
    wall = time.perf_counter() - t0
    if not ok:
        raise RuntimeError("Exudyn's solver did not converge on the roll-up")
    if not static and steps != n_steps:
        raise RuntimeError(f"Exudyn took {steps} steps instead of {n_steps}: it reduced the step")
    pos = np.array([mbs.GetSensorStoredData(s) for s in sensors])  # (N, n, 4): t, x, y, z
    rot = mbs.GetSensorStoredData(tip_rot)
    return {
        "time": pos[0, :, 0], "tip_position": pos[-1, :, 1:4], "tip_rotation": rot[:, 1:10].reshape(-1, 3, 3),
        "node_positions": np.transpose(pos[:, :, 1:4], (1, 0, 2)), "wall_time": wall, "steps": steps,
        "exudyn_version": exu.__version__,
    }
