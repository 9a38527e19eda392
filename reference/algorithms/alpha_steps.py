"""The compiled steps of generalized-α (:mod:`reference.algorithms.generalized_alpha`): predictor,
modified-Newton corrections with the kept factor, acceptance with the energy bookkeeping, and the step-size
control between the outputs (:mod:`reference.algorithms.step_control`: the local error estimate, the
controller, rejection and restore, the step cuts' growing back, landing on the output), all in one compiled
call for many steps; the factorisations stay in Python.

:func:`steps` works in one of three modes (``par["control"]``): :data:`FIXED` steps of ``par["h"]``, as many as
asked; :data:`GROWING` (a step cut after a Newton failure doubles back) and :data:`ERROR_CONTROL`
(``error_tolerance``), which step to the output time ``par["target"]``, choosing each step.  The helpers of the
controlled modes take the arrays they need, never a tuple of arrays or the Model (a helper's arguments cost
two atomic reference-count updates per array in them and call, :mod:`reference.jit`), and they are compiled
apart, not inlined into :func:`steps`, which inlines the whole evaluation (inlined, they lengthened its
compilation: docs/benchmarks.md §10).
A step is judged on its converged iterate before :func:`_accept` writes it into the
state, so a rejected step leaves the state as it was: only the force elements' continuous angles, which every
evaluation continues, are restored, from the flat array ``held``.
"""

from __future__ import annotations

import math

import numpy as np

from reference.algorithms.implicit import compose, evaluate_named, write_record_named
from reference.algorithms.step_control import FLOOR, GROW_AFTER, kept_step, landing_step, next_step, rejected
from reference.jit import inlined, kernel, named
from reference.linalg import lu_solve
from reference.state import Model, Record, record_dtype
from reference.status import DIVERGED, NO_CONVERGENCE, OK, REFACTOR, SINGULAR

FIXED, GROWING, ERROR_CONTROL = 0.0, 1.0, 2.0
"""The modes of :func:`steps` (``par["control"]``): fixed steps; a cut step growing back; error control."""
PAR = record_dtype(
    "h", "alpha_m", "alpha_f", "gamma", "beta", "tolerance", "L", "contraction", "max_iterations", "fresh",
    "iterations", "U", "resume", "corrections", "record", "t0", "n0",
    "control", "dt", "target", "h_next", "dt_min", "dt_max", "error_tolerance", "after_rejection", "good", "ceiling",
    "dead_band", "reuse", "h_factor", "accepted", "h_min", "h_max", "error", "rejected", "over")
"""The settings and counters ``par`` of :func:`steps`, a record: the step ``h`` [s], ``alpha_m``, ``alpha_f``,
``gamma``, ``beta``, the Newton ``tolerance``, the length scale ``L`` [m], the ``contraction`` below which the
factor is kept, ``max_iterations``; ``fresh`` 1 the factor is new, −1 there is none for h; ``iterations``
counted in the kernel; ``U`` the strain energy of the last evaluation [J]; ``resume`` 1 to continue the
interrupted step's iterate; ``corrections`` of this step; ``record`` 1 to first write the output record ``rec``
of the current state from the last evaluation; ``t0``, ``n0`` where the step h began (the time after step n is
``t₀ + (n − n₀) h``).  Then the entries of the controlled modes: the mode ``control``; the output grid's step
``dt`` [s]; the output time to land on, ``target`` [s]; the controller's next step ``h_next`` [s]; ``dt_min``,
``dt_max`` [s]; ``error_tolerance``; ``after_rejection`` 1 right after a rejected step; ``good`` converged
steps since the last cut; the step a cut step grows back to, ``ceiling`` [s]; the ``dead_band``
(:func:`reference.algorithms.step_control.kept_step`); ``reuse``, the relative change of the step within which
the factor is kept; ``h_factor`` the step of the factor [s]; and the statistics since the caller last read them
(:func:`clear_statistics`): ``accepted`` steps, the smallest and largest accepted step ``h_min``, ``h_max`` [s],
the largest ``error`` norm (NaN: none), ``rejected`` steps, accepted steps ``over`` the tolerance (at
``dt_min``)."""


