"""A vibration or buckling mode as a ParaView animation: one VTKHDF file per mode, from a results file.

A results file of a linearised analysis holds, besides the configuration it was
linearised about (``/nodes/position`` (1, N, 3), ``/nodes/rotation`` (1, N, 4); the last
record is taken), the mode shapes ``/modes/shape`` or ``/buckling/shape`` (n, N, 6): per
mode and node the displacement φ_u [m, inertial] and the rotation increment φ_θ [rad,
body frame] (``docs/results.md``).  Mode K (counted from 1) is animated over one period
``τ ∈ [0, 1)`` in ``frames`` frames, ``τ_k = k / frames``:

    x(τ) = x₀ + a sin(2πτ) φ_u,        q(τ) = q₀ ⊗ exp(a sin(2πτ) φ_θ)

— the linearised motion, drawn on the nonlinear configuration space so that the
triads stay rotations.  The amplitude ``a`` makes the largest displacement of a drawn
point (beam nodes, rigid-body centres and named points: to first order
``φ_u + A₀(φ_θ × s)`` at the body-frame offset s) ``fraction`` of the model size (the
diagonal of the points' bounding box, 1 m for a model of one point); a mode that moves
no point (the torsion of a straight beam) turns its largest rotation by ``fraction``
rad.  The file is :func:`reference.io.vtk.write_vtk`'s, with ``displacement`` measured
from the configuration linearised about: frame k's displacement of a beam node is
``a sin(2πk/frames) φ_u``.  Its step values are the time ``τ/f`` [s] of a vibration mode
of frequency f > 0 (velocities then in m/s and rad/s), else the phase τ itself
(buckling shapes, zero-frequency modes; velocities per unit phase).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from reference.io.results import Results
from reference.io.vtk import Layout, rotation_matrices, safe_name, write_vtk

SHAPES = {"modes/shape": "modes/frequency", "buckling/shape": "buckling/load_factor"}
"""The shape datasets a results file may hold (the first one present is animated) and their values."""
FRAMES = 24
"""Frames per period."""
FRACTION = 0.1
"""The largest point displacement as a fraction of the model size."""


class ModeError(ValueError):
    """A mode that cannot be animated from a results file: one line naming the file and the fix."""


def read_mode(path, k: int) -> dict:
    """Mode ``k`` (from 1) of the results file ``path``: ``{"dataset", "shape" (N, 6), "value", "x0" (N, 3),
    "q0" (N, 4), "labels"}``, the value its frequency [Hz] or load factor (NaN when not stored).

    Raises :class:`ModeError` (one line) for a file without mode shapes or a ``k`` out of range.
    """
    with h5py.File(path, "r") as f:
        dataset = next((name for name in SHAPES if name in f), None)
        if dataset is None:
            raise ModeError(f"{path}: the file has no mode shapes ({' or '.join('/' + s for s in SHAPES)}); run a "
                            "deck with [solver] algorithm = \"modes\" or \"buckling\" (flexmbs run DECK) and give its "
                            "results.h5")
        count = f[dataset].shape[0]
        if not 1 <= k <= count:
            fix = f"give --mode 1 … {count}" if count else "it holds none: run the deck again with modes = N ≥ 1"
            raise ModeError(f"{path}: --mode {k}: the file has {count} mode{'s' * (count != 1)} (/{dataset}); {fix}")
        values = f[SHAPES[dataset]][()] if SHAPES[dataset] in f else np.full(count, np.nan)
        labels = [s.decode() if isinstance(s, bytes) else str(s) for s in f["nodes/label"][()]]
        return {"dataset": dataset, "shape": np.asarray(f[dataset][k - 1], dtype=float),
                "value": float(values[k - 1]), "x0": np.asarray(f["nodes/position"][-1], dtype=float),
                "q0": np.asarray(f["nodes/rotation"][-1], dtype=float), "labels": labels}


def _turned(q0: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``q₀ ⊗ exp(v)`` per row (N, 4), v (N, 3) a body-frame rotation vector."""
    half = 0.5 * np.linalg.norm(v, axis=1)
    e0, e = np.cos(half), 0.5 * np.sinc(half / np.pi)[:, None] * v  # sin(|v|/2) v/|v|, exact at 0
    p0, p = q0[:, :1], q0[:, 1:]
    return np.column_stack([p0[:, 0] * e0 - np.einsum("ni,ni->n", p, e), p0 * e + e0[:, None] * p + np.cross(p, e)])


