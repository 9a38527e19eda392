"""Model decks: the connector tables, ``[[joints]]``, ``[[prescribed_displacements]]`` and ``[[springs]]``.

Joints and force elements both connect two bodies (:class:`reference.connector.Connector`); their
tables are read here for :func:`reference.io.deck.load_deck`, with its :class:`~reference.io.deck_reader.Reader`
(the checks and one-line messages) and its references (``refs``: node labels, named points, time
functions).  Every key is documented in ``docs/deck.md``.
"""

from __future__ import annotations

import difflib
import warnings

import numpy as np

from reference.domain import Domain
from reference.expressions import ExpressionError
from reference.forces import KINDS as SPRING_KINDS
from reference.forces import Bushing, PointToPoint, Rotational
from reference.interactions import Expression
from reference.io.deck_reader import Reader, show
from reference.joints.formulations import DEFAULT, REGISTRY
from reference.joints.formulations import deck_keys as formulation_keys
from reference.joints.joint import PRESCRIBED
from reference.joints.joint import ROWS as JOINT_KINDS
from reference.validation import ModelWarning

SPRING_KEYS = {
    "point_to_point": (["body_i", "point_i", "stiffness"],
                       ["body_j", "point_j", "damping", "rest_length", "force_function"]),
    "rotational": (["body_i", "stiffness"], ["body_j", "axis", "reference", "damping", "rest_angle"]),
    "bushing": (["body_i", "point", "stiffness"], ["body_j", "axis", "reference", "damping"]),
}


