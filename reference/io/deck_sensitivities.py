"""The deck's side of the sensitivities: parameters by name, the models they make, and the runs.

A parameter is named in the vocabulary of ``flexmbs sweep`` (docs/deck.md, "Overrides"):

- ``sections.NAME.KEY`` — any entry of a section (``EA``, ``GA2``, ``GA3``, ``GJ``, ``EI2``, ``EI3``,
  ``rhoA``, ``rhoJ1``, ``rhoJ2``, ``rhoJ3``);
- ``loads[i].force``, ``loads[i].moment`` — the scale ``s`` of the i-th ``[[loads]]`` entry
  (its vector times ``s``, nominal ``s = 1``);
- ``rigid_bodies.NAME.mass`` — the mass of a rigid body [kg];
- ``springs[i].stiffness`` — the stiffness of a force element with one stiffness.

Every one of them enters the equations of motion affinely: the internal forces of an element are
``Bᵀ C ε`` with the section stiffnesses in C (``derivations/beam2.py``), the lumped masses, the
inertia and gravity are linear in ``rhoA``, ``rhoJ*`` and a body's mass, a load is its vector
times its scale, and a spring's force is its stiffness times its stretch.  So at a fixed state
``R(p + Δ) − R(p) = Δ ∂R/∂p`` holds exactly (up to rounding, for any Δ): :class:`Parameter.model`
gives the generated element, load and force functions a model with the parameter moved by Δ and
the difference of the two evaluations is ∂R/∂p, with no truncation error.  The same holds for the
tangent and the mass matrix (the eigenvalue sensitivities).

Geometry is refused: the reference strains γ0, κ0 and lengths L0 of the elements depend on the
node positions non-linearly (their derivative ∂S/∂X is not derived yet), and a mesh size is not a
continuous parameter.

:func:`static_sensitivities` reads a deck and runs :mod:`reference.sensitivity.static` on it.
"""

from __future__ import annotations

import copy
import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from reference.interactions import NodalLoad
from reference.io.deck import SECTION_KEYS, load_deck
from reference.io.deck_reader import read_toml
from reference.sensitivity.derivatives import ParameterError, parse_outputs
from reference.sensitivity.eigen import run_buckling, run_modes
from reference.sensitivity.static import STATIC, StaticSensitivities, run_static

GEOMETRY = re.compile(r"^(nodes\.[^.]+\.position|beams\.[^.]+\.(start|end|elements)|rigid_bodies\.[^.]+\."
                      r"(position|points|rotation)|refine)$")