def new_par(**values) -> np.ndarray:
    """A :data:`PAR` array of shape (1,), its record with the fields ``values`` and the statistics cleared, the
    others zero."""
    par = np.zeros(1, PAR)
    clear_statistics(par[0])
    for name, value in values.items():
        par[0][name] = value
    return par


def clear_statistics(par) -> None:
    """The statistics of the record ``par`` (:data:`PAR`) back to none."""
    for name, value in (("accepted", 0.0), ("h_min", math.inf), ("h_max", 0.0), ("error", math.nan),
                        ("rejected", 0.0), ("over", 0.0)):
        par[name] = value


RECOVERABLE = (NO_CONVERGENCE, DIVERGED, SINGULAR)
"""Step failures that a smaller step may cure (:mod:`reference.algorithms.step_control`): Newton's, and a singular
Newton matrix at the step's iterate."""

NO_FACTOR = (np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(1, np.int64),
             np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64))
"""Empty factor arrays, passed to the compiled steps before the first factorisation."""


@kernel
def power(model, Bl, lam, v, w):
    """``−λᵀ B V`` (power of the constraint forces) from the local rows ``Bl``."""
    P = 0.0
    jt_i, jt_j, jt_row0, jt_neq = model.joints.i, model.joints.j, model.joints.row0, model.joints.neq
    for k in range(jt_i.shape[0]):
        i, j = jt_i[k], jt_j[k]
        for r in range(jt_row0[k], jt_row0[k] + jt_neq[k]):
            acc = 0.0
            for a in range(3):
                acc += Bl[r, a] * v[i, a] + Bl[r, 3 + a] * w[i, a]
                if j >= 0:
                    acc += Bl[r, 6 + a] * v[j, a] + Bl[r, 9 + a] * w[j, a]
            P -= lam[r] * acc
    return P


@kernel
def dissipation(model, v, w):
    """Power of the mass-proportional damping ``c Vᵀ M V`` [W] (the force elements' dampers are added
    from the evaluation)."""
    c = model.damping
    D = 0.0
    J, mass = model.nodes.inertia, model.nodes.mass
    for i in range(v.shape[0]):
        for a in range(3):
            D += mass[i] * v[i, a] * v[i, a]
            for b in range(3):
                D += w[i, a] * J[i, a, b] * w[i, b]
    return c * D


_evaluate = evaluate_named
_write_record = write_record_named
_power_inlined = inlined(power)
_dissipation_inlined = inlined(dissipation)
"""The model-taking kernels that :func:`steps` calls every iteration, inlined: a compiled call
with the Model costs an atomic reference-count update per array of it, twice."""


@inlined
def _predict(v, w, vd, a, lam, arr, h, par):
    """The step's predictor from the converged state: algorithmic accelerations ``a_{n+1}`` at
    ``V̇_{n+1} = V̇_n``, the increment ``Δq`` and velocities ``V_{n+1}`` of the scheme, ``λ_{n+1} = λ_n``, into
    the iterate's arrays of ``arr`` (:func:`steps`)."""
    dq, Vn, vdn, an, _, _, _, lamn, _, _, _, _, _, _, _, _ = arr
    am, gamma, beta = par["alpha_m"], par["gamma"], par["beta"]
    for i in range(v.shape[0]):
        for k in range(6):
            Vk = v[i, k] if k < 3 else w[i, k - 3]
            an[i, k] = (vd[i, k] - am * a[i, k]) / (1.0 - am)
            vdn[i, k] = vd[i, k]
            dq[i, k] = Vk + h * (0.5 - beta) * a[i, k] + h * beta * an[i, k]
            Vn[i, k] = Vk + h * (1.0 - gamma) * a[i, k] + h * gamma * an[i, k]
    for k in range(lam.shape[0]):
        lamn[k] = lam[k]


