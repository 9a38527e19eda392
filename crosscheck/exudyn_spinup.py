"""The spin-up of ``models/rotating_blade_reduced.toml``, the blade as Exudyn's ``ObjectFFRFreducedOrder`` (issue 39).

The blade reduced as a floating frame **clamped at its root** (Shabana's "clamped" reference condition,
:func:`reference.reduced.craig_bampton.clamped_modes`: the root node's six coordinates held, the deck's mode count
of fixed-interface modes, the invariants about the root), so that the hub's drive acts on the frame node itself:
Exudyn's generic joint between the ground and the frame, all axes locked, the deck's rotation drive as its offset
(:func:`crosscheck.exudyn_items._drive_offset`).  The modes, invariants and the stress stiffness
``K_G = centrifugal_stiffening(…, axis z, origin the root)`` are flexmbs's; the stiffness enters as Exudyn's
force user function ``−ω_z² K_G q`` (:func:`crosscheck.exudyn_reduced.reduced_body`; the deck spins about z only).
The Craig–Bampton basis of the deck (the root the interface) spans the same motions as this one: the six rigid
motions and the same fixed-interface modes.

:func:`spinup` returns the tip's lead-lag deflection in the hub frame; the report's section and
tests/test_reduced_spinup.py compare it with the full geometrically exact blade run by flexmbs.
"""

from __future__ import annotations

import time

import numpy as np

from crosscheck.exudyn_items import Translation, _drive_offset
from crosscheck.exudyn_model import Unsupported, solver_settings
from crosscheck.exudyn_reduced import reduced_body
from reference.reduced.body import ReducedBody
from reference.reduced.craig_bampton import clamped_modes
from reference.reduced.invariants import invariants
from reference.reduced.stiffening import centrifugal_stiffening


def clamped_blade(domain, reduction, stiffening: bool) -> tuple:
    """``(body, 𝕂)``: the blade of ``reduction`` (:class:`reference.io.deck_reduce.Reduction`, its first interface
    the root) as a :class:`~reference.reduced.body.ReducedBody` with the frame at the root, and its stress
    stiffness (3, 3, r, r) for a spin about z (``None`` without ``stiffening``)."""
    beam, root = reduction.beam, reduction.interfaces[0]
    modes = clamped_modes(beam, root, reduction.modes)
    body = ReducedBody(reduction.label, beam, modes, invariants(beam, modes, origin=beam.x[root]))
    if not stiffening:
        return body, None
    K = np.zeros((3, 3, body.n_modes, body.n_modes))
    K[2, 2] = centrifugal_stiffening(domain, beam, modes, (root,), (0.0, 0.0, 1.0), beam.x[root])
    return body, K


def spinup(path, stiffening: bool = True, t_end: float | None = None) -> dict:
    """Run the deck at ``path`` (its one reduced beam, driven at its root by a rotation drive) in Exudyn; returns
    ``time`` (n_t,), ``lag`` (n_t,) the tip's deflection along the hub frame's y [m], ``wall_time`` [s].

    Raises
    ------
    crosscheck.exudyn_model.Unsupported
        One line: not a single reduced beam driven at its root, or Exudyn's solver stopped.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    from reference.io.deck import load_deck
    from reference.io.deck_reduce import collecting

    overrides = {"t_end": t_end} if t_end else None
    with collecting() as found:
        domain = load_deck(path, overrides).domain
    (reduction,) = found.values()
    root = int(reduction.beam.nodes[reduction.interfaces[0]])
    drives = [j for j in domain.joints if j.kind == "rotation_drive" and j.body_i is not None and j.body_i.id == root]
    if len(found) != 1 or not drives or drives[0].body_j is not None:
        raise Unsupported(f"{path}: the spin-up translation takes one reduced beam driven to the ground at its root")
    body, K = clamped_blade(domain, reduction, stiffening)
    t = Translation(domain, exu, eii)
    obj, mesh = reduced_body(t, body, K)
    frame = t.mbs.GetObject(obj)["nodeNumbers"][0]
    offset = _drive_offset(drives[0])
    t.user_functions.append(offset)
    ground = t.mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=t.ground, localPosition=list(body.inv.origin)))
    hub = t.mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=frame))
    t.mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[ground, hub], constrainedAxes=[1] * 6,
                                           offsetUserFunction=offset))
    OV = exu.OutputVariableType
    tip = t.mbs.AddSensor(eii.SensorSuperElement(bodyNumber=obj, meshNodeNumber=len(body.rest) - 1, storeInternal=True,
                                                 writeToFile=False, outputVariableType=OV.Position))
    rot = t.mbs.AddSensor(eii.SensorNode(nodeNumber=frame, storeInternal=True, writeToFile=False,
                                         outputVariableType=OV.RotationMatrix))
    t.mbs.Assemble()
    dt, every = domain.solver.dt, domain.solver.output_every
    solver, settings, label = solver_settings(domain, dt, domain.solver.t_end, every)
    t0 = time.perf_counter()
    ok = solver.SolveSystem(t.mbs, settings)
    wall = time.perf_counter() - t0
    if ok is not True or solver.it.currentTime < domain.solver.t_end * (1.0 - 1e-9):
        raise Unsupported(f"{path}: Exudyn's {label} stopped at t = {solver.it.currentTime:g}")
    x, R = np.asarray(t.mbs.GetSensorStoredData(tip)), np.asarray(t.mbs.GetSensorStoredData(rot))
    rel = np.einsum("tba,tb->ta", R[:, 1:10].reshape(-1, 3, 3), x[:, 1:4] - body.inv.origin)
    return {"time": x[:, 0], "lag": rel[:, 1], "wall_time": wall, "algorithm": label}

