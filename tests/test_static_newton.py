"""The compiled Newton loop of the static algorithm and of the arc-length corrector
(reference/algorithms/newton_steps.py) against the Python loops it replaced, written out here as the
oracles: the same iterates bit for bit, through the REFACTOR path (a fresh SuperLU factorisation when the
kept pivot order fails) too.
"""

from __future__ import annotations

import numpy as np

from reference.algorithms.implicit import compose
from reference.algorithms.path_checks import row_forces
from reference.algorithms.static import Static
from reference.domain import Domain
from reference.elements import Section
from reference.interactions import Clamp, NodalLoad, Ramp
from reference.linalg import SingularMatrix
from reference.status import OK

SOFT = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=10.0, EI2=10.0, EI3=10.0, rhoA=1.0, rhoJ1=2e-3, rhoJ2=1e-3, rhoJ3=1e-3)


def frame():
    """Two 3-element beams, each clamped at one end, joined by a revolute at their common node, a force and a
    dead moment ramped in on the second: multipliers (the joint-force scale of the balance test), a
    non-symmetric tangent."""
    d = Domain("two beams and a revolute")
    a = d.add_beam("a", (0, 0, 0), (1, 0, 0), 3, SOFT)
    b = d.add_beam("b", (1, 0, 0), (1.6, 0.5, 0.2), 3, SOFT)
    d.add_interaction(Clamp(a[0]))
    d.add_interaction(Clamp(b[-1]))
    d.add_joint("revolute", a[-1], b[0], (1, 0, 0), axis=(0, 0.4, 1))
    ramp = Ramp(0.0, 1.0, 0.0, 1.0)
    d.add_interaction(NodalLoad(b[1], np.array([0.0, -4.0, 2.0]), time_function=ramp))
    d.add_interaction(NodalLoad(b[1], np.array([0.5, 0.0, 0.3]), moment=True, time_function=ramp))
    return d


def python_newton(algo, system, x, q, lam, t, L):
    """The Python full-Newton loop the compiled one replaced (operation for operation); returns (code, corrections)."""
    q_new, tmp = np.empty_like(q), np.empty(4)
    delta = None
    for it in range(algo.max_iterations + 1):
        system.evaluate(x, q, x, x, x, lam, t, False)
        wk = system.work
        scale = max(float(np.max(np.abs(wk.S), initial=0.0)), float(np.max(np.abs(wk.F), initial=0.0)), 1e-300)
        if lam.size:
            scale = max(scale, float(np.max(np.abs(row_forces(system, lam)))))
        phi = np.abs(wk.PHI - system.model.joints.eps * lam)
        balanced = float(np.max(np.abs(wk.r[system.free]), initial=0.0)) <= algo.tolerance * scale and \
            float(np.max(phi, initial=0.0)) <= algo.tolerance * L
        if balanced or (it > 0 and algo.converged(delta, L)):
            return OK, it
        lu = system.factor(x, q, x, t, lam, 0.0, 0.0, 1.0)
        delta, mu = system.newton_correction(lu, 1.0, lam)
        x += delta[:, :3]
        compose(q, np.ascontiguousarray(delta[:, 3:]), q_new, tmp)
        q[:] = q_new
        lam += mu
    raise AssertionError("the oracle did not converge")


def test_compiled_static_newton_gives_the_python_loops_iterates_bit_for_bit():
    """Five load levels of the frame from its reference state (2–5 corrections each): the compiled loop and
    the oracle end at the same x, q, λ bit for bit with the same number of corrections; with the pivot
    threshold at 1 (every kept pivot order refused: the REFACTOR path, a SuperLU factorisation every
    iteration) the same equilibria within 1e-12 (SuperLU may order differently; the iterates then differ
    by round-off), and as many factorisations as corrections."""
    d = frame()
    model = d.initialization()
    algo = Static(0.2)
    runs = []
    for threshold in (None, 1.0):
        state = d.initial_conditions()
        run = algo.start(model, state)
        if threshold is not None:
            run.newton.fields["threshold"] = run.system.slu.PIVOT_THRESHOLD = threshold
        x, q, lam = state.x.copy(), state.q.copy(), run.lam
        ox, oq, olam = x.copy(), q.copy(), lam.copy()
        oracle = algo.newton_system(model)
        levels = []
        for t in (0.2, 0.4, 0.6, 0.8, 1.0):
            assert algo._equilibrium(run, x, q, lam, t) == OK
            code, its = python_newton(algo, oracle, ox, oq, olam, t, run.L)
            levels.append(len(run.history) - 1)
            if threshold is None:
                assert len(run.history) - 1 == its and 2 <= its <= 5
                assert np.array_equal(x, ox) and np.array_equal(q, oq) and np.array_equal(lam, olam)
            else:
                assert np.abs(x - ox).max() <= 1e-12 and np.abs(q - oq).max() <= 1e-12
                assert np.abs(lam - olam).max() <= 1e-12 * np.abs(olam).max()
        runs.append((run.system.slu.fresh, sum(levels), x))
    print("SuperLU factorisations / corrections: kept order", runs[0][:2], "threshold 1", runs[1][:2])
    assert runs[0][0] == 1 and runs[1][0] == runs[1][1]
    assert np.abs(runs[0][2] - runs[1][2]).max() <= 1e-12


