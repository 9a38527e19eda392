"""Critical points along an equilibrium path: the stability count at every point, limit points and
bifurcations, their load factors, the critical mode for a branch switch (docs/formulation.md §11, §12).

:class:`CriticalPoints` is the arc-length algorithm's part that concerns stability
(:class:`reference.algorithms.arc_length.ArcLength`); it uses the host's ``_evaluate`` (the residual and
loads at λ), ``_matrix`` (the Newton matrix at λ), ``_tangent`` (``K δ_F = F``), ``_scaled`` (the path's
norm) and ``_correct`` (the corrector on a normal plane).  Its criterion of a bifurcation (:data:`BIFURCATION`)
and its count's words (:func:`eigenvalue_count`) serve the static algorithm's stability checks too.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from reference.algorithms.implicit import compose
from reference.linalg import SingularMatrix, null_space
from reference.modal import SMALL, nearest_zero, negative_eigenvalues
from reference.status import OK
from reference.validation import ModelWarning

BIFURCATION = 1e-3
"""A change of stability is a bifurcation when the load increment's component along the critical mode is
below this fraction of its size (mass metric): exactly zero on a perfect symmetric structure (the
lateral–torsional mode of an in-plane loaded beam: 1e-12), of the order of the imperfection otherwise."""
REFINE = 3
"""Secant steps that locate a critical point between two points of the path (:meth:`CriticalPoints._locate`)."""


def eigenvalue_count(count: int) -> str:
    """``"1 negative eigenvalue"``, ``"3 negative eigenvalues"``: the stability count in a warning line."""
    return f"{count} negative eigenvalue{'s' if count != 1 else ''}"


class CriticalPoints:
    """The stability count of every converged point and the critical points between them (a mixin of the
    arc-length algorithm: the run state's ``point``, ``negative``, ``sign``, ``events``, ``switch``)."""

    def _reduced(self, run, x, q, lam, Z=None):
        """``(K_r, Z, F_r)``: the tangent at λ reduced to the null space of B, and the reduced load."""
        system = run.system
        _, F = self._evaluate(run, x, q, lam)
        F = F[system.free].copy()
        A = self._matrix(run, x, q, lam, ce=0.0)
        n = system.n_free
        if A.shape[0] == n:
            K = A.toarray() if n <= SMALL else A.copy()
            return K, None, F
        A = A.tocsr()
        if Z is None:
            Z, _ = null_space(A[n:, :n])
        return (Z.T @ A[:n, :n] @ Z).tocsr(), Z, Z.T @ F

    def _stability(self, run, x, q) -> None:
        """Inertia of the reduced tangent at the point just converged, the path slope there, and the events."""
        K, Z, F = self._reduced(run, x, q, run.lam)
        count, sign = negative_eigenvalues(K, (run.negative, run.sign))
        try:
            dF, _ = self._tangent(run, x, q, run.lam)
            t_u = self._scaled(run, dF)
            sgn = -1.0 if run.previous is not None and t_u @ run.previous[:-1] + run.previous[-1] < 0.0 else 1.0
            slope = sgn / math.sqrt(float(t_u @ t_u) + 1.0)
        except SingularMatrix:
            slope = 0.0
        before = run.point
        run.point = (x.copy(), q.copy(), run.mu.copy(), run.lam, run.s, count, slope)
        old, run.negative, run.sign = run.negative, count, sign
        if before is None:
            if count > 0:
                warnings.warn(f"the equilibrium at load factor {run.lam:.6g} is unstable: {eigenvalue_count(count)} of "
                              "the tangent", ModelWarning, stacklevel=3)
            return
        if count == old or count < 0 or old < 0 or run.jumped:  # a branch switch is no event of the path
            return
        system = run.system
        x0, q0, mu0_, lam0, s0, _, slope0 = before
        Zm = sps.identity(system.n_free, format="csr") if Z is None else Z
        M = (Zm.T @ system.mass(x, q) @ Zm).tocsr()
        mu1, phi = nearest_zero(sps.csr_matrix(K), M)
        mu_now = run.mu
        run.mu = mu0_
        K0 = self._reduced(run, x0, q0, lam0, Z)[0]
        run.mu = mu_now
        mu0 = nearest_zero(sps.csr_matrix(K0), M)[0]
        s1, lam1 = run.s, run.lam
        frac = min(max(mu0 / (mu0 - mu1), 0.0), 1.0) if mu0 != mu1 else 1.0  # the critical point inside its bracket
        along = abs(phi @ F)
        size = math.sqrt(max(F @ spla.spsolve(M.tocsc(), F), 0.0)) * math.sqrt(max(phi @ (M @ phi), 0.0))
        if along <= BIFURCATION * size:
            kind = "bifurcation"
            lam_cr = lam0 + frac * (lam1 - lam0)
            if self.branch_switch and not run.switched and count - old >= 2:
                warnings.warn(f"branch_switch: the bifurcation between load factor {lam0:.6g} and {lam1:.6g} has "
                              f"{count - old} critical modes at once (a multiple bifurcation, e.g. equal bending "
                              "stiffnesses): the branch to follow is not unique, so the path stays on the primary "
                              "branch; break the symmetry (a small imperfection load or unequal stiffnesses)",
                              ModelWarning, stacklevel=3)
            elif self.branch_switch and not run.switched:
                mode = np.zeros((x.shape[0], 6))
                mode[system.free] = Zm @ phi
                run.switch, run.switched = mode, True
        else:
            kind = "limit point"
            lam_cr = hermite_extremum(s0, s1, lam0, lam1, slope0, slope)
        located = self._locate(run, before, s1 - s0, mu0, mu1, M, Z)
        lam_cr = lam_cr if located is None else located
        self._evaluate(run, x, q, run.lam)  # the evaluation at the current point again
        run.events.append((lam0, lam1, lam_cr, kind, count))
        change = "stability lost" if count > old else "stability regained" if count == 0 else "stability changed"
        warnings.warn(f"{change} between load factor {lam0:.6g} and {lam1:.6g} (arc length {s0:.6g} to {s1:.6g}): "
                      f"{kind}, {eigenvalue_count(count)} (critical load factor {lam_cr:.8g})", ModelWarning, stacklevel=3)

    def _locate(self, run, before, span, mu0, mu1, M, Z):
        """The load factor where the eigenvalue nearest zero vanishes between the point ``before`` and the
        current one: :data:`REFINE` secant (regula falsi) steps on it along the path, each a point solved
        from ``before`` at the arc σ on its predictor's normal plane (not recorded; the run state is
        restored).  None when a probe fails (the interpolated estimate stands)."""
        x0, q0, m0, lam0, _, _, slope0 = before
        system = run.system
        saved = (run.mu, run.history, run.iterations, system.work.angle.copy())
        a, fa, b, fb = 0.0, mu0, span, mu1
        found = None
        sgn = 1.0 if slope0 >= 0.0 else -1.0
        try:
            for _ in range(REFINE):
                sigma = a + (b - a) * fa / (fa - fb) if fa != fb else 0.5 * (a + b)
                x, q, run.mu = x0.copy(), q0.copy(), m0.copy()
                dF, muF = self._tangent(run, x, q, lam0)
                t_u = self._scaled(run, dF)
                norm = math.sqrt(float(t_u @ t_u) + 1.0)
                dlam = sgn * sigma / norm
                x += dlam * dF[:, :3]
                qn = np.empty_like(q)
                compose(q, np.ascontiguousarray(dlam * dF[:, 3:]), qn, np.empty(4))
                run.mu += dlam * muF
                code, lam, _ = self._correct(run, x, qn, lam0 + dlam, np.append(t_u, 1.0) * (sgn / norm))
                if code != OK:
                    return None
                f = nearest_zero(sps.csr_matrix(self._reduced(run, x, qn, lam, Z)[0]), M)[0]
                found = lam
                if (f > 0.0) == (fa > 0.0):
                    a, fa = sigma, f
                else:
                    b, fb = sigma, f
        except SingularMatrix:
            return None
        finally:
            run.mu, run.history, run.iterations = saved[:3]
            system.work.angle[:] = saved[3]
        return found


def hermite_extremum(s0, s1, f0, f1, d0, d1) -> float:
    """The extremum of the cubic Hermite interpolant of f on [s0, s1] (values f, slopes d); the nearer end's
    value when it has none inside."""
    h = s1 - s0
    a = 2.0 * f0 + h * d0 - 2.0 * f1 + h * d1
    b = -3.0 * f0 - 2.0 * h * d0 + 3.0 * f1 - h * d1
    c = h * d0
    roots = np.roots([3.0 * a, 2.0 * b, c]) if abs(a) + abs(b) > 0.0 else np.array([])
    inside = [float(r.real) for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12 and -1e-9 <= r.real <= 1.0 + 1e-9]
    if not inside:
        return f0 if abs(d0) < abs(d1) else f1
    guess = d0 / (d0 - d1) if d0 != d1 else 0.5
    tau = min(inside, key=lambda r: abs(r - guess))
    return float(((a * tau + b) * tau + c) * tau + f0)