@inlined
def _configuration(x, q, dq, h, x1, q1, tmp, psi):
    """The configuration of the iterate ``h Δq``: ``x_{n+1} = x_n + h Δx``, ``q_{n+1} = q_n ⊗ exp(h Δθ)`` into
    ``x1``, ``q1`` (``psi`` the rotation vectors ``h Δθ`` [rad], ``tmp`` work)."""
    for i in range(x.shape[0]):
        for k in range(3):
            x1[i, k] = x[i, k] + h * dq[i, k]
            psi[i, k] = h * dq[i, 3 + k]
    compose(q, psi, q1, tmp)


@inlined
def _accept(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, arr, Bl, F, fe_out, h, am, af):
    """The converged step: the energy bookkeeping with its last evaluation (within the Newton
    tolerance of the step's end) and the new state ``x, q, V, V̇, a, λ`` from the iterate in ``arr``.

    Takes 18 parameters: the step's state, energy and evaluation arrays and α coefficients, locals of :func:`steps`,
    which inlines it (a record of them would recompile the generalized-α kernels, numerics unchanged).
    """
    dq, Vn, vdn, an, _, _, _, lamn, _, _, _, _, x1, q1, tmp, psi = arr
    N = x.shape[0]
    _configuration(x, q, dq, h, x1, q1, tmp, psi)
    P1 = _power_inlined(model, Bl, lamn, Vn[:, :3], Vn[:, 3:])
    D1 = _dissipation_inlined(model, Vn[:, :3], Vn[:, 3:]) + fe_out[0]
    dW = 0.0
    for i in range(N):
        for k in range(6):
            dW += 0.5 * (f_prev[i, k] + F[i, k]) * h * dq[i, k]
            f_prev[i, k] = F[i, k]
    clock["work"] += dW + 0.5 * h * (energy[0] + P1)
    clock["dissipated"] += 0.5 * h * (energy[1] + D1)
    energy[0], energy[1] = P1, D1
    for i in range(N):
        for k in range(6):
            a[i, k] = an[i, k] + (1.0 - af) / (1.0 - am) * (vdn[i, k] - vd[i, k])
            vd[i, k] = vdn[i, k]
        for k in range(3):
            x[i, k] = x1[i, k]
            v[i, k] = Vn[i, k]
            w[i, k] = Vn[i, 3 + k]
        for k in range(4):
            q[i, k] = q1[i, k]
    for k in range(lam.shape[0]):
        lam[k] = lamn[k]


ROUNDOFF = 64.0 * np.finfo(float).eps
"""A correction below ``ROUNDOFF × max(1, max|x|/L)`` (translations over L, rotations in rad) is at the
round-off of the coordinates: Newton stops there even when the residual, whose round-off can exceed the
tolerance on a stiff model nearly at rest, is not balanced."""


@inlined
def _correction(r, S, F, PHI, row_eps, lamn, dof, ck, factors, rhs, lwork, sol, delta, L, mass, J, vdn):
    """One Newton correction with the kept factor: the right-hand side ``−[c_k r; Φ − ελ]`` of the last
    evaluation, the solution ``sol`` and the node part ``delta`` (N, 6).

    Returns its size (translations over the model size L, rotations in rad; NaN if the residual is not
    finite) and the evaluation's imbalance: the largest free residual force over the step's force scale
    — the largest free inertial force ``M V̇``, internal force S, external force F or ``r − S + F`` (the
    joints' and the inertia's forces together) — moments over L, or ``max |Φ − ελ| / L`` if larger.

    Takes 17 parameters: the last evaluation's arrays, the kept factor and the solve's scratch, locals of
    :func:`steps`, which inlines it every correction.
    """
    m = lamn.shape[0]
    n_free = rhs.shape[0] - m
    res, scale = 0.0, 0.0
    for i in range(r.shape[0]):
        for k in range(6):
            if not math.isfinite(r[i, k]):
                return math.nan, math.nan
            if dof[i, k] >= 0:
                rhs[dof[i, k]] = -ck * r[i, k]
                if k < 3:
                    inertia, unit = mass[i] * vdn[i, k], 1.0
                else:
                    inertia = J[i, k - 3, 0] * vdn[i, 3] + J[i, k - 3, 1] * vdn[i, 4] + J[i, k - 3, 2] * vdn[i, 5]
                    unit = 1.0 / L
                res = max(res, abs(r[i, k]) * unit)
                big = max(abs(inertia), abs(S[i, k]), abs(F[i, k]), abs(r[i, k] - S[i, k] + F[i, k]))
                scale = max(scale, big * unit)
    phi = 0.0
    for k in range(m):
        rhs[n_free + k] = -(PHI[k] - row_eps[k] * lamn[k])
        phi = max(phi, abs(rhs[n_free + k]))
    lu_solve(factors, rhs, lwork, sol)
    size = 0.0
    for i in range(r.shape[0]):
        for k in range(6):
            d = sol[dof[i, k]] if dof[i, k] >= 0 else 0.0
            delta[i, k] = d
            size = max(size, abs(d) / L if k < 3 else abs(d))
    return size, max(res / scale if res > 0.0 else 0.0, phi / L)


