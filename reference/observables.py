"""Observables ("sensors"): one grammar for ``[crosscheck]``, ``[checks]``, ``flexmbs plot`` and reports.

An observable is a short text naming a time history that can be read from
any results file (either engine)::

    KIND[.COMPONENT]:ARGUMENTS

============================  ===============================  ==========  =======================
text                          meaning                          shape       components
============================  ===============================  ==========  =======================
``position:NODE``             node position, inertial [m]      (n, 3)      x y z norm
``velocity:NODE``             node velocity, inertial [m/s]    (n, 3)      x y z norm
``angular_velocity:NODE``     angular velocity, body [rad/s]   (n, 3)      x y z norm
``rotation:NODE``             Euler parameters (scalar first)  (n, 4)      q0 q1 q2 q3
``position:*``                every node's position            (n, N, 3)   —
``distance:P,Q``              ‖x_P − x_Q‖ [m]                  (n,)        —
``angle.AXIS:A[,B]``          rotation of body A relative to   (n,)        AXIS = x, y or z
                              B (default the ground) about an
                              inertial axis, from t = 0 [rad]
``deflection:M,A,B``          transverse deflection of node M  (n, 3)      x y z norm
                              from the chord A–B [m]
``reaction_force:JOINT``      force of JOINT on its body_i,    (n, 3)      x y z norm
                              inertial [N]
``reaction_moment:JOINT``     moment of JOINT on its body_i    (n, 3)      x y z norm
                              about the joint point [N m]
``prescribed_reaction:JOINT`` force of the prescribed          (n,)        —
                              displacement JOINT along its
                              direction: the load [N]
``section_force:ELEMENT``     N at the element's midpoint,     (n, 3)      1 2 3 norm
                              section frame [N]
``section_moment:ELEMENT``    M, section frame [N m]           (n, 3)      1 2 3 norm
``energy:WHICH``              kinetic, strain, external_work,  (n,)        —
                              dissipated or total (T + U) [J]
============================  ===============================  ==========  =======================

NODE is a node label (``crank``, ``coupler:2``) or ``BEAM:start`` / ``BEAM:end``;
ELEMENT an element label ``BEAM/i`` (i from 0) or ``BEAM/end``; JOINT a joint's
label.  One shorthand: ``midspan_deflection:BEAM`` (=
``deflection:BEAM:<middle>,BEAM:start,BEAM:end``, the beam's middle node from its chord).
Observables written for one deck (the three-bar's rocker and crank angles) are the
verification's: :mod:`flexmbs.verification.observables`.

The relative angle is the twist of the relative rotation
``R = A_B0 A_Bᵀ A_A A_A0ᵀ`` about the axis u (swing–twist decomposition of its
quaternion ``(w, v)``: θ = 2 atan2(v·u, w)), unwrapped in time; for a planar
motion about u it is the plain rotation angle.  The deflection is
``d = (x_M − x_A) − ((x_M − x_A)·c) c`` with c the unit chord ``A → B``: it
needs no plane and works for bending in any direction.

Python API::

    obs = parse("reaction_moment.z:crank drive", domain)   # checked against the model: ObservableError
    obs.evaluate(results)                                   # → numpy array, shape per the table
    obs.describe()                                          # one line with the unit

``domain`` may be a :class:`~reference.domain.Domain` or a
:class:`~reference.io.results.Results` (both know the node, joint and element
labels).  :func:`parse` refuses a wrong name or reference with one message
``problem; fix`` (the deck reader adds the file and the entry).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np

from reference.joints.joint import PRESCRIBED
from reference.rotation import EulerParameters


class ObservableError(ValueError):
    """An observable text that cannot be evaluated; the message says why and what would be valid."""


VECTOR = ("x", "y", "z", "norm")
SECTION = ("1", "2", "3", "norm")
KINDS = {
    # kind: (arguments, components, unit, description)
    "position": ("node", VECTOR, "m", "position of node {0}, inertial"),
    "velocity": ("node", VECTOR, "m/s", "velocity of node {0}, inertial"),
    "angular_velocity": ("node", VECTOR, "rad/s", "angular velocity of node {0}, body frame"),
    "rotation": ("node", ("q0", "q1", "q2", "q3"), "-", "Euler parameters of node {0}"),
    "distance": ("node,node", (), "m", "distance between {0} and {1}"),
    "angle": ("body[,body]", ("x", "y", "z"), "rad", "rotation of {0} relative to {1} since t = 0"),
    "deflection": ("node,node,node", VECTOR, "m", "deflection of {0} from the chord {1}–{2}"),
    "reaction_force": ("joint", VECTOR, "N", "force of joint '{0}' on its body_i, inertial"),
    "reaction_moment": ("joint", VECTOR, "N m", "moment of joint '{0}' on its body_i about the joint point, inertial"),
    "prescribed_reaction": ("joint", (), "N", "force of prescribed displacement '{0}' along its direction"),
    "section_force": ("element", SECTION, "N", "section force of element {0}, section frame"),
    "section_moment": ("element", SECTION, "N m", "section moment of element {0}, section frame"),
    "energy": ("which", (), "J", "{0} energy"),
}
ENERGIES = ("kinetic", "strain", "external_work", "dissipated", "total")
SHORTHANDS = ("midspan_deflection:BEAM",)


class _Names:
    """The labels an observable may reference, from a Domain or a Results."""

    def __init__(self, source):
        if hasattr(source, "nodes"):  # a Domain
            self.nodes = [n.label for n in source.nodes]
            self.joints = [j.label for j in source.joints]
            self.elements = [e.label for e in source.elements]
        else:
            self.nodes = list(source.labels)
            self.joints = list(getattr(source, "joint_labels", []) or [])
            self.elements = list(getattr(source, "element_labels", []) or [])
        self.beams = {}
        for label in self.nodes:
            beam, _, i = label.rpartition(":")
            if beam and i.isdigit():
                self.beams.setdefault(beam, []).append(int(i))

    def node(self, ref: str) -> str:
        if ref in self.nodes:
            return ref
        beam, _, which = ref.rpartition(":")
        if beam in self.beams and which in ("start", "end"):
            return f"{beam}:{(min if which == 'start' else max)(self.beams[beam])}"
        options = self.nodes + [f"{b}:{w}" for b in self.beams for w in ("start", "end")]
        raise ObservableError(f"no node {ref!r}" + _hint(ref, options, "node labels, e.g."))

    def joint(self, ref: str) -> str:
        if ref in self.joints:
            return ref
        raise ObservableError(f"no joint {ref!r}" + _hint(ref, self.joints, "joints:"))

    def element(self, ref: str) -> str:
        if ref in self.elements:
            return ref
        beam, _, which = ref.rpartition("/")
        ids = sorted(int(lbl.rpartition("/")[2]) for lbl in self.elements if lbl.rpartition("/")[0] == beam)
        if ids and which in ("start", "end"):
            return f"{beam}/{ids[0] if which == 'start' else ids[-1]}"
        raise ObservableError(f"no element {ref!r}" + _hint(ref, self.elements, "elements (BEAM/i, from 0):"))

    def body(self, ref: str) -> str:
        return self.node(ref)


def _hint(ref, options, what) -> str:
    close = difflib.get_close_matches(ref, list(options), n=1)
    if close:
        return f"; did you mean '{close[0]}'?"
    return f"; {what} {', '.join(list(options)[:6]) or 'none'}"


@dataclass(frozen=True)
class Observable:
    """A parsed observable: ``kind``, ``component`` ('' for all), ``args`` (resolved labels), ``text``.

    Node references are kept as written (``coupler:end``) and resolved on each
    results file, so one observable evaluates on a refined mesh too.
    """

    text: str
    kind: str
    component: str
    args: tuple

    @property
    def is_angle(self) -> bool:
        """True for angles (differences are compared modulo 2π)."""
        return self.kind == "angle"

    @property
    def unit(self) -> str:
        return KINDS[self.kind][2] if self.kind in KINDS else "m"

    def describe(self) -> str:
        """One line: what it is, its component, its unit."""
        if self.kind == "positions":
            return "position of every node, inertial [m]"
        args = list(self.args) + ["the ground"] * (2 - len(self.args))
        what = KINDS[self.kind][3].format(*args)
        if self.kind == "angle":
            what = what.replace("since", f"about the inertial {self.component} axis since")
        elif self.component == "norm":
            what = "magnitude of the " + what
        elif self.component:
            what = f"{self.component} component of the {what}"
        return f"{what} [{self.unit}]"

    def evaluate(self, results) -> np.ndarray:
        """The time history from ``results`` (:class:`reference.io.results.Results`, either engine)."""
        values = self._values(results)
        comps = KINDS.get(self.kind, (None, ()))[1]
        if self.component and self.kind != "angle":
            if self.component == "norm":
                return np.linalg.norm(values, axis=-1)
            return values[..., comps.index(self.component)]
        return values

    def _values(self, r) -> np.ndarray:
        k, a = self.kind, self.args
        if k == "positions":
            return r.positions
        if k in ("position", "velocity", "angular_velocity", "rotation"):
            return getattr(r, k)(a[0])
        if k == "distance":
            return np.linalg.norm(r.position(a[0]) - r.position(a[1]), axis=1)
        if k == "deflection":
            m, p, q = (r.position(x) for x in a)
            c = q - p
            c = c / np.linalg.norm(c, axis=1)[:, None]
            d = m - p
            return d - np.sum(d * c, axis=1)[:, None] * c
        if k == "angle":
            return relative_angle(r, a[0], a[1] if len(a) > 1 else None, "xyz".index(self.component))
        if k == "reaction_force":
            return _present(r.reaction(a[0])[0], self.text)
        if k == "reaction_moment":
            return _present(r.reaction(a[0])[1], self.text)
        if k == "prescribed_reaction":
            values = np.asarray(r.data("joints/prescribed_reaction", r.joint_index(a[0])), dtype=float)
            if not np.any(np.isfinite(values)):
                raise ObservableError(f"{self.text}: the results have no reaction of a prescribed displacement "
                                      f"{a[0]!r}; name a [[prescribed_displacements]] entry")
            return values
        if k == "section_force":
            return _present(r.section_force(a[0]), self.text)
        if k == "section_moment":
            return _present(r.section_moment(a[0]), self.text)
        if k == "energy":
            if a[0] == "total":
                return r.energy["kinetic"] + r.energy["strain"]
            return r.energy[a[0]]
        raise ObservableError(f"unknown observable kind {k!r}")


def _present(values, text):
    if values is None:
        raise ObservableError(f"{text}: the results file has no such dataset (written by an older version?)")
    return values


def relative_angle(results, body, other=None, axis: int = 2) -> np.ndarray:
    """Rotation angle [rad] of ``body`` relative to ``other`` (None: the ground) about inertial axis
    ``axis`` (0, 1, 2), measured from the first output and unwrapped (see the module docstring)."""
    def quats(label):
        return [EulerParameters(q) for q in results.rotation(label)]

    qa = quats(body)
    qb = quats(other) if other is not None else [EulerParameters(np.array([1.0, 0, 0, 0]))] * len(qa)
    theta = np.empty(len(qa))
    for n in range(len(qa)):
        rel = qb[0].product(qb[n].conjugate()).product(qa[n]).product(qa[0].conjugate()).q
        theta[n] = 2.0 * np.arctan2(rel[1 + axis], rel[0])
    return np.unwrap(theta)


def _split_args(text: str, n_max: int) -> list:
    return [s.strip() for s in text.split(",")] if n_max > 1 else [text.strip()]


def parse(text, domain) -> Observable:
    """Parse and check an observable against a model (Domain) or a results file (Results).

    Raises
    ------
    ObservableError
        One line ``problem; fix``: unknown kind, component, node, joint or element.
    """
    if not isinstance(text, str) or not text.strip():
        raise ObservableError(f"expected an observable text such as 'position:beam:end', got {text!r}")
    text = text.strip()
    names = _Names(domain)
    head, colon, rest = text.partition(":")
    kind, _, component = head.partition(".")
    if kind == "midspan_deflection":
        beam = rest.strip()
        if not beam:
            raise ObservableError("'midspan_deflection' needs its beam: write 'midspan_deflection:BEAM'")
        if beam not in names.beams:
            raise ObservableError(f"no beam {beam!r}" + _hint(beam, list(names.beams), "meshed beams:"))
        n = max(names.beams[beam])
        if n % 2:
            raise ObservableError(f"beam {beam!r} has {n} elements, an odd number: no middle node; "
                                  f"use 'deflection:{beam}:<i>,{beam}:start,{beam}:end'")
        return Observable(text, "deflection", "", (f"{beam}:{n // 2}", f"{beam}:start", f"{beam}:end"))
    if kind not in KINDS:
        raise ObservableError(f"unknown observable {kind!r}" + _hint(kind, list(KINDS) + list(SHORTHANDS),
                                                                      "kinds:"))
    args_kind, comps, _, _ = KINDS[kind]
    if not colon or not rest.strip():
        raise ObservableError(f"'{kind}' needs its argument: write '{kind}:{args_kind.upper()}'")
    if component and component not in comps:
        raise ObservableError(f"'{kind}' has no component {component!r}; "
                              + (f"components: {', '.join(comps)}" if comps else "it is a scalar: drop the component"))
    if kind == "angle" and not component:
        raise ObservableError("'angle' needs its axis: write 'angle.z:BODY' (or .x, .y), optionally 'angle.z:BODY,OTHER'")
    if kind == "position" and rest.strip() == "*":
        if component:
            raise ObservableError("'position:*' takes no component")
        return Observable(text, "positions", "", ())
    if kind in ("position", "velocity", "angular_velocity", "rotation"):
        names.node(rest.strip())
        return Observable(text, kind, component, (rest.strip(),))
    if kind in ("reaction_force", "reaction_moment"):
        return Observable(text, kind, component, (names.joint(rest.strip()),))
    if kind == "prescribed_reaction":
        label = names.joint(rest.strip())
        kinds = {j.label: j.kind for j in getattr(domain, "joints", [])}
        if kinds and kinds[label] != PRESCRIBED:
            raise ObservableError(f"joint {label!r} is a {kinds[label]}, not a prescribed displacement; "
                                  "prescribed_reaction names a [[prescribed_displacements]] entry")
        return Observable(text, kind, component, (label,))
    if kind in ("section_force", "section_moment"):
        return Observable(text, kind, component, (names.element(rest.strip()),))
    if kind == "energy":
        which = rest.strip()
        if which not in ENERGIES:
            raise ObservableError(f"no energy {which!r}" + _hint(which, ENERGIES, "energies:"))
        return Observable(text, kind, component, (which,))
    args = _split_args(rest, 3)
    wanted = {"distance": (2, 2), "angle": (1, 2), "deflection": (3, 3)}[kind]
    if not wanted[0] <= len(args) <= wanted[1]:
        raise ObservableError(f"'{kind}' takes {args_kind.replace('[', ' [')} (comma-separated), got {len(args)}: {rest!r}")
    for a in args:
        names.node(a)
    return Observable(text, kind, component, tuple(args))


def default_crosscheck() -> dict:
    """The comparison used when a deck has no ``[crosscheck]`` table: every node's position."""
    return {"all_nodes": {"observable": "position:*", "tolerance": 0.01, "relative_to": "length",
                          "reason": "default comparison (the deck has no [crosscheck] table): every node's "
                                    "position within 1 % of the model's length"}}


def wrap(angle) -> np.ndarray:
    """Angle differences wrapped to (−π, π]."""
    return np.angle(np.exp(1j * np.asarray(angle)))
