"""Any deck the reference accepts, built and run in Exudyn (1.13); the same results file.

The deck is read by the reference's deck reader (so both engines see exactly
the same data: nodes, triads, masses, joints, loads); :func:`build` then
translates the resulting :class:`~reference.domain.Domain` item by item, one
translator per item kind (:mod:`crosscheck.exudyn_items`, whose docstring
tables each deck item, its Exudyn item and its translator), and :func:`solve`
runs it with the solver settings of :func:`solver_settings`.

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

from crosscheck.exudyn_items import (
    AXES, MERGES, TRANSLATORS, Translation, matrix, node_offset, partner, sensors, size, step_function,
)
from reference.forces import ROTATIONAL
from reference.interactions import Gravity, LineLoad, NodalLoad
from reference.joints.joint import PRESCRIBED
from reference.rotation import ORTHOGONALITY_TOLERANCE, EulerParameters
from reference.errors import SolverDiverged


class Unsupported(ValueError):
    """A deck feature the Exudyn translation cannot express."""


class ExudynFailed(SolverDiverged):
    """Exudyn's solver gave up on a translated model (one line: the solver, how far it came, what to try)."""


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
        if j.kind == PRESCRIBED:
            raise Unsupported(f"prescribed displacement {j.label!r} is not translated to Exudyn; cross-check its path "
                              "with flexmbs' arc-length run under load instead")
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
        if j.kind in MERGES and partner(domain, j) is None:
            raise Unsupported(f"joint {j.label!r} ({j.kind}) has no {MERGES[j.kind]} joint between the same bodies "
                              "at the same point and axis: Exudyn's generic joint drives a locked axis")
        par = j.body_fixed()
        for body, s in ((j.body_i, par[0:3]), (j.body_j, par[3:6])):
            if body is not None and body.id in beam_nodes and node_offset(domain, body, s) is None:
                raise Unsupported(f"joint {j.label!r} attaches to beam node {body.label!r} at {np.linalg.norm(s):.3g} "
                                  "from it: Exudyn's node markers have no offset; put the joint point on the node")


def preflight(domain) -> None:
    """Refuse what cannot be translated, then build the Exudyn model once, before anything runs.

    Raises :class:`Unsupported` (one line) for an untranslatable feature or any
    error Exudyn raises while the model is built and assembled.
    """
    check_supported(domain)
    build(domain)


def build(domain, progress=None, t_end: float = 1.0, translators=TRANSLATORS, lie_group: bool = False) -> Translation:
    """Translate ``domain`` into an assembled Exudyn system (:class:`~crosscheck.exudyn_items.Translation`,
    with its ``sensors``).  Raises :class:`Unsupported` (one line) for anything untranslatable or
    refused by Exudyn.  ``translators`` and ``lie_group`` (the nodes' kind) are those of the
    eigen-solve's sparse variant (:mod:`crosscheck.exudyn_modes`); the defaults translate everything."""
    check_supported(domain)
    try:
        return _build(domain, progress, t_end, translators, lie_group)
    except Unsupported:
        raise
    except Exception as exc:  # Exudyn's own errors (RuntimeError, ValueError, …): one line, before any run
        first = next((ln.strip() for ln in str(exc).splitlines() if ln.strip()), type(exc).__name__)
        raise Unsupported(f"Exudyn refused the translated model: {first}") from None


def _build(domain, progress, t_end, translators, lie_group) -> Translation:
    import exudyn as exu
    import exudyn.itemInterface as eii

    t = Translation(domain, exu, eii, lie_group)
    for translate in translators:
        translate(t)
    step_function(t, progress, t_end)
    t.sensors = sensors(t)
    t.mbs.Assemble()
    return t


NEWTON = {"static": 1e-8, "dynamic": 1e-6}
"""Newton's tolerances in Exudyn, relative to the first residual and, times :func:`force_scale`, absolute
(Exudyn's residual is the 2-norm of the force residual).  The static solver uses full Newton (converging
quadratically, so 1e-8 costs one iteration more than 1e-6); the implicit time integration Exudyn's
modified Newton, which converges linearly: 1e-6 as the reference's generalized-α tolerance on its
corrections.  Measured on a steel rod of 200 elements (r = 1 cm, 100 N at the tip,
``tests/test_crosscheck_reliability.py``): with the former fixed tolerances (1e-10 static, 1e-6 dynamic,
absolute in newtons and relative) Exudyn failed within its first steps; with these it agrees with the
reference to 1.3e-9 (static) and 3.6e-7 (generalized-α) of the length."""
FORCE_STRAIN = 1e-6
"""The strain whose force enters :func:`force_scale` (a model without loads: its stiffest section's
EA or GA times this)."""
DENSE_LIMIT = 1000
"""More coordinates than this: Exudyn's sparse linear solver (above it Exudyn warns that the dense one
is slow and memory-hungry)."""