@inlined
def _roundoff(x, L):
    """``ROUNDOFF × max(1, max|x|/L)``: a correction below it is at the coordinates' round-off."""
    extent = 1.0
    for i in range(x.shape[0]):
        for k in range(3):
            extent = max(extent, abs(x[i, k]) / L)
    return ROUNDOFF * extent


@inlined
def _error_norm(a, an, vdn, vd, Vn, h, par):
    """:func:`reference.algorithms.step_control.error_norm` of the converged iterate before it is accepted: the
    new algorithmic accelerations as :func:`_accept` makes them, the same operations in the same order."""
    beta, L, tol, am, af = par["beta"], par["L"], par["error_tolerance"], par["alpha_m"], par["alpha_f"]
    c = h * h * abs(beta - 1.0 / 6.0)
    floor = FLOOR * L
    err = 0.0
    for i in range(a.shape[0]):
        for k in range(6):
            a_new = an[i, k] + (1.0 - af) / (1.0 - am) * (vdn[i, k] - vd[i, k])
            e = abs(a_new - a[i, k]) * c / (tol * (h * abs(Vn[i, k]) + (floor if k < 3 else FLOOR)))
            err = max(err, e)
    return err


_next_step = inlined(next_step)
_kept_step = inlined(kept_step)
_landing_step = inlined(landing_step)
_rejected = inlined(rejected)


def set_step(par, h, t0, n0):
    """Steps of h [s] from time t0 after step n0 (the record ``par`` of :func:`steps`, in Python and compiled).
    A new h needs a new factor (``fresh = −1``: the Newton matrix's coefficients depend on h) unless it lies
    within ``reuse`` of the factor's step."""
    if h != par["h"]:
        par["h"] = h
        if abs(h - par["h_factor"]) > par["reuse"] * par["h_factor"]:
            par["fresh"] = -1.0
    par["t0"], par["n0"] = t0, n0


_set_step = inlined(set_step)


@kernel
def _choose(par, clock, angle, held):
    """The next step of a controlled mode from the state at ``clock["t"]``: the controller's ``par["h_next"]``
    made to land on the output time ``par["target"]`` (:func:`reference.algorithms.step_control.landing_step`),
    and the force elements' continuous angles kept in ``held`` (every evaluation continues them); False, with
    the clock set to the output time, when that is reached."""
    left = par["target"] - clock["t"]
    if left <= 1e-9 * par["dt"]:
        clock["t"] = par["target"]
        return False
    _set_step(par, _landing_step(left, par["h_next"]), clock["t"], clock["n"])
    for k in range(angle.shape[0]):
        held[k] = angle[k]
    return True


@inlined
def _count(par, h, err):
    """:meth:`reference.algorithms.step_control.SolverStatistics.step` into ``par``'s statistics."""
    par["accepted"] += 1.0
    par["h_min"], par["h_max"] = min(par["h_min"], h), max(par["h_max"], h)
    if err == err:
        par["error"] = err if par["error"] != par["error"] else max(par["error"], err)
        if err > 1.0:
            par["over"] += 1.0


