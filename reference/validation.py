"""Checks of model data shared by the Python API and the deck reader, and the model's warnings.

The ``Domain.add_*`` methods and the interactions check their input here and raise a
``ValueError`` of one sentence; the deck reader (:class:`reference.io.deck_reader.Reader`)
uses the same predicates and wording inside its ``FILE: ENTRY: problem; fix`` line, so a model
is refused for the same reasons whichever way it is built.

A joint whose point lies far from both of its bodies is legitimate (an offset pin) but often a
typo, and a large axial strain at the end of a run often a stiffness in the wrong units;
:func:`joint_offsets` and :func:`axial_strain` warn of them with a :class:`ModelWarning`, which the
command line prints as one line (:func:`show_warning`, which prints every other warning on one line too).
"""

from __future__ import annotations

import math
import sys
import unicodedata
import warnings

import numpy as np

ZERO_DIRECTION = ("a direction cannot be the zero vector", "give a non-zero direction, e.g. [0, 0, 1]")
"""(problem, fix) of a zero direction (a joint axis, a section axis)."""
JOINT_OFFSET = 1e-3
"""A joint point farther than this fraction of the model size from every point of both bodies
is warned about, unless the deck marks the offset as intended (``[[joints]] intended_offset =
true``).  The points of a body are its node and its named points (a rigid bar's start, centre and
end); joints sit on those in every shipped model (largest distance 0; Andrews' loop-closing joints
at E, such as E3, sit on the named point E of each of their bodies).  Issue 38: a slider's pin
0.04 m off, 0.13 × the model size, was silent under the former threshold (a quarter of the model)
and moved the slider's end 5 mm; no drawing means a pin a thousandth of the model off its bodies
without saying so."""
MAX_AXIAL_STRAIN = 0.05
"""Largest axial strain ``|N| / EA`` (the section force at an element's midpoint over its axial
stiffness) at any output of a completed run above which it is warned about: a few per cent, far
beyond the elastic range of metals (steel yields near 0.2 %); a stiffness typed in MPa where the deck
is in Pa stretched a steel rod by tens of per cent (issue 38) and completed.  The shipped models stay
below it (docs/benchmarks.md §10)."""


class LabelError(KeyError):
    """A reference to a node that the model does not have: ``problem`` and ``fix`` (a close label, the
    forms a reference takes), one line ``problem; fix`` — the deck reader puts the same two parts in its
    ``FILE: ENTRY: problem; fix`` line."""

    def __init__(self, problem: str, fix: str = ""):
        self.problem, self.fix = problem, fix
        super().__init__(problem + (f"; {fix}" if fix else ""))

    def __str__(self) -> str:
        return self.args[0]


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


def not_integer(value, minimum: int = 1) -> bool:
    """Whether ``value`` is not an integer ≥ ``minimum`` (a bool, a float such as ``8.0``, a string …)."""
    return isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum


def unusable_label(value: str) -> bool:
    """Whether the string ``value`` is not a usable name: labels name nodes, results datasets and
    files, so 1–200 printable characters without path separators."""
    bad = [c for c in value if unicodedata.category(c)[0] == "C" or c in "/\\"]
    return not value.strip() or bool(bad) or value in (".", "..") or len(value) > 200


def _clip(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:59] + "…"


def integer(value, what: str, minimum: int = 1) -> int:
    """``value`` as an int ≥ ``minimum``, or a ``ValueError`` ``what: expected an integer ≥ 1, got 8.0``
    (the deck reader's wording, :meth:`reference.io.deck_reader.Reader.integer`)."""
    if not_integer(value, minimum):
        raise ValueError(f"{what}: expected an integer ≥ {minimum}, got {_clip(value)}")
    return int(value)


def label(value, what: str) -> str:
    """``value`` if a usable name (:func:`unusable_label`), else a ``ValueError`` in the deck reader's
    wording (:meth:`reference.io.deck_reader.Reader.label`)."""
    if not isinstance(value, str):
        raise ValueError(f"{what}: expected a string, got {_clip(value)}")
    if unusable_label(value):
        raise ValueError(f"{what}: unusable name {_clip(value)}; give 1–200 printable characters without "
                         "'/' or '\\' (e.g. 'arm_2')")
    return value


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


def far_joints(domain) -> list[tuple]:
    """``(distance / model size, joint, [distance from body_i, from body_j], model size)``, farthest first,
    of every joint whose point lies farther than :data:`JOINT_OFFSET` × the model size (the diagonal of
    the box around every node and named point) from both of its bodies (the ground counts as near),
    those marked ``intended_offset`` left out."""
    if not domain.joints or not domain.nodes:
        return []
    points = np.concatenate([_body_points(n) for n in domain.nodes])
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    found = []
    for joint in domain.joints:
        if joint.body_i is None or joint.body_j is None or joint.intended_offset or not size > 0.0:
            continue
        point = np.asarray(joint.point, dtype=float)
        far = [float(np.min(np.linalg.norm(_body_points(n) - point, axis=1))) for n in (joint.body_i, joint.body_j)]
        if min(far) > JOINT_OFFSET * size:
            found.append((min(far) / size, joint, far, size))
    return sorted(found, key=lambda item: -item[0])


def joint_offsets(domain) -> list[str]:
    """The line warning of the joints far from both of their bodies (:func:`far_joints`): ``[]`` if none,
    else one line naming the farthest and how many more, also issued as a :class:`ModelWarning`."""
    found = far_joints(domain)
    if not found:
        return []
    ratio, joint, far, size = found[0]
    more = f" (and {len(found) - 1} more joints)" if len(found) > 1 else ""
    line = (f"joint {joint.label!r}{more}: its point is {far[0]:.3g} from {joint.body_i.label!r} and "
            f"{far[1]:.3g} from {joint.body_j.label!r} ({ratio:.2g} × the model size {size:.3g}); "
            "check the point and its units, or mark an intended offset with intended_offset = true")
    warnings.warn(line, ModelWarning, stacklevel=2)
    return [line]


def axial_strain(largest: float, element: str, t: float) -> str:
    """The line warning of a completed run whose largest axial strain ``largest`` (``|N| / EA``, of the
    element labelled ``element`` at time ``t`` [s]) is above :data:`MAX_AXIAL_STRAIN`, else ``""``; the
    line is also issued as a :class:`ModelWarning`."""
    if not largest > MAX_AXIAL_STRAIN:
        return ""
    line = (f"element {element!r} reached an axial strain |N|/EA of {largest:.3g} at t = {t:.6g}, above "
            f"{MAX_AXIAL_STRAIN:g}: check the stiffness's units (EA in N, e.g. 2.1e11 Pa × the area in m²) "
            "and the loads")
    warnings.warn(line, ModelWarning, stacklevel=2)
    return line


def show_warning(message, category, filename, lineno, file=None, line=None):
    """``warnings.showwarning`` of the command line: every warning on one line, ``flexmbs: warning: …``,
    without the source file and line Python prints (a :class:`ModelWarning` as its message alone, any
    other, e.g. SciPy's ``MatrixRankWarning``, with its category's name)."""
    out = sys.stderr if file is None else file
    text = " ".join(str(message).split())
    if not issubclass(category, ModelWarning):
        text = f"{category.__name__}: {text}"
    try:
        out.write(f"flexmbs: warning: {text}\n")
    except OSError:  # a closed or broken stream: a warning is not worth a failure
        pass
