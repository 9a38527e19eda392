"""The sensitivities of a deck's run (issue 40): the models its parameters make, and the runs.

The parameters by name: :mod:`reference.io.deck_parameters`.  :func:`parameter_kinds` tells how each is
differentiated (:mod:`reference.sensitivity.derivatives`): a section stiffness by the generated ``∂S/∂c``, a
load's scale by its own vector, a mass by the masses' change, a spring's stiffness or a time function's value by
the model with the parameter moved by Δ (exact where the residual is affine in it).
:func:`static_sensitivities` and :func:`eigen_sensitivities` read a deck and run
:mod:`reference.sensitivity.static` and :mod:`reference.sensitivity.eigen` on it.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np

from reference.interactions import NodalLoad
from reference.io.deck import load_deck
from reference.io.deck_parameters import ParameterError, check_algorithm, parse_outputs, resolve_all
from reference.io.deck_reader import DeckError, read_toml
from reference.plain.newton import relative_rotation
from reference.sensitivity.derivatives import LoadScale, Mass, Moved, Spring, Stiffness
from reference.sensitivity.dynamic import run_dynamic
from reference.sensitivity.eigen import run_buckling, run_modes
from reference.sensitivity.static import STATIC, StaticSensitivities, run_static

def model_at(parameter, path, overrides: dict, value: float):
    """The assembled Model (:meth:`reference.domain.Domain.initialization`) of the deck at ``path`` with
    ``overrides`` and ``parameter`` (:class:`reference.io.deck_parameters.Parameter`) set to ``value``."""
    if parameter.override:
        return load_deck(path, overrides={**overrides, parameter.override: float(value)}).domain.initialization()
    domain = load_deck(path, overrides=overrides).domain
    if parameter.body:
        body = domain.node(parameter.body)
        body.inertia = body.inertia * float(value)
        return domain.initialization()
    loads = [i for i in domain.loading if isinstance(i, NodalLoad)]
    loads[parameter.load].vector = loads[parameter.load].vector * float(value)
    return domain.initialization()


def static_sensitivities(path, parameters, outputs, overrides: dict | None = None) -> StaticSensitivities:
    """Solve the static deck at ``path`` on the reference path and differentiate every load level
    (:func:`reference.sensitivity.static.run_static`).

    Parameters
    ----------
    path : path-like
        A deck with ``algorithm = "static"``.
    parameters : list of str
        Parameter names (:mod:`reference.io.deck_parameters`).
    outputs : list of str
        Kinematic observables (docs/observables.md; :data:`reference.io.deck_parameters.KINEMATIC`).
    overrides : dict, optional
        As :func:`reference.io.deck.load_deck`'s.

    Raises
    ------
    ParameterError, ObservableError
        One line: an unknown or non-differentiable parameter, an output without a sensitivity, another algorithm.
    """
    domain, params, kinds = parameter_kinds(path, parameters, overrides, STATIC)
    return run_static(domain, [p.name for p in params], kinds, parse_outputs(outputs, domain))


def dynamic_sensitivities(path, parameters, outputs, overrides: dict | None = None):
    """Solve the generalized-α deck at ``path`` on the reference path with the tangent-linear sensitivities
    (:mod:`reference.sensitivity.dynamic`): ``(t (n,), {output: {parameter: (n, …)}})`` at its outputs."""
    domain, params, kinds = parameter_kinds(path, parameters, overrides, ("generalized_alpha",))
    try:
        return run_dynamic(domain, [p.name for p in params], kinds, parse_outputs(outputs, domain))
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def eigen_sensitivities(path, parameters, overrides: dict | None = None):
    """The eigenvalues of the modes or buckling deck at ``path`` and their derivatives
    (:mod:`reference.sensitivity.eigen`): ``(ω [rad/s] (n,), dω/dp (P, n))`` for modes about the reference state,
    ``(μ (n,), dμ/dp (P, n))`` for the buckling load factors."""
    domain, params, (moved, _), steps = _setup(path, parameters, overrides, ("modes", "buckling"))
    try:
        if domain.solver.algorithm == "modes":
            return run_modes(domain, moved, steps, [p.name for p in params])
        return run_buckling(domain, moved, steps)
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def _refuse(params, algorithm: str) -> None:
    """Refuse, before any model is built, a parameter ``algorithm`` has no sensitivity for
    (:func:`reference.io.deck_parameters.check_algorithm`)."""
    for p in params:
        check_algorithm(p, algorithm)


def _toml(value) -> str:
    """The TOML text of a deck value (a number, string, boolean, array or table, inline)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # JSON's escapes are TOML's basic-string escapes
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml(v)}" for k, v in value.items()) + "}"