@kernel
def _judge(par, clock, a, an, vdn, vd, Vn, angle, held):
    """The converged iterate of a step of ``par["h"]`` from ``clock["t"]`` in a controlled mode, before it is accepted:
    the statistics and the next step (:mod:`reference.algorithms.step_control`); True when the step is rejected
    for its error estimate (:func:`reference.algorithms.step_control.rejected`: the state is left as it was at the
    step's start, the angles restored from ``held``)."""
    h_use, h = par["h"], par["h_next"]
    if par["control"] != ERROR_CONTROL:
        _count(par, h_use, math.nan)
        par["good"] += 1.0
        if par["h_next"] < par["ceiling"] and par["good"] >= GROW_AFTER:
            par["h_next"], par["good"] = min(2.0 * par["h_next"], par["ceiling"]), 0.0
        return False
    err = _error_norm(a, an, vdn, vd, Vn, h_use, par)
    h_next = min(max(_next_step(h_use, err), par["dt_min"]), par["dt_max"])
    if _rejected(err, h_use, _landing_step(par["target"] - clock["t"], h_next), par["dt_min"]):
        par["rejected"] += 1.0
        par["h_next"], par["after_rejection"] = h_next, 1.0
        for k in range(angle.shape[0]):
            angle[k] = held[k]
        return True
    if par["after_rejection"] == 1.0:
        h_next, par["after_rejection"] = min(h_next, h_use), 0.0  # no growth right after a rejection (HNW §II.4)
    h_next = _kept_step(h_use, h_next, par["dead_band"])
    _count(par, h_use, err)
    # a step shortened to land on an output keeps the controller's step for the next
    par["h_next"] = h_next if h_use >= h else max(h, h_next)
    return False


@inlined
def _coefficients(par):
    """``(h, β', γ', c_k)`` of the step ``par["h"]``: ``β' = (1 − α_m)/(h²β(1 − α_f))``, ``γ' = γ/(hβ)``,
    ``c_k = 1/β'``."""
    h, am, af, gamma, beta = par["h"], par["alpha_m"], par["alpha_f"], par["gamma"], par["beta"]
    bp = (1.0 - am) / (h * h * beta * (1.0 - af))
    return h, bp, gamma / (h * beta), 1.0 / bp


@inlined
def _corrected(dq, Vn, vdn, lamn, delta, sol, h, gp, bp):
    """The iterate after a Newton correction ``delta`` (N, 6) and ``sol``'s multiplier rows: ``dq += δ/h``,
    ``V += γ' δ``, ``V̇ += β' δ``, ``λ += β' Δλ`` (``gp``, ``bp`` :func:`_coefficients`)."""
    N, m = dq.shape[0], lamn.shape[0]
    n_free = sol.shape[0] - m
    for i in range(N):
        for k in range(6):
            dq[i, k] += delta[i, k] / h
            Vn[i, k] += gp * delta[i, k]
            vdn[i, k] += bp * delta[i, k]
    for k in range(m):
        lamn[k] += bp * sol[n_free + k]


