"""Design parameters by name, as the parameter studies name deck values (issue 40), and the deck's
``[sensitivities]`` table.

A parameter is named in the vocabulary of ``flexmbs sweep`` (docs/deck.md, "Overrides"):

- ``sections.NAME.KEY`` — any entry of a section (``EA``, ``GA2``, ``GA3``, ``GJ``, ``EI2``, ``EI3``,
  ``rhoA``, ``rhoJ1``, ``rhoJ2``, ``rhoJ3``);
- ``loads[i].force``, ``loads[i].moment`` — the scale ``s`` of the i-th ``[[loads]]`` entry
  (its vector times ``s``, nominal ``s = 1``);
- ``rigid_bodies.NAME.mass`` — the mass of a rigid body [kg];
- ``rigid_bodies.NAME.inertia`` — the scale ``s`` of a rigid body's inertia tensor (the deck's times ``s``,
  nominal 1);
- ``springs[i].stiffness`` — the stiffness of a force element with one stiffness;
- ``time_functions.NAME.v0``, ``.v1`` — the end values of a ramp or smooth step (a drive's speed, a load's level);
- ``nodes.NAME.position.x`` (``.y``, ``.z``) — a coordinate [m] of a ``[[nodes]]`` node or of a beam's end given
  by coordinates (``BEAM:start``, ``BEAM:end``): geometry, static runs only.

All but the last two enter the equations of motion affinely (:mod:`reference.sensitivity.derivatives`).  A
node's position enters through the rest state the deck builds from it (the elements' lengths L0, reference
strains γ0, κ0 and frames, the re-meshed beams), non-linearly: its ∂R/∂X is a central difference of the
residual at the fixed state between the decks rebuilt with the coordinate moved (docs/formulation.md §14).  A
mesh size is not a continuous parameter and is refused, as are a whole position (name a component) and a rigid
body's geometry.  This module reads names only (no model is built): the deck reader checks the
``[sensitivities]`` table with it, :mod:`reference.io.deck_sensitivities` runs them.
"""

from __future__ import annotations

import copy
import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from reference.io.deck_reader import Reader, override_value, read_toml
from reference.observables import ObservableError, parse

DIFFERENTIATED = ("static", "modes", "buckling", "generalized_alpha")
"""The algorithms whose runs have sensitivities."""

AFFINE_TIME_FUNCTIONS = ("ramp", "smooth_step")
"""Time-function kinds whose values are affine in their end values ``v0``, ``v1`` (a drive's speed or a load's
level): ``time_functions.NAME.v0``/``.v1`` of these are parameters."""

KINEMATIC = ("position", "positions", "rotation", "distance", "deflection")
"""Observable kinds with a sensitivity: functions of the nodes' configuration alone."""


class ParameterError(ValueError):
    """A parameter that is not in the deck or cannot be differentiated, or a run without sensitivities
    (one line, ``problem; fix``)."""


GEOMETRY = re.compile(r"^(beams\.[^.]+\.(start|end|elements)|rigid_bodies\.[^.]+\.(position|points|rotation)|refine)$")
"""Names of deck values that are geometry or mesh: not differentiable here (module docstring)."""
COMPONENTS = ("x", "y", "z")
"""The components of a node's position parameter, ``nodes.NAME.position.x`` …"""


@dataclass(frozen=True)
class Parameter:
    """One resolved parameter.

    Attributes
    ----------
    name : str
        As written (``sections.rollup.EI2``).
    override : str
        The deck reader's dotted override of its value ("" for a load scale).
    load : int
        The index of the ``[[loads]]`` entry whose scale it is (−1 for an override).

    Its model at another value: :func:`reference.io.deck_sensitivities.model_at`.
    value : float
        Its nominal value (1 for a load scale).
    affine : bool
        Whether the residual is affine in it (all but a time function's end value, which a drive's rotation
        takes non-linearly, and a node's coordinate).
    geometry : tuple
        For a node's coordinate, where the deck (its TOML dict) gives it: ``("nodes", k, "position", c)`` or
        ``("beams", k, "start" | "end", c)``; () otherwise.
    body : str
        For a rigid body's inertia scale, the body's label; "" otherwise.
    """

    name: str
    override: str
    load: int
    value: float
    affine: bool = True
    geometry: tuple = ()
    body: str = ""


def candidates(deck: dict) -> list[str]:
    """Every parameter name a deck (its TOML dict) offers, for the "did you mean" of a misspelt one."""
    names = [f"sections.{s}.{k}" for s, table in deck.get("sections", {}).items() if isinstance(table, dict)
             for k, v in table.items() if isinstance(v, (int, float))]
    for i, ld in enumerate(deck.get("loads", [])):
        names += [f"loads[{i}].{k}" for k in ("force", "moment") if k in ld]
    names += [f"rigid_bodies.{rb.get('label')}.{k}" for rb in deck.get("rigid_bodies", []) for k in ("mass", "inertia")]
    names += [f"time_functions.{n}.{k}" for n, tf in deck.get("time_functions", {}).items()
              if isinstance(tf, dict) and tf.get("kind") in AFFINE_TIME_FUNCTIONS for k in ("v0", "v1")]
    names += [f"springs[{i}].stiffness" for i, sp in enumerate(deck.get("springs", [])) if "stiffness" in sp]
    names += [f"nodes.{label}.position.{c}" for label in _positions(deck) for c in COMPONENTS]
    return names