def geometry_domain(parameter, path, overrides: dict, value: float):
    """The Domain of the deck at ``path`` (with ``overrides``) with the node coordinate ``parameter``
    (:attr:`reference.io.deck_parameters.Parameter.geometry`) set to ``value`` [m]: the deck's TOML with the
    coordinate changed, written to a temporary file and read again, so that the mesh, the frames and the rest state
    are rebuilt as the deck reader builds them."""
    _, deck = read_toml(Path(path))
    table, k, key, c = parameter.geometry
    deck[table][k][key][c] = float(value)
    with tempfile.TemporaryDirectory() as folder:
        moved = Path(folder) / Path(path).name
        moved.write_text("\n".join(f"{json.dumps(name)} = {_toml(v)}" for name, v in deck.items()) + "\n",
                         encoding="utf-8")
        try:
            return load_deck(moved, overrides=overrides).domain
        except DeckError as exc:
            problem = str(exc).split(": ", 1)[-1]
            raise ParameterError(f"parameter {parameter.name!r}: the deck with it at {value:.6g} is refused "
                                 f"({problem}); name a coordinate the deck stays valid around") from None


def geometry_kind(parameter, path, overrides: dict, domain) -> Moved:
    """A node coordinate's :class:`~reference.sensitivity.derivatives.Moved`: the models rebuilt at ``X ± Δ``
    (``Δ = 1e-4`` of the model's extent: truncation 1e-8 relative) and the derivative of the coordinates the run
    holds fixed (a clamp's position and frame move with the geometry), ``[dx | dθ]`` (N,6) by the same central
    difference (body-frame rotations, zero on the free coordinates)."""
    start = domain.initial_conditions()
    step = 1e-4 * max(float(np.ptp(start.x)), abs(parameter.value), 1e-300)
    plus, minus = (geometry_domain(parameter, path, overrides, parameter.value + s) for s in (step, -step))
    ends = [d.initial_conditions() for d in (plus, minus)]
    if any(e.x.shape != start.x.shape for e in ends):
        raise ParameterError(f"parameter {parameter.name!r}: moving the node changes the number of nodes; name a "
                             "coordinate that moves nodes without re-meshing")
    fixed = np.hstack([ends[0].x - ends[1].x, relative_rotation(start.q, ends[0].q) -
                       relative_rotation(start.q, ends[1].q)]) / (2.0 * step)
    model = plus.initialization()
    fixed[model.nodes.free > 0.5] = 0.0
    return Moved(model, step, minus.initialization(), fixed)


STIFFNESS = ("EA", "GA2", "GA3", "GJ", "EI2", "EI3")
"""The section entries differentiated by the generated ``∂S/∂c`` (derivations/sensitivities.py), in its column
order."""
MASSES = ("rhoA", "rhoJ1", "rhoJ2", "rhoJ3")
"""The section entries the lumped masses are affine in (:class:`reference.sensitivity.derivatives.Mass`)."""


def _section_members(deck: dict, domain, section: str) -> np.ndarray:
    """(E,) bool over the Domain's elements: those of the deck's (TOML dict) beams whose ``section`` is
    ``section`` (an element of beam ``B`` is labelled ``B/i``, :meth:`reference.domain.Domain.add_beam`)."""
    beams = {b.get("label") for b in deck.get("beams", []) if b.get("section") == section}
    return np.array([e.label.rsplit("/", 1)[0] in beams for e in domain.elements], dtype=bool)


def _prepared(path, parameters, overrides: dict, algorithms):
    """The deck's Domain and its resolved parameters, for a run of one of ``algorithms`` only (one-line
    ParameterError otherwise, and for a parameter that algorithm cannot differentiate)."""
    domain = load_deck(path, overrides=overrides).domain
    if domain.solver.algorithm not in algorithms:
        raise ParameterError(f"sensitivities of a {domain.solver.algorithm!r} run are not built here; "
                             f"use algorithm = {' or '.join(map(repr, algorithms))}")
    params = resolve_all(path, parameters, overrides)
    _refuse(params, domain.solver.algorithm)
    return domain, params


def _step(p) -> float:
    """The step Δ a parameter is moved by: ``max(|p|, 1)`` where the residual is affine in it (the difference is
    exact), ``1e-4 |p|`` for a central difference (truncation 1e-8 relative)."""
    return max(abs(p.value), 1.0) if p.affine else 1e-4 * max(abs(p.value), 1e-300)


