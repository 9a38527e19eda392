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

Closed forms the checks compare with belong in :mod:`reference.analytic`.
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
