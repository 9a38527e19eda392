"""Blow-up detection during a run: the energy balance and a deformation sanity check.

The balance is checked every step by the algorithm when it supports the guard
(:attr:`reference.state.Scratch.guard`, the staggered scheme does: one pass over the
nodes for the kinetic energy, the rest of the balance is already computed), and at
every output by :class:`BlowUpMonitor`, which also checks the deformation and writes
the message.

An explicit run that goes unstable does not at once produce NaN: a mode above the
stability limit grows by a factor per step (|λ| ≈ 1.33 at 1.01 × the critical
step of central differences) while every number stays finite, and the run would
"complete" with energies of 10¹³ J.  A run is stopped when

- the energy balance fails: with E = kinetic + strain energy, W the work of the
  external and driving forces and D the energy dissipated by damping (all from the
  algorithm's own bookkeeping, :class:`~reference.state.Record`),
  ``E − E₀ − W + D > TOLERANCE × S``, where the energy scale S is the largest
  ``|E₀| + |W| + D`` seen so far (the energy that has entered the model), and never below
  the **round-off floor** of :func:`energy_floor`: energy that appeared from nowhere.  A stable run keeps this residual at the integration error
  (|residual| below 0.05 S on the shipped models), a blow-up makes it grow
  geometrically.  The check is one-sided: energy lost (the Park–Chiou stabilisation
  of the constraints dissipates) is no blow-up.  The per-step check adds an
  allowance of one step of external and constraint power for the half-step lag of
  the trapezoidal work;
- or the deformation is absurd: an element stretched beyond ``MAX_STRETCH`` times its
  length or shortened below ``1 / MAX_STRETCH`` of it.

The message names the likely cause: the time step, when it is above
``SAFETY × the critical estimate`` (the deck reader keeps decks below that,
:func:`reference.io.deck_solution.read_solver`), else the loads (the deformation they produce, or the energy they put in).

**The round-off floor.**  Without a floor the scale S of a model at rest, or at the start of a
load ramped in from zero, is itself round-off, and the ratio of two round-off numbers trips the
guard (an unloaded quarter arc: docs/benchmarks.md §10).  A model at rest is not at rest in floating point: its coordinates carry a round-off of
ε|x| (ε = 2.2e-16), so its elements start with strains of order ε X / L_e (X the largest
coordinate, L_e the element length) whose forces do not balance exactly, and the structure
answers those round-off loads through its compliance — unbounded by any fixed number of ulps:
the energy of an unloaded, undamped quarter arc grows by orders of magnitude over ten thousand steps,
and more on a finer mesh (docs/benchmarks.md §10).  The floor is therefore ε times a characteristic energy of the model (the energies
it sums are of that size, so their round-off is), :func:`energy_floor`:
``E_c = ½ Σ_e [(EA + GA₂ + GA₃) L_e + (GJ + EI₂ + EI₃) / L_e]`` (the strain energy of a unit
strain and a unit curvature × L_e in every element) ``+ ½ Σ k X²`` (translational springs)
``+ ½ Σ k`` (rotational, 1 rad) ``+ |g| X Σ m`` (gravity across the model): the energy of a strain
of √ε ≈ 1.5e-8.  For the arc, ε E_c lies orders of magnitude above the round-off it holds and well
below the work its tip load has put in at the end of its ramp (docs/benchmarks.md §10); a blow-up,
growing geometrically, passes it within a few dozen steps.

**Mass-proportional damping** (force −c m v, moment −c J ω, at the old half-step velocity
V^{n−½}): the kick multiplies a free velocity by 1 − c h, and with a stiffness of frequency ω
the step's characteristic polynomial is ``λ² − (2 − c h − h²ω²) λ + (1 − c h)``, whose roots
stay in the unit circle (Jury's test) for ``0 ≤ c h < 2 − (h ω)² / 2``; with the critical step
``h_c = 2 / ω_max`` of the undamped scheme, ``c h < 2 (1 − (h / h_c)²)`` (:func:`damping_limit`).
The energy the damping removes in a kick is its force times the mean of the two half-step
velocities, ``h c m V^{n−½}·½(V^{n−½} + V^{n+½})`` (:func:`reference.algorithms.staggered_nodes.node_sums`), the first
half kick included: the product with ``V^{n−½}`` alone overcounts a kick by ``1 / (1 − c h / 2)``,
fourfold at c h = 1.5 (a free decay at c h = 1.5 now books its loss to 1.2e-7; before, 0.26 of it).
"""

