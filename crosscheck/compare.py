"""Compare two results files of one deck (any engines honouring the results contract).

``compare(a, b, deck_checks)`` returns the differences of

- every common node's trajectory (:func:`paired_nodes`): positions (max and RMS, absolute and relative
  to the model's characteristic length, the diagonal of its initial bounding
  box) and rotations (the angle of ``q_a* ⊗ q_b``);
- the observables the deck names in ``[crosscheck]`` (see below), absolute and
  relative to the observable's peak in file ``a``;
- the constraint drift of both files (max ‖Φ‖ and ‖BV + Φ_t‖),

and a verdict per observable against the tolerance the deck states with its
reason.  Output times must coincide (both engines write the deck's output
interval); ``b`` is interpolated linearly onto ``a``'s times otherwise.

Deck syntax::

    [crosscheck.tip]
    observable = "position:beam:end"       # any observable (reference/observables.py, docs/observables.md)
    tolerance = 0.005
    relative_to = "length"                 # "length", "peak" or "absolute"
    reason = "..."

The difference per output time is ``|a − b|`` for a scalar (modulo 2π for an
angle), ``‖a − b‖`` for a vector and the largest node's ``‖a − b‖`` for
``position:*``; its maximum over time is divided by the scale (the model's
length, the peak of ``|a|`` / ``‖a‖`` in file ``a``, or 1) and compared with
the tolerance.  A deck without ``[crosscheck]`` tables is compared by
:func:`reference.observables.default_crosscheck` (every node's position, 1 %
of the length).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reference.observables import ObservableError, parse, wrap
from reference.rotation import EulerParameters


@dataclass
class Verdict:
    name: str
    observable: str
    max_difference: float
    rms_difference: float
    scale: float
    tolerance: float
    relative_to: str
    reason: str

    @property
    def measure(self) -> float:
        return self.max_difference / self.scale

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.measure) and self.measure <= self.tolerance)


def pointwise(values) -> np.ndarray:
    """Per output time: ``|v|`` of a scalar, ``‖v‖`` of a vector, max over points of ``‖v‖`` for (n, N, 3)."""
    values = np.asarray(values)
    if values.ndim == 1:
        return np.abs(values)
    if values.ndim == 2:
        return np.linalg.norm(values, axis=1)
    return np.linalg.norm(values, axis=2).max(axis=1)


def _on_times(values, t_from, t_to):
    if len(t_from) == len(t_to) and np.allclose(t_from, t_to, rtol=0, atol=1e-9):
        return values
    flat = values.reshape(len(t_from), -1)
    out = np.stack([np.interp(t_to, t_from, flat[:, k]) for k in range(flat.shape[1])], axis=1)
    return out.reshape((len(t_to),) + values.shape[1:])


def paired_nodes(a, b) -> tuple[list, list]:
    """Indices ``(ia, ib)`` of the nodes of ``a`` and ``b`` that are one point: the same label at the same
    initial position, or, where the meshes differ (a converged-mesh comparison: beam ``B`` in n and in 8n
    elements), a node ``B:i`` of ``a`` and the node ``B:j`` of ``b`` at its initial position (1e-9 of the
    model's size)."""
    xa, xb = np.asarray(a.positions[0]), np.asarray(b.positions[0])
    tol = 1e-9 * max(float(np.ptp(xa, axis=0).max()), 1.0)
    index_b = {lbl: j for j, lbl in enumerate(b.labels)}
    by_beam: dict = {}
    for j, lbl in enumerate(b.labels):
        by_beam.setdefault(lbl.rpartition(":")[0], []).append(j)
    ia, ib = [], []
    for i, lbl in enumerate(a.labels):
        j = index_b.get(lbl)
        if j is None or np.linalg.norm(xb[j] - xa[i]) > tol:
            beam = lbl.rpartition(":")[0]
            candidates = np.array(by_beam.get(beam, []) if beam else [], dtype=int)
            distance = np.linalg.norm(xb[candidates] - xa[i], axis=1) if len(candidates) else np.array([np.inf])
            j = int(candidates[np.argmin(distance)]) if distance.min() <= tol else None
        if j is not None:
            ia.append(i)
            ib.append(j)
    return ia, ib


def compare(a, b, checks: dict | None = None) -> dict:
    """Differences between results ``a`` and ``b`` (see the module docstring)."""
    ia, ib = paired_nodes(a, b)
    pos_b = _on_times(b.positions[:, ib], b.time, a.time)
    rot_b = _on_times(b.rotations[:, ib], b.time, a.time)
    x0 = a.positions[0, ia]
    length = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0))) or 1.0
    dpos = np.linalg.norm(a.positions[:, ia] - pos_b, axis=2)
    angles = np.zeros(dpos.shape)
    for t in range(dpos.shape[0]):
        for k in range(dpos.shape[1]):
            qa = EulerParameters(a.rotations[t, ia[k]])
            angles[t, k] = qa.conjugate().product(EulerParameters(rot_b[t, k])).angle()
    out = {
        "nodes": len(ia), "length": length,
        "position_max": float(dpos.max()), "position_rms": float(np.sqrt(np.mean(dpos**2))),
        "position_max_relative": float(dpos.max() / length),
        "rotation_max": float(angles.max()), "rotation_rms": float(np.sqrt(np.mean(angles**2))),
        "drift": {name: {"violation_max": float(np.nanmax(r.constraint_violation)),
                         "velocity_violation_max": float(np.nanmax(r.velocity_constraint_violation))}
                  for name, r in (("a", a), ("b", b))},
        "verdicts": [],
    }
    for name, spec in (checks or {}).items():
        obs = spec["observable"]
        try:
            parsed_a, parsed_b = parse(obs, a), parse(obs, b)
        except ObservableError as exc:
            raise ObservableError(f"crosscheck.{name}.observable: {exc}") from None
        if obs == "position:*":  # every node: the paired ones (two meshes of one model have other node counts)
            va, vb = a.positions[:, ia], _on_times(b.positions[:, ib], b.time, a.time)
        else:
            va = parsed_a.evaluate(a)
            vb = _on_times(parsed_b.evaluate(b), b.time, a.time)
        diff = va - vb
        if parsed_a.is_angle:
            diff = wrap(diff)
        d = pointwise(diff)
        relative_to = spec.get("relative_to", "absolute")
        scale = {"length": length, "peak": float(np.max(pointwise(va))), "absolute": 1.0}[relative_to]
        out["verdicts"].append(Verdict(name, obs, float(np.max(d)), float(np.sqrt(np.mean(d**2))), scale,
                                       float(spec["tolerance"]), relative_to, str(spec.get("reason", ""))))
    return out
