"""∂R/∂p and the outputs' derivatives along a state sensitivity, on the reference path.

:class:`ResidualDerivatives` holds, for each parameter, a Newton system
(:class:`reference.plain.newton.Newton`) of the model with the parameter moved by ``Δ``; the residual
being affine in every parameter (:mod:`reference.io.deck_parameters`), ::

    ∂r/∂p = (r(p + Δ) − r(p)) / Δ,      ∂Φ/∂p = (Φ(p + Δ) − Φ(p)) / Δ

at the same state, exactly up to rounding (``Δ = max(|p|, 1)``, so the difference is as large as the
forces themselves and loses no digits).  :func:`output_derivative` carries a state sensitivity
``(dx, dθ)`` (inertial translations, body-frame rotations, as the Newton increments) to an
observable (docs/observables.md).
"""

from __future__ import annotations

import numpy as np

from reference.observables import _Names
from reference.plain.newton import Newton, compose

class ResidualDerivatives:
    """∂r/∂p and ∂Φ/∂p for the parameters of one run (module docstring).

    Parameters
    ----------
    base : Newton
        The run's own Newton system (the model at the nominal parameters).
    moved : list of Model
        Per parameter, the model with the parameter moved by its step
        (:func:`reference.io.deck_sensitivities.model_at`).
    steps : list of float
        Per parameter, that step Δ.
    minus : list of (Model or None), optional
        Per parameter, None (the residual is affine in it: the one-sided difference is exact) or the model with
        the parameter moved by −Δ: a central difference, for a parameter that enters non-linearly (a drive's
        scale, through the drive's rotation; ``Δ = 1e-4 |p|``, truncation 1e-8 relative).
    """

    def __init__(self, base: Newton, moved, steps, minus=None):
        self.base = base
        self.steps = list(steps)
        self.moved = [Newton(model) for model in moved]
        self.minus = [None if model is None else Newton(model) for model in (minus or [None] * len(self.moved))]

    def __call__(self, x, q, v, w, vd, lam, t, dynamic) -> list:
        """``[(∂r/∂p (N,6), ∂Φ/∂p (m,)), …]`` per parameter at the state ``(x, q, V, V̇, λ, t)`` (the residual of
        :meth:`reference.plain.newton.Newton.evaluate`, static or dynamic); the base system's last evaluation
        (``base.last``, with its B) is left at this state."""
        angle = self.base.angle.copy()
        base = self.base.evaluate(x, q, v, w, vd, lam, t, dynamic)
        r0, phi0 = base.r.copy(), base.phi.copy()
        self.base.angle[:] = angle
        out = []
        for nw, back, d in zip(self.moved, self.minus, self.steps):
            nw.angle[:] = angle
            res = nw.evaluate(x, q, v, w, vd, lam, t, dynamic)
            if back is None:
                out.append(((res.r - r0) / d, (res.phi - phi0) / d))
                continue
            back.angle[:] = angle
            low = back.evaluate(x, q, v, w, vd, lam, t, dynamic)
            out.append(((res.r - low.r) / (2.0 * d), (res.phi - low.phi) / (2.0 * d)))
        return out


class _Configuration:
    """The two configurations ``(x, q) ⊕ ±h (dx, dθ)`` seen as a results file of two outputs, for
    :meth:`reference.observables.Observable.evaluate`."""

    def __init__(self, names: _Names, x, q):
        self.names, self.x, self.q = names, x, q

    def _index(self, key) -> int:
        return self.names.nodes.index(self.names.node(key))

    def position(self, key):
        return self.x[:, self._index(key)]

    def rotation(self, key):
        return self.q[:, self._index(key)]

    @property
    def positions(self):
        return self.x


def output_derivative(obs, names: _Names, x, q, dx, dtheta, length: float) -> np.ndarray:
    """``d(obs)/dp = ∂obs/∂(x, q) · (dx, dθ)``: the observable's own formula differentiated along the state
    sensitivity by a central difference of step ``h`` (``h |dx| = 1e-6 length``).  Exact for positions and
    rotations' translations (linear in x); for a deflection or a distance the truncation error is
    ``O((h |dx| / length)²) = 1e-12`` relative and rounding ``1e-16 / 1e-6``."""
    size = max(float(np.max(np.abs(dx))) / length, float(np.max(np.abs(dtheta))), 1e-300)
    h = 1e-6 / size
    xs = np.stack([x + h * dx, x - h * dx])
    qs = np.stack([compose(q, h * dtheta), compose(q, -h * dtheta)])
    values = obs.evaluate(_Configuration(names, xs, qs))
    return (values[0] - values[1]) / (2.0 * h)
