"""Per-deck check functions of the verification report, found by the deck's ``meta.name``.

A deck ``models/NAME.toml`` whose checks need code — a closed form, a
literature table, a convergence study, an observable of its own — gets a
module ``flexmbs/deckchecks/NAME.py`` providing one function::

    def evaluate(ctx) -> tuple[list[str], list[Check]]

``ctx`` is a :class:`flexmbs.report.Context`: ``ctx.domain(**overrides)``
builds the deck, ``ctx.solve(domain, what)`` runs it warm with progress and
records the solve time, ``ctx.check(name, label, reference, computed)`` makes
a check row with the tolerance and reason of the deck's ``[checks.NAME]``,
``ctx.figure(fig, file, caption)`` saves a figure and returns its Markdown,
``ctx.quick`` asks for a reduced run.  The function returns the section's
Markdown lines (text, tables, figures) and its checks.  The report adds the
deck's data, a sketch of the model and the Exudyn cross-check itself.

Closed forms the checks compare with belong in :mod:`flexmbs.verification.analytic`, observables
written for one deck in :mod:`flexmbs.verification.observables`.
"""

from __future__ import annotations

import importlib
import re


def module_for(name: str):
    """The check module of deck ``name`` (``None`` if there is none)."""
    if not re.fullmatch(r"[a-z_][a-z0-9_]*", name or ""):
        return None
    try:
        return importlib.import_module(f"flexmbs.deckchecks.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == f"flexmbs.deckchecks.{name}":
            return None
        raise


def at(results, label: str, t: float):
    """The position of node ``label`` at the output nearest to time ``t``."""
    import numpy as np

    return results.position(label)[int(np.argmin(np.abs(results.time - t)))]


def history_axes(plt, n: int, height: float = 2.2, width: float = 6.4):
    """``n`` stacked axes sharing the time axis (labelled on the last)."""
    fig, axes = plt.subplots(n, 1, figsize=(width, height * n + 0.6), sharex=True, squeeze=False)
    axes[-1, 0].set_xlabel("time t [s]")
    return fig, axes[:, 0]


def inertia_about(node, axis) -> float:
    """Moment of inertia [kg m²] of a rigid body about an inertial ``axis`` through its centre, at t = 0."""
    import numpy as np

    from reference.rotation import EulerParameters

    A = EulerParameters(node.rotation).matrix()
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return float(a @ A @ node.inertia @ A.T @ a)


def crossings(t, y, direction: int = -1):
    """Times where ``y`` crosses zero downwards (``direction = -1``) or upwards (+1), linearly interpolated."""
    import numpy as np

    y = np.asarray(y)
    i = np.where((direction * y[:-1] < 0) & (direction * y[1:] >= 0))[0]
    return t[i] + (t[i + 1] - t[i]) * y[i] / (y[i] - y[i + 1])


def energy_error(results):
    """Change of ``W − (T + U) − D`` over the run (W includes gravity's work), relative to the peak kinetic energy.

    Zero for a conservative system with exact integration: the balance of work
    and energy measured from its initial value.
    """
    import numpy as np

    e = results.energy
    dissipated = np.nan_to_num(e.get("dissipated", 0.0 * e["kinetic"]))
    balance = e["external_work"] - e["kinetic"] - e["strain"] - dissipated
    return float(np.max(np.abs(balance - balance[0])) / np.max(e["kinetic"]))


def energy_panel(ax, results):
    """Kinetic, strain energy and the work of the external forces against time, on ``ax``."""
    e = results.energy
    ax.plot(results.time, e["kinetic"], label="kinetic T")
    if max(abs(e["strain"])) > 0:
        ax.plot(results.time, e["strain"], label="strain U")
    ax.plot(results.time, e["external_work"], "--", label="work of external forces W")
    ax.set_ylabel("energy [J]")
    ax.legend(fontsize=7)