def force_scale(domain) -> float:
    """The model's force scale [N]: the largest of its loads at their largest over the run (a moment
    divided by the model's size, a line load times the beam length it loads), its weight, and the
    force of a strain :data:`FORCE_STRAIN` in its stiffest section."""
    forces = [0.0]
    times = np.linspace(0.0, domain.solver.t_end, 201)
    for ld in domain.loading:
        if isinstance(ld, Gravity):
            forces.append(float(np.linalg.norm(ld.g)) * float(np.sum(domain.model.nodes.mass)))
        elif isinstance(ld, (NodalLoad, LineLoad)):
            for nl in ld.nodal_loads() if isinstance(ld, LineLoad) else [ld]:
                peak = max(abs(float(nl.time_function(t))) for t in times)
                forces.append(float(np.linalg.norm(nl.vector)) * peak / (size(domain) if nl.moment else 1.0))
    for e in domain.elements:
        sec = e.formulation.section
        forces.append(FORCE_STRAIN * max(sec.EA, sec.GA2, sec.GA3))
    return max(forces) or 1.0


SUBDIVISIONS = (1, 2, 4, 8, 16)
"""The step subdivisions :func:`solve` tries in turn.  Exudyn's adaptive steps (a step whose Newton fails
is cut, by 4 in the static solver, by 2 in time integration, and regrown) solve what fixed steps cannot
(the 45° bend of 4 elements an arc in 4 load steps: fixed steps fail at every subdivision up to 16), but
an output is recorded at the end of whatever step crosses its time (16 elements an arc: a load level of
45.94 in place of 45); a run whose outputs are off their times is run again on a finer grid."""


def solver_settings(domain, dt: float, t_end: float, every: int, algorithm: str | None = None):
    """Exudyn's solver and settings for the deck's algorithm (or ``algorithm``) at the step ``dt``,
    recording every ``every`` steps; returns ``(solver, settings, label)``.

    ``static`` → Exudyn's static solver, the load factor its time, ``t_end / dt`` load
    steps; ``generalized_alpha`` → Exudyn's generalized-α at the same ρ∞; the explicit
    scheme → Exudyn's generalized-α (its default ρ∞); adaptive steps (see :data:`SUBDIVISIONS`).
    Newton's tolerances scale with the model's forces (:data:`NEWTON`, :func:`force_scale`).
    """
    import exudyn as exu

    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = every * dt
    settings.timeIntegration.verboseMode = 0
    n_steps = int(round(t_end / dt))
    force = force_scale(domain)
    algorithm = algorithm or domain.solver.algorithm
    if algorithm == "static":
        static = settings.staticSolver
        static.verboseMode = 0
        static.numberOfLoadSteps = n_steps
        static.loadStepDuration = t_end
        static.adaptiveStep = True
        static.useLoadFactor = False  # the loads follow their time functions (pre-step)
        static.newton.relativeTolerance = NEWTON["static"]
        static.newton.absoluteTolerance = NEWTON["static"] * force
        return exu.MainSolverStatic(), settings, f"static solver, {n_steps} load steps"
    ti = settings.timeIntegration
    ti.numberOfSteps = n_steps
    ti.endTime = t_end
    ti.newton.relativeTolerance = NEWTON["dynamic"]
    ti.newton.absoluteTolerance = NEWTON["dynamic"] * force
    ti.adaptiveStep = True
    if algorithm == "generalized_alpha":
        ti.generalizedAlpha.spectralRadius = domain.solver.rho_inf
    label = f"generalized-alpha, rho_inf = {ti.generalizedAlpha.spectralRadius:g}"
    return exu.MainSolverImplicitSecondOrder(), settings, label