def _positions(deck: dict) -> dict:
    """The node positions a deck (its TOML dict) gives by coordinates: label → ``(table, k, key)``, for the
    ``[[nodes]]`` entries and the beams' ends given as ``start``/``end`` (``BEAM:start``, ``BEAM:end``)."""
    out = {nd.get("label"): ("nodes", k, "position") for k, nd in enumerate(deck.get("nodes", []))
           if isinstance(nd, dict) and isinstance(nd.get("position"), list)}
    for k, bm in enumerate(deck.get("beams", [])):
        if isinstance(bm, dict):
            out.update({f"{bm.get('label')}:{side}": ("beams", k, side) for side in ("start", "end")
                        if isinstance(bm.get(side), list)})
    return out


def _node_position(name: str, deck: dict) -> Parameter | None:
    """A ``nodes.NAME.position…`` parameter; None for another name.

    Raises
    ------
    ParameterError
        A whole position (name a component), or a node whose position the deck does not give by coordinates.
    """
    m = re.fullmatch(r"nodes\.(.+)\.position(?:\.([^.]+))?", name)
    if not m:
        return None
    where = _positions(deck).get(m[1])
    if where is None:
        raise ParameterError(f"parameter {name!r}: node {m[1]!r} has no position of its own in the deck (a mesh "
                             "node or a rigid body's is geometry or mesh, not differentiated); name a [[nodes]] "
                             "label or a beam's end given by coordinates (BEAM:start, BEAM:end)")
    if m[2] not in COMPONENTS:
        raise ParameterError(f"parameter {name!r} is a whole position; name one component, e.g. "
                             f"'nodes.{m[1]}.position.x'")
    table, k, key = where
    c = COMPONENTS.index(m[2])
    return Parameter(name, "", -1, float(deck[table][k][key][c]), affine=False, geometry=(table, k, key, c))


def _unknown(name: str, deck: dict) -> ParameterError:
    close = difflib.get_close_matches(name, candidates(deck), n=1, cutoff=0.6)
    fix = f"did you mean '{close[0]}'?" if close else \
        "name a section entry, a load's force or moment, a rigid body's mass or a spring's stiffness " \
        "(e.g. sections.NAME.EI2, loads[0].force)"
    return ParameterError(f"unknown parameter {name!r}; {fix}")


def resolve(name, deck: dict) -> Parameter:
    """The :class:`Parameter` named ``name`` in the deck ``deck`` (its TOML dict, after overrides).

    Raises
    ------
    ParameterError
        An unknown name (with the closest known one), a geometry or mesh value, or a value that is not a
        single number.
    """
    if not isinstance(name, str) or not name:
        raise ParameterError(f"expected a parameter name such as 'sections.NAME.EI2', got {name!r}")
    position = _node_position(name, deck)
    if position is not None:
        return position
    if GEOMETRY.match(name):
        raise ParameterError(f"parameter {name!r} is geometry or mesh, which the sensitivities do not differentiate "
                             "(a mesh size is not continuous); name a stiffness, a mass, a load's scale, a "
                             "spring's stiffness or a node's coordinate (nodes.NAME.position.x)")
    m = re.fullmatch(r"sections\.([^.]+)\.([^.]+)", name)
    if m and isinstance(deck.get("sections", {}).get(m[1]), dict) and isinstance(deck["sections"][m[1]].get(m[2]),
                                                                                    (int, float)):
        return Parameter(name, name, -1, float(deck["sections"][m[1]][m[2]]))
    m = re.fullmatch(r"loads\[(\d+)\]\.(force|moment)", name)
    if m and int(m[1]) < len(deck.get("loads", [])) and m[2] in deck["loads"][int(m[1])]:
        return Parameter(name, "", int(m[1]), 1.0)
    m = re.fullmatch(r"time_functions\.([^.]+)\.(v0|v1)", name)
    tf = deck.get("time_functions", {}).get(m[1]) if m else None
    if isinstance(tf, dict) and tf.get("kind") in AFFINE_TIME_FUNCTIONS:
        return Parameter(name, name, -1, float(tf.get(m[2], 0.0 if m[2] == "v0" else 1.0)), affine=False)
    m = re.fullmatch(r"rigid_bodies\.([^.]+)\.(mass|inertia)", name)
    labels = [rb.get("label") for rb in deck.get("rigid_bodies", [])]
    if m and m[1] in labels and m[2] == "inertia":
        return Parameter(name, "", -1, 1.0, body=m[1])
    if m and m[1] in labels:
        k = labels.index(m[1])
        return Parameter(name, f"rigid_bodies.{k}.mass", -1, float(deck["rigid_bodies"][k]["mass"]))
    m = re.fullmatch(r"springs\[(\d+)\]\.stiffness", name)
    if m and int(m[1]) < len(deck.get("springs", [])) and "stiffness" in deck["springs"][int(m[1])]:
        k = deck["springs"][int(m[1])]["stiffness"]
        if not isinstance(k, (int, float)):
            raise ParameterError(f"parameter {name!r} is a vector of stiffnesses; only a spring with one stiffness "
                                 "is a parameter here")
        return Parameter(name, f"springs.{m[1]}.stiffness", -1, float(k))
    raise _unknown(name, deck)