def parameter_kinds(path, parameters, overrides, algorithms):
    """The deck's Domain, the resolved parameters and how each is differentiated
    (:class:`reference.sensitivity.derivatives.ParameterDerivatives`' kinds), for ``algorithms`` only.  A mass
    parameter's ``∂m/∂p``, ``∂J/∂p`` are the change of the assembled lumped masses over Δ = max(|p|, 1)
    (exact: affine); a :class:`~reference.sensitivity.derivatives.Moved` one carries its moved models (as
    :func:`_setup`)."""
    overrides = dict(overrides or {})
    domain, params = _prepared(path, parameters, overrides, algorithms)
    base, deck, kinds = None, read_toml(Path(path))[1], []
    for p in params:
        parts = p.override.split(".")
        step = _step(p)
        if p.geometry:
            kinds.append(geometry_kind(p, path, overrides, domain))
        elif parts[0] == "sections" and parts[2] in STIFFNESS:
            kinds.append(Stiffness(_section_members(deck, domain, parts[1]), STIFFNESS.index(parts[2])))
        elif p.load >= 0:
            kinds.append(LoadScale(p.load))
        elif (parts[0] == "sections" and parts[2] in MASSES) or (parts[0] == "rigid_bodies" and parts[-1] == "mass") \
                or p.body:
            base = model_at(p, path, overrides, p.value) if base is None else base
            moved = model_at(p, path, overrides, p.value + step).nodes
            kinds.append(Mass((moved.mass - base.nodes.mass) / step, (moved.inertia - base.nodes.inertia) / step))
        else:
            kinds.append(_moved_kind(p, path, overrides, step))
    return domain, params, kinds


def _moved_kind(p, path, overrides: dict, step: float):
    """A parameter the model moved by Δ tells: a spring's stiffness (the one force element whose stiffnesses
    change: :class:`~reference.sensitivity.derivatives.Spring`, ``∂k/∂p`` exact by affinity), else
    :class:`~reference.sensitivity.derivatives.Moved` (by −Δ too for a parameter the residual is not affine in)."""
    moved = model_at(p, path, overrides, p.value + step)
    if p.override.startswith("springs."):
        k0, k1 = model_at(p, path, overrides, p.value).force_elements.k, moved.force_elements.k
        rows = np.flatnonzero(np.any(k1 != k0, axis=1))
        if rows.size == 1:
            return Spring(int(rows[0]), (k1[rows[0]] - k0[rows[0]]) / step)
    return Moved(moved, step, None if p.affine else model_at(p, path, overrides, p.value - step))


def _setup(path, parameters, overrides, algorithms):
    """The deck's Domain, the resolved parameters, their models moved by +Δ and by −Δ (None for a parameter the
    residual is affine in: :class:`reference.sensitivity.derivatives.ResidualDerivatives`) and the steps Δ, for
    ``algorithms`` only."""
    overrides = dict(overrides or {})
    domain, params = _prepared(path, parameters, overrides, algorithms)
    steps = [_step(p) for p in params]
    moved = [model_at(p, path, overrides, p.value + d) for p, d in zip(params, steps)]
    minus = [None if p.affine else model_at(p, path, overrides, p.value - d) for p, d in zip(params, steps)]
    return domain, params, (moved, minus), steps


def sensitivity_datasets(path, sensitivities: dict, overrides: dict | None = None) -> dict:
    """The results file's datasets of a deck's ``[sensitivities]`` table (docs/results.md): for a static run
    ``sensitivities/<output>/<parameter>`` (one value per load step, the observable's shape after it) and
    ``sensitivities/load_factor``; for generalized-α the same per output time, with ``sensitivities/time``; for
    modes ``sensitivities/frequency/<parameter>`` (dω/dp / 2π [Hz per unit of p]); for buckling ``sensitivities/load_factor/<parameter>`` (dμ/dp).  ``/`` in a name (an output
    ``deflection:…``) is written as ``|``, an HDF5 path separator otherwise."""
    names, outputs = sensitivities["parameters"], sensitivities.get("outputs", [])
    key = lambda text: text.replace("/", "|")  # noqa: E731
    domain = load_deck(path, overrides=overrides).domain
    if domain.solver.algorithm in STATIC or domain.solver.algorithm == "generalized_alpha":
        if domain.solver.algorithm in STATIC:
            result = static_sensitivities(path, names, outputs, overrides)
            t, histories, axis = result.t, result.outputs, "load_factor"
        else:
            (t, histories), axis = dynamic_sensitivities(path, names, outputs, overrides), "time"
        out = {f"sensitivities/{axis}": np.asarray(t)}
        for text, by_name in histories.items():
            out.update({f"sensitivities/{key(text)}/{key(n)}": np.asarray(v) for n, v in by_name.items()})
        return out
    values, d = eigen_sensitivities(path, names, overrides)
    if domain.solver.algorithm == "modes":
        return {f"sensitivities/frequency/{key(n)}": d[i] / (2.0 * np.pi) for i, n in enumerate(names)}
    return {f"sensitivities/load_factor/{key(n)}": d[i] for i, n in enumerate(names)}