from __future__ import annotations

import math

import numpy as np

from reference.status import REGULARISE
from reference.validation import far_joints

TOLERANCE = 0.5
"""Energy-balance residual, as a fraction of the energy scale, that stops a run."""
MAX_STRETCH = 10.0
"""Element stretch ratio (current / initial length) that stops a run."""
SAFETY = 0.9
"""Largest dt as a fraction of the critical estimate that the deck reader accepts (``solver.allow_unsafe_dt``
lifts it), and above which the monitor names the time step as the likely cause.

The estimate (:meth:`Domain.critical_time_step`) is the linear limit of the undeformed mesh and is
tight: at 1.01 × the estimate the scheme blows up.  Tension, large rotations, joints and follower
loads shift the highest frequency of the running model, so decks keep 10 % below it.
"""


class BlowUpMonitor:
    """Watches the records of one run.

    Parameters
    ----------
    domain : Domain
        For the element connectivity, lengths and the critical step estimate.
    dt : float
        The run's step [s].
    explicit : bool
        Whether the algorithm's step is bounded by the critical step (then a step above
        ``SAFETY ×`` the estimate is named as the likely cause).
    critical : float, optional
        The domain's critical step estimate [s] (:meth:`Domain.critical_time_step`), if already computed.
    """

    def __init__(self, domain, dt: float, explicit: bool = True, critical: float | None = None, screen=None):
        self.domain = domain
        self.screen = within_stretch if screen is None else screen
        """``screen(x, conn, low, high) → bool``: whether every element is within its stretch bounds (:meth:`stretch`);
        :func:`within_stretch` in NumPy, or its compiled twin on the compiled path
        (:func:`reference.outputs.within_stretch_compiled`): it runs at every output (docs/benchmarks.md §20)."""
        model = domain.model
        # every element's end nodes and their initial distance (a two-node beam's reference length)
        self.conn = np.zeros((model.n_elements, 2), dtype=np.int64)
        for data in model.elements:
            self.conn[data.index] = data.conn[:, [0, -1]]
        x0 = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3)
        self.L0 = np.linalg.norm(x0[self.conn[:, 1]] - x0[self.conn[:, 0]], axis=1)
        with np.errstate(all="ignore"):
            self.bounds = ((self.L0 / MAX_STRETCH) ** 2, (self.L0 * MAX_STRETCH) ** 2)
        """The squared lengths [m²] between which every element is within its stretch bounds (:meth:`stretch`)."""
        self.dt, self.explicit = dt, explicit
        self.critical = domain.critical_time_step() if critical is None else critical
        self.labels = [e.label for e in domain.elements]
        self.floor = energy_floor(model, x0)
        """The round-off floor of the energy scale [J] (:func:`energy_floor`)."""
        self.E0 = None
        self.scale = self.floor
        self.worst = 0.0
        self.peak_energy = 0.0

    def residual(self, energy) -> tuple[float, float]:
        """(energy-balance residual, energy scale) [J] of ``energy`` = [kinetic, strain, external work,
        dissipated] (:attr:`reference.state.Record.energy`)."""
        T, U, W, D = energy.tolist()
        E = T + U
        if self.E0 is None:
            self.E0 = E
        self.scale = max(self.scale, abs(self.E0) + abs(W) + abs(D))
        return abs(E - self.E0 - W + D), self.scale

    def check(self, energy, x=None) -> str:
        """A one-sentence diagnosis if the run has blown up at this output (non-finite energies, or
        absurd deformation of the node positions ``x``), else ``""``; keeps the largest energy-balance
        residual seen (:attr:`worst`, a fraction of the energy scale) for reports."""
        r, S = self.residual(energy)
        E = float(energy[0] + energy[1])
        self.peak_energy = max(self.peak_energy, E)
        if S > 0.0:
            self.worst = max(self.worst, r / S)
        if not math.isfinite(r):
            return self.cause("the energies became non-finite")
        stretch = self.stretch(x) if x is not None else None
        if stretch is not None:
            return self.cause(stretch)
        return ""

    @staticmethod
    def guard_report(guard, work: float) -> str:
        """``" (kinetic + strain energy … against … of work done)"`` when the algorithm's per-step
        guard (the :data:`reference.state.GUARD` record ``guard``) stopped the run, else ``""``."""
        tolerance, scale = guard["tolerance"], guard["scale"]
        if not (tolerance > 0.0 and guard["residual"] > tolerance * scale):
            return ""  # the guard did not stop the run (its lag allowance only adds)
        return f" (energy {guard['energy']:.3g} J, work {work:.3g} J)"

    def stretch(self, x: np.ndarray) -> str | None:
        """The element whose length ratio (current / initial) is farthest outside ``(1/MAX_STRETCH, MAX_STRETCH)``
        (or not a number) and by how much, else None: :attr:`screen` at every output, and the NumPy search for
        the element only when it fires."""
        if not len(self.L0) or self.screen(x, self.conn, self.bounds[0], self.bounds[1]):
            return None
        with np.errstate(all="ignore"):
            L = np.linalg.norm(x[self.conn[:, 1]] - x[self.conn[:, 0]], axis=1)
            ratio = L / self.L0
        bad = np.flatnonzero(~((ratio < MAX_STRETCH) & (ratio > 1.0 / MAX_STRETCH)))
        if not len(bad):
            return None
        e = int(bad[np.argmax(np.abs(np.log(np.maximum(ratio[bad], 1e-300))))])
        return f"element {self.labels[e]!r} is {ratio[e]:.3g} × its initial length"

    def cause(self, what: str) -> str:
        """``what`` happened; add the likely cause and the fix."""
        return f"{what}: {likely_cause(self.dt, self.critical, self.explicit, self.domain)}"