@kernel
def steps(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, dof, par, n_steps, factors, wt, arr, rec, held):
    """Up to ``n_steps`` generalized-α steps with the kept factor (compiled modified Newton), or in a controlled mode
    (``par["control"]``) up to ``n_steps`` tries of a step (accepted or rejected) towards ``par["target"]``, each
    chosen by the step control; ``(status, steps)``, the steps tried before the return (in a controlled mode the clock
    is at ``par["target"]`` when it is reached; the caller bounds ``n_steps`` so that a call returns to Python within
    a fraction of a second, :class:`reference.algorithms.base.CallBudget`).

    ``REFACTOR`` (a correction shrank by less than ``contraction``, or no factor for the step yet) leaves the
    unfinished step's iterate in ``arr`` (x1, q1, V, λ, h Δq): the caller factors the Newton matrix there at
    ``par["h"]`` and calls again, and the step resumes from it.  ``NO_CONVERGENCE`` after ``max_iterations``
    corrections.  Converged: :func:`_correction`'s imbalance (× θ/(1 − θ) once θ is known) below the Newton tolerance,
    or a correction at :func:`_roundoff`.  ``clock``, ``par``: the (1,) records :data:`reference.state.CLOCK`,
    :data:`PAR`; ``held``: :func:`_choose`.

    Takes 19 parameters: the State's arrays one by one, as its Python driver holds them (a record: a recompile)."""
    model, rec = named(model, Model), named(rec, Record)
    clock, par = clock[0], par[0]
    dq, Vn, vdn, an, delta, _, _, lamn, mu, rhs, sol, lwork, x1, q1, tmp, psi = arr
    S, F, r, PHI, PHIt, Bl, A, jphi, jB, jphit, prim_phi, prim_B, fe, elements = wt
    am, af = par["alpha_m"], par["alpha_f"]
    tol, L, contraction = par["tolerance"], par["L"], par["contraction"]
    max_it = int(par["max_iterations"])
    h, bp, gp, ck = _coefficients(par)
    row_eps, angle, control, floor = model.joints.compliance, fe[1], par["control"] != FIXED, _roundoff(x, L)
    if par["record"] == 1.0:
        par["record"] = 0.0
        _write_record(model, x, q, v, w, par["U"], clock, lam, PHI, PHIt, Bl, rec)
    for step in range(n_steps):
        if control and par["resume"] != 1.0:  # a new step of a controlled mode
            if not _choose(par, clock, angle, held):
                return OK, step  # landed on the output time
            h, bp, gp, ck = _coefficients(par)
        t1 = clock["t"] + h
        if not (step == 0 and par["resume"] == 1.0):
            # predictor (unless resuming the iterate of an interrupted step with a new factor)
            par["corrections"] = 0.0
            _predict(v, w, vd, a, lam, arr, h, par)
        par["resume"] = 1.0  # an interruption from here on keeps the iterate
        previous = -1.0
        converged = False
        while par["corrections"] < max_it:
            _configuration(x, q, dq, h, x1, q1, tmp, psi)
            par["U"] = _evaluate(model, x1, q1, Vn[:, :3], Vn[:, 3:], vdn, lamn, t1, True, wt)
            if par["fresh"] < 0.0:
                return REFACTOR, step
            size, imbalance = _correction(r, S, F, PHI, row_eps, lamn, dof, ck, factors, rhs, lwork, sol, delta, L,
                                          model.nodes.mass, model.nodes.inertia, vdn)
            if not math.isfinite(size):
                return DIVERGED, step
            theta = size / previous if previous > 0.0 else 1.0
            # left after this correction: θ/(1 − θ) of the imbalance it corrected (Hairer & Wanner 1996, §IV.8)
            done = imbalance <= tol or (theta < 1.0 and theta * imbalance <= tol * (1.0 - theta)) or size <= floor
            if previous >= 0.0 and size > contraction * previous and not done:
                return REFACTOR, step  # a new factor at this iterate (full Newton when it keeps happening)
            previous = size
            par["corrections"] += 1.0
            _corrected(dq, Vn, vdn, lamn, delta, sol, h, gp, bp)
            par["iterations"] += 1.0
            if done:  # a slow contraction refactors only a step that has not converged
                converged = True
                break
        if not converged:
            par["resume"] = 0.0
            return NO_CONVERGENCE, step
        par["fresh"] = 0.0
        par["resume"] = 0.0
        if control and _judge(par, clock, a, an, vdn, vd, Vn, angle, held):
            par["U"] = math.nan  # rejected: the state stays, the last evaluation is not at it
            continue
        _accept(model, x, q, v, w, vd, a, lam, clock, f_prev, energy, arr, Bl, F, fe[8], h, am, af)
        clock["n"] += 1
        clock["t"] = par["t0"] + (clock["n"] - par["n0"]) * h
    return OK, n_steps