def test_a_singular_first_factor_is_reported_not_raised():
    """A free-floating beam under a load (no support): the first SuperLU factorisation fails; the loop returns
    SINGULAR (the run's message), it raises nothing."""
    d = Domain("floating")
    a = d.add_beam("a", (0, 0, 0), (1, 0, 0), 2, SOFT)
    d.add_interaction(NodalLoad(a[-1], np.array([0.0, 1.0, 0.0])))
    model = d.initialization()
    algo = Static(1.0)
    state = d.initial_conditions()
    run = algo.start(model, state)
    try:
        code = algo._equilibrium(run, state.x, state.q, run.lam, 1.0)
    except SingularMatrix as exc:  # pragma: no cover - the failure this test guards against
        raise AssertionError(f"raised {exc}") from None
    assert code != OK


def python_corrector(algo, run, x, q, lam, normal):
    """The Python arc-length corrector the compiled one replaced (operation for operation)."""
    system = run.system
    q_new, tmp = np.empty_like(q), np.empty(4)
    moved = np.zeros(system.n_free + 1)
    delta = None
    for it in range(algo.max_iterations + 1):
        run.U = float(system.evaluate(x, q, x, x, x, run.mu, algo.t_end, False))
        F = system.work.F
        r = system.work.r + (1.0 - lam) * F
        wk = system.work
        scale = max(float(np.max(np.abs(wk.S), initial=0.0)), abs(lam) * float(np.max(np.abs(F), initial=0.0)), 1e-300)
        if run.mu.size:
            scale = max(scale, float(np.max(np.abs(row_forces(system, run.mu)))))
        phi = np.abs(wk.PHI - system.model.joints.eps * run.mu)
        balanced = float(np.max(np.abs(r[system.free]), initial=0.0)) <= algo.tolerance * scale and \
            float(np.max(phi, initial=0.0)) <= algo.tolerance * run.L
        if balanced or (it > 0 and algo.converged(delta, run.L)):
            return OK, lam, moved, it
        lu = system.slu.factor(algo._matrix(run, x, q, lam))
        phi = system.work.PHI - system.model.joints.eps * run.mu
        dR, muR = system.solve(lu, -r, -phi)
        dlam = 0.0
        if normal is not None:
            dF, muF = system.solve(lu, F, np.zeros_like(phi))
            den = normal[:-1] @ algo._scaled(run, dF) + normal[-1]
            dlam = -(normal[:-1] @ algo._scaled(run, dR)) / den
            dR += dlam * dF
            muR += dlam * muF
        delta = dR
        x += delta[:, :3]
        compose(q, np.ascontiguousarray(delta[:, 3:]), q_new, tmp)
        q[:] = q_new
        run.mu += muR
        lam += dlam
        moved[:-1] += algo._scaled(run, delta)
        moved[-1] += dlam
    raise AssertionError("the oracle did not converge")


def test_compiled_arc_length_corrector_gives_the_python_correctors_iterates():
    """The frame with a follower force and a dead moment added (load blocks scaled to λ in the kernel): a
    corrector at fixed λ = 0.6 from the reference state, then one on the normal plane of the tangent predictor
    (bordered, λ an unknown): the compiled corrector and the oracle agree in x, q, μ, λ and the scaled path
    increment to 1e-12 (the kernel's dot products and 3×3 products go through BLAS as numpy's do; the
    load-block products may round differently), with the same number of corrections."""
    from reference.algorithms.arc_length import ArcLength

    d = frame()
    nodes = [n for n in d.nodes]
    d.add_interaction(NodalLoad(nodes[2], np.array([0.0, 0.5, -1.0]), follower=True))
    d.add_interaction(NodalLoad(nodes[4], np.array([0.2, 0.1, 0.0]), moment=True))
    model = d.initialization()
    algo = ArcLength(0.1, 3, 10.0, t_end=1.0)
    out = []
    for corrector in ("compiled", "oracle"):
        state = d.initial_conditions()
        run = algo.start(model, state)
        x, q = state.x, state.q
        step = algo._correct if corrector == "compiled" else \
            (lambda run, x, q, lam, normal: python_corrector(algo, run, x, q, lam, normal)[:3])
        code, lam, _ = step(run, x, q, 0.6, None)
        assert code == OK
        dF, muF = algo._tangent(run, x, q, lam)
        t_u = algo._scaled(run, dF)
        norm = np.sqrt(t_u @ t_u + 1.0)
        dlam = 0.3 / norm
        x += dlam * dF[:, :3]
        qn = np.empty_like(q)
        compose(q, np.ascontiguousarray(dlam * dF[:, 3:]), qn, np.empty(4))
        q[:] = qn
        run.mu += dlam * muF
        code, lam, moved = step(run, x, q, lam + dlam, np.append(t_u, 1.0) / norm)
        assert code == OK
        out.append((x.copy(), q.copy(), run.mu.copy(), lam, moved))
    (xc, qc, mc, lc, sc), (xo, qo, mo, lo, so) = out
    diff = max(np.abs(xc - xo).max(), np.abs(qc - qo).max(), abs(lc - lo), np.abs(sc - so).max(),
               np.abs(mc - mo).max() / np.abs(mo).max())
    print(f"compiled against Python corrector: largest difference {diff:.1e} (λ = {lc:.6f})")
    assert diff <= 1e-12 and abs(lc - 0.6) > 1e-3