def within_stretch(x: np.ndarray, conn: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
    """Whether every element's squared end-to-end distance lies within ``(low, high)`` [m²] (a NaN or an inf
    is outside): the screen of :meth:`BlowUpMonitor.stretch`, ``x`` (N, 3) the node positions [m] and ``conn``
    (E, 2) each element's end nodes."""
    d = x[conn[:, 1]] - x[conn[:, 0]]
    squared = np.einsum("ij,ij->i", d, d)
    return bool(np.all((squared > low) & (squared < high)))


LENGTH_SPREAD = 100.0
"""Ratio of the longest to the shortest member (flexible beam or rigid bar) above which a failure's
diagnosis names the geometry: a coordinate typed in mm in a model in m makes one member a thousand
times the others (issue 38: a rod end in mm, 2828 m against a crank of 1 m); the shipped models
span at most a factor 5 (Lee's frame, the three-bar mechanisms)."""


def model_suspect(domain) -> str:
    """What in the model's data most likely makes a run fail, as a clause with its fix, or ``""``:
    read from what the model contains, not from the failure (issue 38 item 12):

    - the geometry: members whose lengths span more than :data:`LENGTH_SPREAD` (a unit slip), or a
      joint point far from both of its bodies (:func:`reference.validation.far_joints`);
    - a position-mode drive whose θ(0) or s(0) is not zero: the configuration jumps at t = 0 (a rate
      given without ``mode = "velocity"``).
    """
    lengths = []
    for label, nodes in domain.beams.items():
        lengths.append((float(np.linalg.norm(nodes[-1].position - nodes[0].position)), f"beam {label!r}"))
    for node in domain.nodes:
        points = getattr(node, "points", {})
        if "start" in points and "end" in points:
            lengths.append((float(np.linalg.norm(points["end"] - points["start"])), f"rigid bar {node.label!r}"))
    if len(lengths) > 1:
        (short, small), (long, big) = min(lengths), max(lengths)
        if short > 0.0 and long > LENGTH_SPREAD * short:
            return (f"likely cause: the geometry, {big} is {long / short:.3g} × as long as {small} "
                    f"({long:.4g} against {short:.4g}); check the coordinates and their units")
    far = far_joints(domain)
    if far:
        ratio, joint, distances, _ = far[0]
        return (f"likely cause: the geometry, joint {joint.label!r}'s point is {min(distances):.3g} from its "
                f"bodies ({ratio:.2g} × the model size); check the point and its units")
    for joint in domain.joints:
        if joint.kind.endswith("_drive") and joint.mode == "position":
            start = float(joint.time_function(0.0))
            if start != 0.0 and math.isfinite(start):
                unit = "rad" if joint.kind == "rotation_drive" else "m"
                return (f"likely cause: the drive {joint.label!r} jumps to {'θ' if unit == 'rad' else 's'}(0) = "
                        f"{start:.4g} {unit} at t = 0; a rate? set mode = \"velocity\"")
    return ""


def likely_cause(dt: float, critical: float, explicit: bool = True, domain=None) -> str:
    """The likely cause of a blow-up, and the fix (one short clause): the time step when an explicit
    step is above ``SAFETY ×`` the critical estimate; else, with the ``domain`` given, what its data
    suggest (:func:`model_suspect`); else the loads, when it has any (loads, gravity, actuator forces),
    or the drives and initial velocities when it has none."""
    ratio = dt / critical if critical > 0 else math.inf
    if explicit and ratio > SAFETY:
        return f"likely cause: the time step, dt = {ratio:.3g} × the critical {critical:.3g}; use dt ≤ {0.8 * critical:.3g}"
    suspect = model_suspect(domain) if domain is not None else ""
    if suspect:
        return suspect
    step = f"dt = {ratio:.2f} × critical" if explicit else ""
    if domain is not None and not (domain.loading or any(getattr(f, "force_function", None) is not None
                                                         for f in domain.force_elements)):
        return (f"likely cause: the drives or initial velocities (no loads{'; ' + step if step else ''}); "
                "check their rates and units, or reduce dt")
    return f"likely cause: the loads{f' ({step})' if step else ''}; check their size and units, ramp them in, or reduce dt"


def rediagnosed(message: str, domain, dt: float, critical: float, explicit: bool) -> str:
    """An algorithm's failure ``message`` with its generic likely cause (:func:`likely_cause` without the
    model, or the singular constraints' advice to regularise) replaced by what the ``domain``'s data
    suggest; ``message`` itself when they suggest nothing more (the algorithms see the plain-data
    model only; the solution loop, which has the Domain, calls this)."""
    generic = likely_cause(dt, critical, explicit)
    if generic in message:
        return message.replace(generic, likely_cause(dt, critical, explicit, domain))
    if REGULARISE in message:
        suspect = model_suspect(domain)
        if suspect.startswith("likely cause: the geometry"):
            return message.replace(REGULARISE, suspect[0].upper() + suspect[1:] + ".")
    return message


def nonfinite_load(domain, times) -> str:
    """``"the load on node … is not finite at t = …"`` (or of a drive, or gravity) for the first of
    ``times`` where a load's or a drive's time function, or a load vector, is not finite, else ``""``:
    what a failed run reports instead of a singular matrix or a non-finite state (a formula such as
    ``1/t`` or ``log(t - 1)`` outside its domain)."""
    from reference.interactions import Gravity, LineLoad, NodalLoad

    for t in times:
        if not math.isfinite(t):  # a step of no length in time (a linearised analysis's dt = inf)
            continue
        with np.errstate(all="ignore"):
            for load in domain.loading:
                if isinstance(load, Gravity):
                    if not np.all(np.isfinite(load.g)):
                        return f"the gravity is not finite ({load.g.tolist()})"
                    continue
                f = load.time_function(t)
                vec = load.vector if isinstance(load, NodalLoad) else np.concatenate(
                    [load.force_per_length, load.moment_per_length]) if isinstance(load, LineLoad) else np.zeros(1)
                if not (math.isfinite(f) and np.all(np.isfinite(f * np.asarray(vec, dtype=float)))):
                    node = load.node if isinstance(load, NodalLoad) else load.nodes[0]
                    return (f"the load on {'node' if isinstance(load, NodalLoad) else 'the beam at'} {node.label!r} "
                            f"is not finite at t = {t:.6g} (its time function gives {f:g})")
            for joint in domain.joints:
                if joint.drive_code:
                    f = joint.time_function(t)
                    if not math.isfinite(f):
                        return f"the drive {joint.label!r} is not finite at t = {t:.6g} (its time function gives {f:g})"
    return ""


def energy_floor(model, x: np.ndarray) -> float:
    """The round-off floor of the energy scale [J]: ε (the machine epsilon) times the model's
    characteristic energy E_c — a unit strain and curvature in every element and spring, gravity
    across the model (derivation and measurements in the module docstring).

    Parameters
    ----------
    model : Model
        Its element families (each family's ``characteristic_energy``: a unit strain and curvature in
        every element), force elements, masses and gravity.
    x : ndarray (N, 3)
        The node positions [m]; X is their largest magnitude.
    """
    from reference.forces import BUSHING, POINT_TO_POINT

    X = float(np.max(np.abs(x))) if x.size else 0.0
    from reference.elements.families import family_of

    energy = sum(float(family_of(data).characteristic_energy(data)) for data in model.elements)
    kind, k = np.asarray(model.force_elements.kind), np.abs(np.asarray(model.force_elements.k, dtype=float))
    if kind.size:
        translational = (np.where(kind == POINT_TO_POINT, k[:, 0], 0.0)
                         + np.where(kind == BUSHING, k[:, :3].sum(axis=1), 0.0))
        energy += 0.5 * float(np.sum(translational)) * X * X + 0.5 * float(np.sum(k) - np.sum(translational))
    energy += float(np.linalg.norm(model.gravity)) * X * float(np.sum(model.nodes.mass))
    return float(np.finfo(float).eps) * energy


def damping_limit(dt: float, critical: float) -> float:
    """The largest stable ``c·dt`` of the explicit scheme's mass-proportional damping at the step
    ``dt``: ``2 (1 − (dt / critical)²)`` (derivation in the module docstring; 2 for a model without
    stiffness, ``critical = inf``)."""
    ratio = dt / critical if critical > 0.0 else math.inf
    return 2.0 * (1.0 - ratio * ratio)


def damping_problem(c: float, dt: float, critical: float, margin: float = 1.0) -> str:
    """Why the damping ``c`` [1/s] makes the explicit step ``dt`` unstable (``c·dt`` above ``margin ×``
    :func:`damping_limit`), with the fix, or ``""`` (also for a step at or above the critical one,
    unstable without damping: the time-step checks name that)."""
    limit = margin * damping_limit(dt, critical)
    ratio = dt / critical if critical > 0.0 else math.inf
    if not c > 0.0 or c * dt <= limit or ratio >= 1.0:
        return ""
    # the largest dt with c dt = margin · 2 (1 − (dt/critical)²)
    a = 2.0 * margin / critical**2 if math.isfinite(critical) else 0.0
    h = (-c + math.sqrt(c * c + 8.0 * margin * a)) / (2.0 * a) if a > 0.0 else 2.0 * margin / c
    lim = 2.0 * (1.0 - ratio * ratio)
    return (f"c·dt = {c * dt:.3g} exceeds {'' if margin == 1.0 else f'{margin:g} × '}the explicit scheme's damping "
            f"limit 2(1 − (dt/dt_crit)²) = {lim:.3g} at dt = {ratio:.2g} × critical; use dt ≤ {0.99 * h:.2g} "
            f"or damping ≤ {0.99 * max(limit, 0.0) / dt:.3g}")
