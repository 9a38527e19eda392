"""∂R/∂p and the outputs' derivatives along a state sensitivity, on the reference path.

:class:`ParameterDerivatives` gives, at a state, ``∂r/∂p`` and ``∂Φ/∂p`` of every parameter of a run
(docs/formulation.md §14), each by its kind (:class:`Stiffness`, :class:`LoadScale`, :class:`Mass`,
:class:`Spring`, :class:`Moved`):

- a section stiffness entry: ``∂S/∂c_j`` of the elements of that section, from the generated kernels
  (derivations/sensitivities.py; :func:`reference.plain.elements.element_stiffness_derivatives`), one element
  pass for all of them;
- a load's scale s: ``∂r/∂s = −F_k(t)``, the load's own vector (no other evaluation);
- a mass (a section's ``rhoA``, ``rhoJi``, a rigid body's mass): the lumped masses ``m``, ``J`` are affine in
  it, so ``∂m/∂p``, ``∂J/∂p`` are differences of the assembled masses, taken once (:class:`Mass`), and
  ``∂r/∂p = ∂m/∂p (v̇ + c v − g)`` on the translations, ``∂J/∂p (ω̇ + c ω) + ω × ∂J/∂p ω`` on the rotations
  (``−∂m/∂p g`` alone when static);
- a spring's stiffness: ``∂r/∂p = −∂G/∂p``, ``∂G/∂p = −B_eᵀ (∂k/∂p) (e − e_0)`` the spring force of the element
  alone, evaluated with its stiffnesses' change per unit of p, no damper and no actuator (:class:`Spring`);
- a time function's end value (a drive's speed): the residual of the model with the parameter moved, a central
  difference ``(r(p + Δ) − r(p − Δ)) / 2Δ`` (:class:`Moved`);
- a node's coordinate X (geometry): the central difference ``(r(X + Δ) − r(X − Δ)) / 2Δ`` of the residual at the
  fixed state between the decks rebuilt with X moved (:class:`Moved`, with the fixed coordinates' own derivative:
  :func:`reference.sensitivity.static.solve_static`).

:class:`ResidualDerivatives` is that re-evaluation for every parameter: the oracle the tests compare the
kinds above with.  :func:`output_derivatives` carries a state sensitivity ``(dx, dθ)`` (inertial translations,
body-frame rotations, as the Newton increments) to an observable (docs/observables.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reference.observables import _Names
from reference.plain import loads
from reference.plain.elements import element_stiffness_derivatives
from reference.plain.newton import Newton, compose


@dataclass
class Stiffness:
    """The section entry ``c_j`` (``column`` j of ``(EA, GA2, GA3, GJ, EI2, EI3)``) of the elements
    ``members`` (bool over the Domain's elements)."""

    members: np.ndarray
    column: int


@dataclass
class LoadScale:
    """The scale of the model's load row ``row`` (:class:`reference.state.Loads`)."""

    row: int


@dataclass
class Mass:
    """A parameter the lumped masses are affine in: ``dm`` (N,) ``∂m/∂p``, ``dJ`` (N,3,3) ``∂J/∂p``."""

    dm: np.ndarray
    dJ: np.ndarray


@dataclass
class Spring:
    """The stiffness of the force element ``row`` (:class:`reference.state.ForceElements`): ``dk`` (6,) the change
    of its stiffness per measure per unit of the parameter."""

    row: int
    dk: np.ndarray


@dataclass
class Moved:
    """A parameter differentiated by the residual of the model moved by ``step`` (and by −step: ``minus``, for a
    parameter the residual is not affine in; None otherwise); ``fixed`` (N,6), for a node's coordinate, the
    derivative ``[dx | dθ]`` of the coordinates the run holds fixed (None: they do not move)."""

    model: object
    step: float
    minus: object = None
    fixed: np.ndarray | None = None


class ParameterDerivatives:
    """∂r/∂p and ∂Φ/∂p for the parameters of one run, each by its kind (module docstring).

    Parameters
    ----------
    base : Newton
        The run's own Newton system (the model at the nominal parameters).
    kinds : list of Stiffness, LoadScale, Mass or Moved
        Per parameter.
    """

    def __init__(self, base: Newton, kinds):
        self.base, self.kinds = base, list(kinds)
        model = base.model
        self._one_load = {k.row: model._replace(
            loads=type(model.loads)(*(a[k.row:k.row + 1] for a in model.loads)),
            nodes=model.nodes._replace(mass=np.zeros_like(model.nodes.mass))) for k in self.kinds
            if isinstance(k, LoadScale)}
        self._one_spring = {k.row: _one_spring(model, k) for k in self.kinds if isinstance(k, Spring)}
        moved = [k for k in self.kinds if isinstance(k, Moved)]
        self._moved = {id(k): (Newton(k.model), None if k.minus is None else Newton(k.minus)) for k in moved}

    def __call__(self, x, q, v, w, vd, lam, t, dynamic) -> list:
        """``[(∂r/∂p (N,6), ∂Φ/∂p (m,)), …]`` per parameter at the state ``(x, q, V, V̇, λ, t)`` (the residual of
        :meth:`reference.plain.newton.Newton.evaluate`, static or dynamic); the base system's last evaluation
        (``base.last``, with its B) is left at this state."""
        angle = self.base.angle.copy()
        base = self.base.evaluate(x, q, v, w, vd, lam, t, dynamic)
        self.base.angle[:] = angle
        N, no_phi = x.shape[0], np.zeros(self.base.m)
        blocks = element_stiffness_derivatives(self.base.model, x, q) if any(
            isinstance(k, Stiffness) for k in self.kinds) else []
        out = []
        for kind in self.kinds:
            if isinstance(kind, Stiffness):
                dr = np.zeros((N, 6))
                for index, conn, ds in blocks:
                    sel = kind.members[index]
                    np.add.at(dr, conn[sel].reshape(-1), ds[sel][..., kind.column].reshape(-1, 6))
                out.append((dr, no_phi))
            elif isinstance(kind, LoadScale):
                out.append((-loads.external_forces(self._one_load[kind.row], q, t), no_phi))
            elif isinstance(kind, Mass):
                out.append((self._mass(kind, v, w, vd, dynamic), no_phi))
            elif isinstance(kind, Spring):
                G = loads.force_element_forces(self._one_spring[kind.row], x, q, v, w, t,
                                               angle[kind.row:kind.row + 1].copy())[0]
                out.append((-G, no_phi))
            else:
                out.append(self._reevaluated(kind, base, angle, (x, q, v, w, vd, lam, t, dynamic)))
        return out

    def _mass(self, kind: Mass, v, w, vd, dynamic) -> np.ndarray:
        """``∂r/∂p`` of a mass parameter (module docstring)."""
        model, c = self.base.model, self.base.ev.damping
        dr = np.zeros((kind.dm.shape[0], 6))
        dr[:, :3] = -kind.dm[:, None] * model.gravity
        if dynamic:
            dJw = np.einsum("nab,nb->na", kind.dJ, w)
            dr[:, :3] += kind.dm[:, None] * (vd[:, :3] + c * v)
            dr[:, 3:] += np.einsum("nab,nb->na", kind.dJ, vd[:, 3:]) + np.cross(w, dJw) + c * dJw
        return dr

    def _reevaluated(self, kind: Moved, base, angle, state) -> tuple:
        """``(∂r/∂p, ∂Φ/∂p)`` of a :class:`Moved` parameter: the moved model's residual at the same state."""
        plus, minus = self._moved[id(kind)]
        plus.angle[:] = angle
        res = plus.evaluate(*state)
        if minus is None:
            return (res.r - base.r) / kind.step, (res.phi - base.phi) / kind.step
        minus.angle[:] = angle
        low = minus.evaluate(*state)
        return (res.r - low.r) / (2.0 * kind.step), (res.phi - low.phi) / (2.0 * kind.step)

    def moved(self, kind):
        """The Newton systems ``(+Δ, −Δ or None)`` of a :class:`Moved` parameter."""
        return self._moved[id(kind)]


def _one_spring(model, kind: Spring):
    """``model`` with the force element ``kind.row`` alone, its stiffnesses ``kind.dk``, no damper, no actuator:
    its spring force is ``∂G/∂p`` (:func:`reference.plain.loads.force_element_forces`)."""
    fe = model.force_elements
    one = type(fe)(*(a[kind.row:kind.row + 1] for a in fe))
    return model._replace(force_elements=one._replace(k=kind.dk[None].astype(float), c=np.zeros_like(one.c),
                                                      tf=np.full_like(one.tf, -1)))


class ResidualDerivatives:
    """∂r/∂p and ∂Φ/∂p for every parameter by the moved models' residuals: the oracle of
    :class:`ParameterDerivatives` (module docstring); exact for the parameters the residual is affine in.

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


def output_derivatives(obs, names: _Names, x, q, d, length: float) -> list:
    """``d(obs)/dp = ∂obs/∂(x, q) · (dx, dθ)`` for every parameter: the observable's own formula differentiated
    along each state sensitivity ``d[k] = [dx | dθ]`` (P, N, 6) by a central difference of step ``h_k``
    (``h_k |dx_k| = 1e-6 length``), the 2P configurations in one evaluation.  Exact for positions and
    rotations' translations (linear in x); for a deflection or a distance the truncation error is
    ``O((h |dx| / length)²) = 1e-12`` relative and rounding ``1e-16 / 1e-6``."""
    dx, dtheta = d[:, :, :3], d[:, :, 3:]
    size = np.maximum(np.max(np.abs(dx), axis=(1, 2)) / length, np.max(np.abs(dtheta), axis=(1, 2)))
    h = 1e-6 / np.maximum(size, 1e-300)
    steps = np.concatenate([h, -h])[:, None, None]  # (2P, 1, 1): +h_k for the first P, −h_k for the last
    xs = x[None] + steps * np.concatenate([dx, dx])
    turned = compose(np.tile(q, (len(steps), 1)), (steps * np.concatenate([dtheta, dtheta])).reshape(-1, 3))
    values = obs.evaluate(_Configuration(names, xs, turned.reshape(len(steps), *q.shape)))
    P = len(h)
    return [(values[k] - values[P + k]) / (2.0 * h[k]) for k in range(P)]
