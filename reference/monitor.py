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
  ``|E₀| + |W| + D`` seen so far (the energy that has entered the model): energy that
  appeared from nowhere.  A stable run keeps this residual at the integration error
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
"""

from __future__ import annotations

import math

import numpy as np

from reference.jit import kernel

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
    """

    def __init__(self, domain, dt: float, explicit: bool = True):
        model = domain.model
        # every element's end nodes and their initial distance (a two-node beam's reference length)
        self.conn = np.zeros((model.n_elements, 2), dtype=np.int64)
        for data in model.elements:
            self.conn[data.index] = data.conn[:, [0, -1]]
        x0 = np.array([n.position for n in domain.nodes]).reshape(-1, 3)
        self.L0 = np.linalg.norm(x0[self.conn[:, 1]] - x0[self.conn[:, 0]], axis=1)
        self.dt, self.explicit = dt, explicit
        self.critical = domain.critical_time_step()
        self.labels = [e.label for e in domain.elements]
        self.E0 = None
        self.scale = 0.0
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
        guard (:attr:`reference.state.Scratch.guard`) stopped the run, else ``""``."""
        E0, S, tol, r, E = guard
        if not (tol > 0.0 and r > tol * S):  # the guard stopped the run (its lag allowance only adds)
            return ""
        return (f" (kinetic + strain energy {E:.3g} against {work:.3g} of work done, residual "
                f"{r / max(S, 1e-300):.2g} × the energy put in)")

    def stretch(self, x: np.ndarray) -> str | None:
        if not len(self.L0) or not _stretched(x, self.conn, self.L0, MAX_STRETCH):
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
        return f"{what}: {likely_cause(self.dt, self.critical, self.explicit)}"


@kernel
def _stretched(x, conn, L0, limit):
    """Whether an element's length ratio (current / initial) is not within ``(1/limit, limit)``
    (or not a number): the compiled screen of :meth:`BlowUpMonitor.stretch`."""
    for e in range(conn.shape[0]):
        i, j = conn[e, 0], conn[e, 1]
        d0, d1, d2 = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
        ratio = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / L0[e]
        if not (ratio < limit and ratio > 1.0 / limit):
            return True
    return False


def likely_cause(dt: float, critical: float, explicit: bool = True) -> str:
    """The likely cause of a blow-up, and the fix: the time step when an explicit step is above
    ``SAFETY ×`` the critical estimate, else the loads."""
    ratio = dt / critical if critical > 0 else math.inf
    if explicit and ratio > SAFETY:
        return (f"the run went unstable; likely cause: the time step, dt = {dt:.3g} is {ratio:.3g} × the critical "
                f"estimate {critical:.3g}; use dt ≤ {0.8 * critical:.3g}")
    return ("the run went unstable" + (f" with dt = {ratio:.2f} × the critical estimate" if explicit else "")
            + "; likely cause: the loads (too large for the structure, or not ramped in); check their magnitude "
            "and units, ramp them in (a time_function), or reduce dt if the deformed model is much stiffer")