"""Names of deck values that are geometry or mesh: not differentiable here (module docstring)."""


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
    value : float
        Its nominal value (1 for a load scale).
    """

    name: str
    override: str
    load: int
    value: float

    def model(self, path, overrides: dict, value: float):
        """The assembled Model (:meth:`reference.domain.Domain.initialization`) of the deck at ``path`` with
        ``overrides`` and this parameter set to ``value``."""
        if self.override:
            return load_deck(path, overrides={**overrides, self.override: float(value)}).domain.initialization()
        domain = load_deck(path, overrides=overrides).domain
        loads = [i for i in domain.loading if isinstance(i, NodalLoad)]
        loads[self.load].vector = loads[self.load].vector * float(value)
        return domain.initialization()


def candidates(deck: dict) -> list[str]:
    """Every parameter name a deck (its TOML dict) offers, for the "did you mean" of a misspelt one."""
    names = [f"sections.{s}.{k}" for s in deck.get("sections", {}) for k in SECTION_KEYS]
    for i, ld in enumerate(deck.get("loads", [])):
        names += [f"loads[{i}].{k}" for k in ("force", "moment") if k in ld]
    names += [f"rigid_bodies.{rb.get('label')}.mass" for rb in deck.get("rigid_bodies", [])]
    names += [f"springs[{i}].stiffness" for i, sp in enumerate(deck.get("springs", [])) if "stiffness" in sp]
    return names


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
    if GEOMETRY.match(name):
        raise ParameterError(f"parameter {name!r} is geometry or mesh, which the sensitivities do not differentiate "
                             "(the elements' reference strains depend on it non-linearly); name a stiffness, "
                             "a mass, a load's scale or a spring's stiffness")
    m = re.fullmatch(r"sections\.([^.]+)\.([^.]+)", name)
    if m and m[1] in deck.get("sections", {}) and m[2] in SECTION_KEYS:
        return Parameter(name, name, -1, float(deck["sections"][m[1]][m[2]]))
    m = re.fullmatch(r"loads\[(\d+)\]\.(force|moment)", name)
    if m and int(m[1]) < len(deck.get("loads", [])) and m[2] in deck["loads"][int(m[1])]:
        return Parameter(name, "", int(m[1]), 1.0)
    m = re.fullmatch(r"rigid_bodies\.([^.]+)\.mass", name)
    labels = [rb.get("label") for rb in deck.get("rigid_bodies", [])]
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


def resolve_all(path, names, overrides: dict | None = None) -> list[Parameter]:
    """:func:`resolve` every name of ``names`` against the deck at ``path`` (with ``overrides`` applied to its
    section values, as the deck reader applies them); a repeated name is refused."""
    _, deck = read_toml(Path(path))
    deck = copy.deepcopy(deck)
    for key, value in (overrides or {}).items():
        parts = key.split(".")
        if parts[0] == "sections" and len(parts) == 3 and parts[1] in deck.get("sections", {}):
            deck["sections"][parts[1]][parts[2]] = value
    seen = set()
    out = []
    for name in names:
        if name in seen:
            raise ParameterError(f"parameter {name!r} is named twice; name each parameter once")
        seen.add(name)
        out.append(resolve(name, deck))
    return out


def static_sensitivities(path, parameters, outputs, overrides: dict | None = None) -> StaticSensitivities:
    """Solve the static deck at ``path`` on the reference path and differentiate every load level
    (:func:`reference.sensitivity.static.run_static`).

    Parameters
    ----------
    path : path-like
        A deck with ``algorithm = "static"``.
    parameters : list of str
        Parameter names (module docstring).
    outputs : list of str
        Kinematic observables (docs/observables.md; :data:`reference.sensitivity.derivatives.KINEMATIC`).
    overrides : dict, optional
        As :func:`reference.io.deck.load_deck`'s.

    Raises
    ------
    ParameterError, ObservableError
        One line: an unknown or non-differentiable parameter, an output without a sensitivity, another algorithm.
    """
    domain, params, moved, steps = _setup(path, parameters, overrides, STATIC)
    return run_static(domain, [p.name for p in params], moved, steps, parse_outputs(outputs, domain))


def eigen_sensitivities(path, parameters, overrides: dict | None = None):
    """The eigenvalues of the modes or buckling deck at ``path`` and their derivatives
    (:mod:`reference.sensitivity.eigen`): ``(ω [rad/s] (n,), dω/dp (P, n))`` for modes about the reference state,
    ``(μ (n,), dμ/dp (P, n))`` for the buckling load factors."""
    domain, _, moved, steps = _setup(path, parameters, overrides, ("modes", "buckling"))
    try:
        if domain.solver.algorithm == "modes":
            return run_modes(domain, moved, steps)
        return run_buckling(domain, moved, steps)
    except ValueError as exc:
        raise ParameterError(str(exc)) from None


def _setup(path, parameters, overrides, algorithms):
    """The deck's Domain, the resolved parameters, their moved models and steps Δ, for ``algorithms`` only."""
    overrides = dict(overrides or {})
    domain = load_deck(path, overrides=overrides).domain
    if domain.solver.algorithm not in algorithms:
        raise ParameterError(f"sensitivities of a {domain.solver.algorithm!r} run are not built here; "
                             f"use algorithm = {' or '.join(map(repr, algorithms))}")
    params = resolve_all(path, parameters, overrides)
    steps = [max(abs(p.value), 1.0) for p in params]
    moved = [p.model(path, overrides, p.value + d) for p, d in zip(params, steps)]
    return domain, params, moved, steps