def amplitude(lay: Layout, q0: np.ndarray, shape: np.ndarray, fraction: float = FRACTION) -> float:
    """The scale ``a`` of a mode (the module docstring): its largest point displacement ``fraction`` of the
    model size, or, when it moves no point, its largest rotation ``fraction`` rad."""
    n = lay.node_of_point
    arm = np.einsum("pij,pj->pi", rotation_matrices(q0[n]), np.cross(shape[n, 3:], lay.offsets))
    moved = float(np.max(np.linalg.norm(shape[n, :3] + arm, axis=1), initial=0.0))
    size = float(np.linalg.norm(np.ptp(lay.p0, axis=0))) or 1.0
    turned = float(np.max(np.linalg.norm(shape[:, 3:], axis=1), initial=0.0))
    if moved > 1e-9 * size * turned and moved > 0.0:
        return fraction * size / moved
    return fraction / turned if turned > 0.0 else 0.0


def mode_history(mode: dict, a: float, frames: int = FRAMES) -> Results:
    """The animation of ``mode`` (:func:`read_mode`) at amplitude ``a`` as an in-memory :class:`Results`
    (the time history :func:`reference.io.vtk.write_vtk` and ``flexmbs plot --animate`` draw)."""
    tau = np.arange(frames) / frames
    vibration = mode["dataset"] == "modes/shape" and np.isfinite(mode["value"]) and mode["value"] > 0.0
    rate = mode["value"] if vibration else 1.0  # d/dt = f d/dτ
    s, ds = a * np.sin(2.0 * np.pi * tau), 2.0 * np.pi * rate * a * np.cos(2.0 * np.pi * tau)
    phi_u, phi_t = mode["shape"][:, :3], mode["shape"][:, 3:]
    return Results(time=tau / rate, labels=mode["labels"],
                   positions=mode["x0"][None] + s[:, None, None] * phi_u[None],
                   rotations=np.array([_turned(mode["q0"], si * phi_t) for si in s]),
                   velocities=ds[:, None, None] * phi_u[None],
                   angular_velocities=ds[:, None, None] * phi_t[None],  # exp(s φ) turns about φ: ω = ṡ φ
                   attrs={"mode_dataset": mode["dataset"], "mode_value": mode["value"], "mode_amplitude": a})


def write_mode_vtk(domain, path, k: int, directory, frames: int = FRAMES, fraction: float = FRACTION) -> tuple:
    """Write mode ``k`` (from 1) of the results file ``path`` as ``directory/NAME_modeK.vtkhdf`` (``_bucklingK``
    for a buckling shape); ``domain`` is the deck's (the connectivity).  Returns ``(file, history)``: the
    animation (:func:`mode_history`), its attributes ``mode_dataset``, ``mode_value``, ``mode_amplitude``.

    Raises :class:`ModeError` (one line) for a file without that mode or whose nodes are not the deck's.
    """
    mode = read_mode(path, k)
    if mode["shape"].shape != (len(domain.nodes), 6):
        raise ModeError(f"{path}: /{mode['dataset']} has {mode['shape'].shape[0]} nodes, its deck's model "
                        f"{len(domain.nodes)}: the file does not belong to the deck it carries; run the deck again")
    lay = Layout(domain, mode["x0"], mode["q0"])
    a = amplitude(lay, mode["q0"], mode["shape"], fraction)
    kind = "mode" if mode["dataset"] == "modes/shape" else "buckling"
    name = f"{safe_name(domain.name)}_{kind}{k}"
    history = mode_history(mode, a, frames)
    return write_vtk(domain, history, Path(directory), name, about=(mode["x0"], mode["q0"])), history