def solve(domain, dt: float | None = None, t_end: float | None = None, results_path=None, progress=None,
          deck=None) -> dict:
    """Build and run ``domain`` in Exudyn (:func:`solver_settings`); return results and timing.

    A run that fails, or whose outputs are off their times, is run again with every step
    divided by the next of :data:`SUBDIVISIONS` (the outputs stay at the same times); models with more than
    :data:`DENSE_LIMIT` coordinates use Exudyn's sparse linear solver.  Returns a dict
    with ``results`` (:class:`reference.io.results.Results`, engine Exudyn),
    ``wall_time`` (the successful solve call only), ``steps`` (its steps), ``exudyn_version``
    and ``algorithm``.  ``deck`` (:class:`reference.io.deck.Deck`) is recorded in the
    results file.

    Raises
    ------
    ExudynFailed
        Exudyn's solver gave up at the finest subdivision: one line naming it, the time (load
        factor) reached and what to try.
    """
    dt = float(dt or domain.solver.dt)
    t_end = float(t_end or domain.solver.t_end)
    every = max(int(round(domain.solver.output_every * domain.solver.dt / dt)), 1)
    for k in SUBDIVISIONS:
        t = build(domain, progress, t_end)
        solver, settings, label = solver_settings(domain, dt / k, t_end, every * k)
        if len(t.mbs.systemData.GetODE2Coordinates()) + len(t.mbs.systemData.GetAECoordinates()) > DENSE_LIMIT:
            settings.linearSolver.solverType = _exudyn().LinearSolverType.EigenSparse
        t0 = time.perf_counter()
        try:
            ok = solver.SolveSystem(t.mbs, settings)
        except Exception as exc:  # a failed step raises in some versions: the same one line
            ok = " ".join(str(exc).split())[:200] or type(exc).__name__
        wall = time.perf_counter() - t0
        reached = float(solver.it.currentTime)
        if ok is True and not _rotations_proper(t):
            ok = "its rotations stopped being proper rotation matrices: the solution diverged"
        if ok is True and reached >= t_end * (1.0 - 1e-9) and _on_grid(t, every * dt, t_end):
            break
    else:
        raise ExudynFailed(_failure(domain, label, reached, t_end, dt, ok))
    if k > 1:
        label += f" (the deck's steps divided by {k}: fewer failed or missed output times)"
    results = _results(domain, t, wall, dt / k)
    if results_path is not None:
        _write(results, results_path, domain, label, dt / k, deck)
    return {"results": results, "wall_time": wall, "steps": int(solver.it.currentStepIndex) - 1,
            "exudyn_version": _exudyn().__version__, "algorithm": label}


def _on_grid(t, interval: float, t_end: float) -> bool:
    """Whether the recorded outputs lie at the output times 0, interval, 2 interval, … t_end."""
    times = np.asarray(t.mbs.GetSensorStoredData(t.sensors["position"][0]))[:, 0]
    expected = interval * np.arange(int(round(t_end / interval)) + 1)
    return times.shape == expected.shape and bool(np.allclose(times, expected, rtol=0.0, atol=1e-9 * t_end))


def _rotations_proper(t, tolerance: float = ORTHOGONALITY_TOLERANCE) -> bool:
    """Whether every recorded rotation matrix is finite, orthogonal to ``tolerance`` and not a reflection (the
    test :meth:`reference.rotation.EulerParameters.from_matrix` applies to one matrix, here on all of them
    at once): a diverged Exudyn run can finish its steps and record garbage."""
    for sensor in t.sensors["rotation"]:
        R = np.asarray(t.mbs.GetSensorStoredData(sensor))[:, 1:10].reshape(-1, 3, 3)
        if not np.all(np.isfinite(R)):
            return False
        err = np.abs(np.einsum("kba,kbc->kac", R, R) - np.eye(3)).max(initial=0.0)
        if err > tolerance or np.any(np.linalg.det(R) <= 0.0):
            return False
    return True


def _exudyn():
    import exudyn

    return exudyn


def _failure(domain, label: str, reached: float, t_end: float, dt: float, why) -> str:
    """The one line of a failed Exudyn solve: the solver, how far it came, the options to try."""
    static = domain.solver.algorithm == "static"
    where = f"load factor {reached:.6g} of {t_end:g}" if static else f"t = {reached:.6g} of {t_end:g}"
    cause = f" ({why})" if isinstance(why, str) else ""
    fix = ("more load steps (solver.load_steps in the deck)" if static else
           f"a smaller step for Exudyn (--exudyn-dt, e.g. {dt / (4 * SUBDIVISIONS[-1]):g})")
    return (f"Exudyn's {label} did not converge: it stopped at {where}{cause} with adaptive steps on a grid "
            f"divided by up to {SUBDIVISIONS[-1]}; try {fix}")