def read_joints(rd: Reader, deck: dict, domain: Domain, refs) -> None:
    """``[[joints]]`` (a drive's expression gets its integral here when its mode is ``velocity``)."""
    tfs = refs.tfs
    for i, jt in enumerate(rd.items(deck, "joints")):
        entry = f"joints[{i}]"
        own_keys = formulation_keys()
        rd.keys(jt, entry, required=["kind", "body_i", "point"],
                optional=["label", "body_j", "axis", "reference", "formulation", "time_function", "mode",
                          "intended_offset", *own_keys])
        kind = rd.string(jt["kind"], f"{entry}.kind")
        if kind == PRESCRIBED:
            raise rd.fail(f"{entry}.kind", "a prescribed displacement is not a [[joints]] kind",
                          "write it as a [[prescribed_displacements]] entry (node, direction, time_function)")
        if kind not in JOINT_KINDS:
            close = difflib.get_close_matches(kind, list(JOINT_KINDS), n=1)
            raise rd.fail(f"{entry}.kind", f"unknown joint kind {show(kind)}",
                          f"did you mean '{close[0]}'?" if close else f"one of: {', '.join(JOINT_KINDS)}")
        name = rd.choice(jt.get("formulation", DEFAULT), f"{entry}.formulation", REGISTRY, "joint formulation")
        for key in jt:
            if key in own_keys and key not in REGISTRY[name].deck_keys:
                raise rd.fail(f"{entry}.{key}", f"applies to formulation = {show(own_keys[key])}, not {show(name)}",
                              f"remove it, or set formulation = {show(own_keys[key])}")
        formulation = REGISTRY[name].from_deck(rd, jt, entry)
        body_i = refs.node(jt["body_i"], f"{entry}.body_i")
        body_j = None
        if jt.get("body_j", "ground") != "ground":
            body_j = refs.node(jt["body_j"], f"{entry}.body_j")
        if body_j is body_i:
            raise rd.fail(entry, "body_i and body_j are the same body")
        drive = kind.endswith("_drive")
        if drive and "time_function" not in jt:
            raise rd.fail(entry, f"a {kind} needs a time_function (the prescribed motion or its rate)")
        if not drive and ("time_function" in jt or "mode" in jt):
            raise rd.fail(entry, "time_function and mode apply to rotation_drive and displacement_drive only")
        tf = None
        if drive:
            name = rd.string(jt["time_function"], f"{entry}.time_function")
            if name not in tfs:
                raise rd.fail(f"{entry}.time_function", f"no time function {show(name)}", f"defined: {', '.join(tfs) or 'none'}")
            tf = tfs[name]
        mode = rd.choice(jt.get("mode", "position"), f"{entry}.mode", ("position", "velocity"), "mode",
                         "'position' (the time function is the angle/displacement) or 'velocity' (its rate)")
        if tf is not None and mode == "velocity" and isinstance(tf, Expression) and not tf.with_integral:
            try:
                tf = tfs[jt["time_function"]] = Expression(tf.expr, with_integral=True)
            except ExpressionError as exc:
                raise rd.fail(f"time_functions.{jt['time_function']}.expr", str(exc)) from None
        intended = rd.boolean(jt.get("intended_offset", False), f"{entry}.intended_offset")
        reference = rd.vector(jt["reference"], f"{entry}.reference") if "reference" in jt else None
        label = rd.label(jt.get("label", f"{kind}:{i}"), f"{entry}.label")
        point = rd.vector(jt["point"], f"{entry}.point")
        axis = rd.direction(jt.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis")
        if reference is not None:
            reference = rd.direction(jt["reference"], f"{entry}.reference")
        try:
            domain.add_joint(kind, body_i, body_j, point, axis=axis, reference=reference,
                             formulation=formulation,
                             time_function=tf, mode=mode, label=label, intended_offset=intended)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None
    sliding = [j for j in domain.joints if j.kind == "displacement_drive"]
    if sliding:
        j = sliding[0]
        more = f" (and the {len(sliding) - 1} other displacement drives)" if len(sliding) > 1 else ""
        axis = ", ".join(f"{c:g}" for c in j.frame[:, 2] + 0.0)
        warnings.warn(f"joint {j.label!r}{more}: displacement_drive: +s moves body_i {j.body_i.label!r} along +axis "
                      f"[{axis}] relative to {'the ground' if j.body_j is None else repr(j.body_j.label)}; "
                      "decks written for the former sign (body_i moved by −s) flip their time function",
                      ModelWarning, stacklevel=3)


def read_prescribed_displacements(rd: Reader, deck: dict, domain: Domain, refs) -> None:
    """``[[prescribed_displacements]]``: displacement control, a one-row joint to the ground
    (:data:`reference.joints.joint.PRESCRIBED`) that moves ``point`` (default the node) by the time
    function's value along the inertial ``direction``; refused along a fixed coordinate of the node."""
    fixed: dict = {}
    for bc in domain.boundary_conditions:
        fixed.setdefault(id(bc.node), set()).update(d for d in bc.dofs if d < 3)
    for i, pd in enumerate(rd.items(deck, "prescribed_displacements")):
        entry = f"prescribed_displacements[{i}]"
        rd.keys(pd, entry, required=["node", "direction", "time_function"], optional=["label", "point"])
        node = refs.node(pd["node"], f"{entry}.node")
        direction = rd.direction(pd["direction"], f"{entry}.direction")
        direction = direction / np.linalg.norm(direction)
        along = [k for k in sorted(fixed.get(id(node), ())) if abs(direction[k]) > 1e-12]
        if along:
            names = ", ".join("xyz"[k] for k in along)
            raise rd.fail(f"{entry}.direction", f"has a component along {names}, fixed on node {node.label!r} "
                          "([[fixed]]/[[clamps]])", "give a direction across its free coordinates, or free them")
        point = rd.vector(pd["point"], f"{entry}.point") if "point" in pd else node.position
        label = rd.label(pd.get("label", f"{PRESCRIBED}:{i}"), f"{entry}.label")
        tf = refs.time_function(pd, entry)
        try:
            domain.add_joint(PRESCRIBED, node, None, point, axis=direction, time_function=tf, label=label)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None


def read_springs(rd: Reader, deck: dict, domain: Domain, refs) -> None:
    """``[[springs]]``: force elements (:mod:`reference.forces`)."""
    for i, sp in enumerate(rd.items(deck, "springs")):
        entry = f"springs[{i}]"
        if not isinstance(sp, dict) or "kind" not in sp:
            raise rd.fail(entry, "missing required key 'kind'", f"one of: {', '.join(SPRING_KINDS)}")
        kind = rd.choice(sp["kind"], f"{entry}.kind", SPRING_KINDS, "spring kind")
        required, optional = SPRING_KEYS[kind]
        rd.keys(sp, entry, required=["kind"] + required, optional=["label"] + optional)
        label = rd.string(sp.get("label", f"{kind}:{i}"), f"{entry}.label")
        body_i = refs.node(sp["body_i"], f"{entry}.body_i")
        body_j = None if sp.get("body_j", "ground") == "ground" else refs.node(sp["body_j"], f"{entry}.body_j")
        if body_j is body_i:
            raise rd.fail(entry, "body_i and body_j are the same body", "connect two bodies, or a body and \"ground\"")
        if kind == "bushing":
            stiffness = rd.vector(sp["stiffness"], f"{entry}.stiffness", 6)
            damping = rd.vector(sp.get("damping", [0.0] * 6), f"{entry}.damping", 6)
            for name, values in (("stiffness", stiffness), ("damping", damping)):
                if np.any(values < 0.0):
                    raise rd.fail(f"{entry}.{name}", f"must not be negative, got {values.tolist()}",
                                  "give six values ≥ 0 (three translational, three rotational)")
        else:
            stiffness = rd.number(sp["stiffness"], f"{entry}.stiffness", nonnegative=True)
            damping = rd.number(sp.get("damping", 0.0), f"{entry}.damping", nonnegative=True)
        try:
            if kind == "point_to_point":
                rest = sp.get("rest_length")
                element = PointToPoint(
                    body_i, rd.vector(sp["point_i"], f"{entry}.point_i"), body_j,
                    rd.vector(sp.get("point_j", [0.0, 0.0, 0.0]), f"{entry}.point_j"), stiffness=stiffness,
                    damping=damping,
                    rest_length=None if rest is None else rd.number(rest, f"{entry}.rest_length", positive=True),
                    force_function=refs.time_function(sp, entry), label=label)
            elif kind == "rotational":
                element = Rotational(
                    body_i, body_j, axis=rd.vector(sp.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis"),
                    stiffness=stiffness, damping=damping,
                    rest_angle=rd.number(sp.get("rest_angle", 0.0), f"{entry}.rest_angle"),
                    reference=rd.vector(sp["reference"], f"{entry}.reference") if "reference" in sp else None,
                    label=label)
            else:
                element = Bushing(
                    body_i, body_j, point=rd.vector(sp["point"], f"{entry}.point"),
                    axis=rd.vector(sp.get("axis", [0.0, 0.0, 1.0]), f"{entry}.axis"),
                    reference=rd.vector(sp["reference"], f"{entry}.reference") if "reference" in sp else None,
                    stiffness=stiffness, damping=damping, label=label)
        except ValueError as exc:
            raise rd.fail(entry, str(exc)) from None
        domain.add_force_element(element)
