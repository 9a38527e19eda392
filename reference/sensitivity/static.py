"""Static sensitivities by direct differentiation: ``K dx/dp = −∂R/∂p`` at every converged load step.

At an equilibrium of the static problem (:mod:`reference.plain.static`) ::

    r(x, λ; p) = S − F + Bᵀλ = 0,        Φ(x; p) − ε λ = 0,

differentiating along p with the increments of the Newton update (inertial ``dx``, body-frame ``dθ``:
``q(p + dp) = q(p) ⊗ exp(dθ dp)``) gives the Newton matrix itself ::

    [ K   Bᵀ ] [ dx/dp ]     [ ∂r/∂p ]
    [ B  −ε  ] [ dλ/dp ] = − [ ∂Φ/∂p ]

(K the tangent with the constraints' geometric stiffness, :meth:`reference.plain.newton.Newton.matrix`).
It is factorised once per load step at the converged state and back-substituted once per parameter;
∂r/∂p and ∂Φ/∂p are exact (:class:`reference.sensitivity.derivatives.ParameterDerivatives`).  The
sensitivity of a rotation is the body-frame ``dθ/dp`` [rad per unit of p].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

from reference.observables import _Names
from reference.plain.backend import twin
from reference.sensitivity.derivatives import ParameterDerivatives, output_derivatives
from reference.status import OK

STATIC = ("static",)
"""The algorithms whose runs :func:`run_static` differentiates."""


@dataclass
class StaticSensitivities:
    """The sensitivities of a static run, one entry per recorded load level.

    Attributes
    ----------
    t : list of float
        The load levels (the deck's time).
    state : list of ndarray (P, N, 6)
        Per level, per parameter, ``[dx/dp | dθ/dp]`` per node.
    outputs : dict
        ``outputs[text][name]``: the list over levels of ``d(observable)/dp`` (shape of the observable at one time).
    x, q : list of ndarray
        The converged configurations.
    """

    t: list = field(default_factory=list)
    state: list = field(default_factory=list)
    outputs: dict = field(default_factory=dict)
    x: list = field(default_factory=list)
    q: list = field(default_factory=list)


class KeptMatrix:
    """The static run's engine face (:class:`reference.plain.newton.EngineFace`), keeping the last Newton matrix it
    assembles with the configuration and time it was assembled at: the run's stability check assembles the
    tangent at every equilibrium it reaches (:func:`reference.algorithms.static.reduced_tangent`), the matrix
    :func:`solve_static` factorises there, so it is not assembled twice."""

    def __init__(self, face):
        self._face, self.kept = face, None

    def matrix(self, x, q, w, t, lam, cm, cc, ck, ce=None, psi=None):
        A = self._face.matrix(x, q, w, t, lam, cm, cc, ck, ce, psi)
        self.kept = (x.copy(), q.copy(), lam.copy(), t, (cm, cc, ck, psi is None), ce, A)
        return A

    def __getattr__(self, name):
        return getattr(self._face, name)

    def static_matrix(self, nw, x, q, lam, t):
        """The static Newton matrix ``[K, Bᵀ; B, −ε]`` at ``(x, q, λ, t)`` if the kept one is the tangent there
        (its ``−c_e ε`` block replaced by ``−ε``), else None."""
        if self.kept is None:
            return None
        x0, q0, lam0, t0, coefficients, ce, A = self.kept
        if (coefficients != (0.0, 0.0, 1.0, True) or t0 != t or not np.array_equal(x0, x) or not np.array_equal(q0, q)
                or not np.array_equal(lam0, lam)):
            return None
        if nw.m == 0:
            return A
        fix = sps.diags(np.concatenate([np.zeros(nw.n_free), ((0.0 if ce is None else ce) - 1.0) * nw.eps]))
        return (A + fix).tocsc()


def solve_static(nw, derivatives, x, q, lam, t, kept: KeptMatrix | None = None) -> np.ndarray:
    """``[dx/dp | dθ/dp]`` (P, N, 6) at the equilibrium ``(x, q, λ)`` at load level t (module docstring): one
    factorisation of the Newton matrix (``kept``'s where it holds the tangent at this equilibrium) and one
    back-substitution per parameter.  A parameter that moves the coordinates the run holds fixed (a node's
    coordinate: ``fixed`` of its kind) adds their share ``K_fc d_c``, ``B_c d_c`` to its right-hand side (K, B over
    every coordinate) and keeps ``d_c`` as their sensitivity."""
    zero = np.zeros_like(x)
    rhs = derivatives(x, q, zero, zero, np.zeros((x.shape[0], 6)), lam, t, False)  # evaluates nw here: its B
    fixed = [getattr(kind, "fixed", None) for kind in getattr(derivatives, "kinds", [None] * len(rhs))]
    if any(f is not None for f in fixed):
        K = nw.ev.tangent(x, q, zero, zero, t, lam, nw.angle)
        rhs = [(dr, dphi) if f is None else (dr + (K @ f.ravel()).reshape(f.shape), dphi + nw.last.B @ f.ravel())
               for (dr, dphi), f in zip(rhs, fixed)]
    A = None if kept is None else kept.static_matrix(nw, x, q, lam, t)
    lu = nw.factor(nw.matrix(x, q, zero, zero, t, lam, (0.0, 0.0, 1.0, 1.0)) if A is None else A)
    if lu is None:
        raise ValueError(f"the tangent is singular at load level {t:.6g}: no sensitivity at a critical point")
    out = np.empty((len(rhs), x.shape[0], 6))
    for k, (dr, dphi) in enumerate(rhs):
        solved = nw.solve(lu, -dr, -dphi)
        out[k] = solved[0] if solved is not None else np.nan
        if fixed[k] is not None:
            out[k] += fixed[k]
    return out


def run_static(domain, names, kinds, observables) -> StaticSensitivities:
    """Solve the static problem of ``domain`` on the reference path and differentiate every load level.

    Parameters
    ----------
    domain : Domain
        Ready to solve, ``algorithm = "static"``.
    names : list of str
        The parameters' names.
    kinds : list
        Per parameter, how it is differentiated (:class:`reference.sensitivity.derivatives.ParameterDerivatives`).
    observables : list of Observable
        :func:`reference.sensitivity.derivatives.parse_outputs`'s.
    """
    model = domain.initialization()
    state = domain.initial_conditions()
    algo = twin(domain.algorithm())
    run = algo.start(model, state)
    run.system = kept = KeptMatrix(run.system)
    derivatives = ParameterDerivatives(run.newton, kinds)
    result = StaticSensitivities(outputs={o.text: {p: [] for p in names} for o in observables})
    for level in range(algo.n_steps(domain.solver.t_end) + 1):
        code = algo.advance(model, state, run, 0 if level == 0 else 1, None)
        if code != OK:
            raise ValueError(f"the static run stopped at load level {state.t:.6g}: no sensitivity beyond")
        d = solve_static(run.newton, derivatives, state.x, state.q, run.lam, state.t, kept)
        _store(result, observables, _Names(domain), names, state, d, run.L)
    return result


def _store(result, observables, labels, names, state, d, length) -> None:
    """Append one level's state sensitivities and the outputs' derivatives to ``result``."""
    result.t.append(state.t)
    result.state.append(d)
    result.x.append(state.x.copy())
    result.q.append(state.q.copy())
    for obs in observables:
        for name, value in zip(names, output_derivatives(obs, labels, state.x, state.q, d, length)):
            result.outputs[obs.text][name].append(value)