def _results(domain, t, wall: float, dt: float):
    """The run's results (:class:`reference.io.results.Results`) from the translation's sensors."""
    mbs, sensors, primary = t.mbs, t.sensors, t.primary
    data = {k: np.array([mbs.GetSensorStoredData(s) for s in v]) for k, v in sensors.items()}
    times = data["position"][0, :, 0]
    pos = np.transpose(data["position"][:, :, 1:4], (1, 0, 2))
    vel = np.transpose(data["velocity"][:, :, 1:4], (1, 0, 2))
    # back from each Exudyn node's frame (the node frame turned by o_p) to the node frame
    Op = np.array([matrix(o) for o in primary])
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
    return results


def _write(results, path, domain, label: str, dt: float, deck) -> None:
    """The results file of an Exudyn run (engine ``exudyn``)."""
    from reference.io.results import ResultsWriter, deck_attrs

    writer = ResultsWriter(path, labels=results.labels, ids=[n.id for n in domain.nodes],
                           items={"joints": results.joint_labels, "elements": results.element_labels}, attrs={
        "engine": "exudyn", "engine_version": _exudyn().__version__, **deck_attrs(deck),
        "algorithm": f"{label} (Exudyn)", "dt": dt,
        "energy_note": "evaluated with the reference's definitions on Exudyn's states; external work "
                       "excludes driving motions",
        "reaction_note": "joint reactions from Exudyn's joint sensors (ForceLocal, TorqueLocal of "
                         "ObjectJointGeneric), section resultants from the beams' own ForceLocal/TorqueLocal "
                         "output at the element midpoint; no multipliers (Exudyn's are another set)"})
    for i, t in enumerate(results.time):
        writer.append({"time": t, "position": results.positions[i], "rotation": results.rotations[i],
                       "velocity": results.velocities[i], "angular_velocity": results.angular_velocities[i],
                       "violation_norm": results.constraint_violation[i],
                       "reaction_force": results.reaction_forces[i], "reaction_moment": results.reaction_moments[i],
                       "section_force": results.section_forces[i], "section_moment": results.section_moments[i],
                       "velocity_violation_norm": results.velocity_constraint_violation[i],
                       **{k: v[i] for k, v in results.energy.items()}})
    writer.close("completed")


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
    drives = {id(partner(domain, j)): j for j in domain.joints if j.kind in MERGES}
    for k, j in enumerate(domain.joints):
        carrier = partner(domain, j) if j.kind in MERGES else j  # the Exudyn joint (and its markers)
        swapped = carrier.kind == "universal"
        locked = [1] * 6 if id(carrier) in drives else AXES[carrier.kind]
        par = carrier.body_fixed()
        frames = {"i": (carrier.body_i, par[6:15].reshape(3, 3)), "j": (carrier.body_j, par[15:24].reshape(3, 3))}
        m0, m1 = (frames["i"], frames["j"]) if swapped else (frames["j"], frames["i"])
        sign = -1.0 if swapped else 1.0  # marker 1 is body_i unless swapped
        drive = drives.get(id(carrier))
        for t in range(n):
            J0, J1 = ((np.eye(3) if body is None else matrix(rot[t, body.id])) @ f for body, f in (m0, m1))
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
    from reference.io.results import Results
    from reference.evaluation.forces import generalized_forces
    from reference.state import element_work

    model = domain.model
    n, N = len(times), len(domain.nodes)
    # the kernels below are compiled for C-ordered arrays: a strided view would compile them again
    pos, rot, vel, omg = (np.ascontiguousarray(a, dtype=float) for a in (pos, rot, vel, omg))
    phi = np.zeros(n)
    phid = np.zeros(n)
    kinetic, strain, work = np.zeros(n), np.zeros(n), np.zeros(n)
    S, F, A, ework = np.zeros((N, 6)), np.zeros((N, 6)), np.zeros(9), element_work(model)
    G, angle = np.zeros((N, 6)), np.zeros(model.force_elements.kind.shape[0])
    prim_phi, prim_B = np.zeros(10), np.zeros(120)
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
