"""Checks of model data shared by the Python API and the deck reader, and the model's warnings.

The ``Domain.add_*`` methods and the interactions check their input here and raise a
``ValueError`` of one sentence; the deck reader (:class:`reference.io.deck_reader.Reader`)
uses the same predicates and wording inside its ``FILE: ENTRY: problem; fix`` line, so a model
is refused for the same reasons whichever way it is built.

A joint whose point lies far from both of its bodies is legitimate (an offset pin) but often a
typo; :func:`joint_offsets` warns of it with a :class:`ModelWarning`, which the command line
prints as one line (:func:`show_warning`).
"""

from __future__ import annotations

import math
import sys
import warnings

import numpy as np

ZERO_DIRECTION = ("a direction cannot be the zero vector", "give a non-zero direction, e.g. [0, 0, 1]")
"""(problem, fix) of a zero direction (a joint axis, a section axis)."""
JOINT_OFFSET = 0.25
"""A joint point farther than this fraction of the model size from every point of both bodies
is warned about.  The points of a body are its node and its named points (a rigid bar's start,
centre and end); joints sit on those in every shipped model (largest distance 0 × the model
size), and an offset pin of a quarter of the model is no longer a detail of the drawing: the
reproducer of a misplaced pin, 0.3 m off both bodies of a 1 m model, moved the tip by 0.56 m."""


class ModelWarning(UserWarning):
    """Something legitimate but suspicious in a model (printed as one line by the command line)."""


def vector(value, what: str, n: int = 3, fix: str = "") -> np.ndarray:
    """``value`` as ``n`` finite numbers, or a ``ValueError`` naming ``what`` (e.g. ``"Gravity g"``),
    ending with ``fix``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (n,) or not np.all(np.isfinite(arr)):
        text = repr(value)
        text = text if len(text) <= 60 else text[:59] + "…"
        raise ValueError(f"{what}: expected a vector of {n} finite numbers, got {text}" + (f"; {fix}" if fix else ""))
    return arr


def direction(value, what: str) -> np.ndarray:
    """A non-zero 3-vector (:data:`ZERO_DIRECTION`)."""
    vec = vector(value, what)
    if not math.hypot(*vec) > 0.0:
        raise ValueError(f"{what}: {ZERO_DIRECTION[0]}; {ZERO_DIRECTION[1]}")
    return vec


def _body_points(node) -> np.ndarray:
    points = [np.asarray(node.position, dtype=float)] + [np.asarray(p, dtype=float)
                                                         for p in getattr(node, "points", {}).values()]
    return np.array(points).reshape(-1, 3)


def joint_offsets(domain) -> list[str]:
    """One line for each joint whose point lies farther than :data:`JOINT_OFFSET` × the model size
    (the diagonal of the box around every node and named point) from both of its bodies (the
    ground counts as near); each is also issued as a :class:`ModelWarning`."""
    if not domain.joints:
        return []
    points = np.concatenate([_body_points(n) for n in domain.nodes]) if domain.nodes else np.zeros((1, 3))
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    lines = []
    for joint in domain.joints:
        if joint.body_i is None or joint.body_j is None:
            continue
        point = np.asarray(joint.point, dtype=float)
        far = [float(np.min(np.linalg.norm(_body_points(n) - point, axis=1))) for n in (joint.body_i, joint.body_j)]
        if size > 0.0 and min(far) > JOINT_OFFSET * size:
            lines.append(f"joint {joint.label!r}: its point is {far[0]:.3g} from {joint.body_i.label!r} and "
                         f"{far[1]:.3g} from {joint.body_j.label!r} ({min(far) / size:.2g} × the model size "
                         f"{size:.3g}); check the point, or ignore this for an intended offset")
    for line in lines:
        warnings.warn(line, ModelWarning, stacklevel=2)
    return lines


def show_warning(message, category, filename, lineno, file=None, line=None):
    """``warnings.showwarning`` of the command line: a :class:`ModelWarning` as one line
    ``flexmbs: warning: …``, any other warning as Python prints it."""
    out = sys.stderr if file is None else file
    if issubclass(category, ModelWarning):
        out.write(f"flexmbs: warning: {message}\n")
    else:
        out.write(warnings.formatwarning(message, category, filename, lineno, line))