def check_algorithm(p: Parameter, algorithm: str) -> None:
    """Refuse a parameter ``algorithm`` has no sensitivity for: a node's coordinate outside static runs (in a
    dynamic run the initial state moves with it; the modes and buckling loads are not built for it), a time
    function's end value outside generalized-α runs.

    Raises
    ------
    ParameterError
        One line, ``problem; fix``.
    """
    if p.geometry and algorithm != "static":
        raise ParameterError(f"parameter {p.name!r} (a node's coordinate) has sensitivities in static runs only, "
                             f"not {algorithm!r}; name a stiffness, mass or load scale")
    if not p.affine and not p.geometry and algorithm != "generalized_alpha":
        raise ParameterError(f"parameter {p.name!r} (a time function's end value) has sensitivities in "
                             f"generalized-α runs only, not {algorithm!r}; name a stiffness, mass or load scale")


def resolve_all(path, names, overrides: dict | None = None) -> list[Parameter]:
    """:func:`resolve` every name of ``names`` against the deck at ``path`` (with its dotted ``overrides``
    applied as the deck reader applies them, so that a parameter's nominal value is the value the run uses);
    a repeated name is refused."""
    _, deck = read_toml(Path(path))
    deck = copy.deepcopy(deck)
    for key, value in (overrides or {}).items():
        if "." in key:
            override_value(deck, key, value, Reader(Path(path)))
    seen = set()
    out = []
    for name in names:
        if name in seen:
            raise ParameterError(f"parameter {name!r} is named twice; name each parameter once")
        seen.add(name)
        out.append(resolve(name, deck))
    return out


def parse_outputs(texts, domain) -> list:
    """The observables ``texts`` parsed against ``domain``; one whose value is not a function of the
    configuration alone (a velocity, a reaction, an energy, an angle since t = 0) is refused (ObservableError)."""
    out = []
    for text in texts:
        obs = parse(text, domain)
        if obs.kind not in KINEMATIC:
            raise ObservableError(f"output {text!r}: the sensitivities give kinematic outputs only; name a position, "
                                  "rotation, distance or deflection (midspan_deflection) of nodes")
        out.append(obs)
    return out


def read_sensitivities(rd: Reader, deck: dict, domain, algorithm: str) -> dict:
    """``[sensitivities]``: ``parameters`` (names, :func:`resolve`) and ``outputs`` (kinematic observables,
    :func:`parse_outputs`), checked against the deck (its TOML dict after overrides) and ``domain``; {} without
    the table.  The algorithm must be one of :data:`DIFFERENTIATED` (the explicit one is refused)."""
    table = deck.get("sensitivities")
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise rd.fail("sensitivities", "expected a table", "write [sensitivities] with parameters = [...]")
    rd.keys(table, "sensitivities", required=["parameters"], optional=["outputs"])
    if algorithm not in DIFFERENTIATED:
        raise rd.fail("sensitivities", f"sensitivities of algorithm {algorithm!r} are not built",
                      f"use algorithm = {', '.join(map(repr, DIFFERENTIATED))}, or drop [sensitivities]")
    out = {}
    for key in ("parameters", "outputs"):
        values = table.get(key, [])
        if not isinstance(values, list) or not all(isinstance(v, str) for v in values):
            raise rd.fail(f"sensitivities.{key}", f"expected an array of strings, got {values!r}")
        out[key] = list(values)
    if not out["parameters"]:
        raise rd.fail("sensitivities.parameters", "no parameter named", "name one, e.g. \"sections.NAME.EI2\"")
    seen = set()
    for i, name in enumerate(out["parameters"]):
        try:
            if name in seen:
                raise ParameterError(f"parameter {name!r} is named twice; name each parameter once")
            seen.add(name)
            check_algorithm(resolve(name, deck), algorithm)
        except ParameterError as exc:
            raise rd.fail(f"sensitivities.parameters[{i}]", *str(exc).split("; ", 1)) from None
    try:
        parse_outputs(out["outputs"], domain)
    except ObservableError as exc:
        raise rd.fail("sensitivities.outputs", *str(exc).split("; ", 1)) from None
    return out
