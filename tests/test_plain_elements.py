"""The reference path's elements (reference/plain/vectorise.py, reference/plain/elements.py) against the engine's.

The NumPy twins of the generated helpers against the scalar functions, branch by branch; then every element
family's forces, strain energy, tangent and section resultants on gallery decks, at rest and in a deformed and
rotated configuration, against the engine's evaluation kernels that inline the families' calls
(:mod:`reference.elements.families`: ``assemble_forces``, ``tangent_values``, ``resultants``; :func:`engine`).
Beam2's run compiled, in this process.  beam2_se3's and beam3's compile for minutes cold for their own family
data (tests/test_families.py says why), so their comparison runs once in a subprocess with the engine uncompiled
(``NUMBA_DISABLE_JIT=1``): the same family code, interpreted.  This module is also that subprocess's script.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import LEE_FRAME_BEAM2
from reference.io.deck import load_deck

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"

TOLERANCE = 1e-12
"""Relative agreement with the engine's element code (the brief of the reference path): the same generated
arithmetic, element-wise on arrays; NumPy's sin, cos, sqrt, arctan2 and ** may differ from the C library's
in the last bit, and cancellation in a strained element's forces can amplify that a few times.  Measured:
forces and energies equal bit for bit, tangents within 3e-16 of their largest entry."""

CASES = {
    # deck, overrides: Beam2 straight beams between rigid bodies (4 elements: the per-element loops of both paths)
    "three_bar": ("three_bar.toml", {}),
    # two arcs: section frames offset from the node frames (the curved mesh and the 'mid' node's identity frame)
    "curved_cantilever": ("curved_cantilever.toml", {}),
    # 80 elements (the deck's former Beam2 mesh): the vectorised block loop and the parallel tangent of the
    # compiled family
    "lee_frame": ("lee_frame.toml", LEE_FRAME_BEAM2),
    "curved_beam2_se3": ("curved_cantilever.toml", {"beams.0.element": "beam2_se3", "beams.1.element": "beam2_se3",
                                                    "solver.algorithm": "generalized_alpha"}),
    "three_bar_beam2_se3": ("three_bar.toml", {"beams.1.element": "beam2_se3",
                                               "solver.algorithm": "generalized_alpha"}),
    "curved_beam3": ("curved_cantilever.toml", {"beams.0.element": "beam3", "beams.1.element": "beam3",
                                                "solver.algorithm": "generalized_alpha"}),
    "three_bar_beam3": ("three_bar.toml", {"beams.1.element": "beam3", "solver.algorithm": "generalized_alpha"}),
}
COMPILED = ("three_bar", "curved_cantilever", "lee_frame")
"""The Beam2 cases, compared in this process with the compiled kernels."""
OUTSIDE = "truss"
"""A family registered from outside the engine with a reference-path adapter of its own (:class:`TrussTwin`):
tests/test_element_families.py's toy truss, no section frames (its data have no offsets)."""


def deformed(x, q, seed: int = 1):
    """A deformed and rotated configuration: each node moved by 3 % of the model's extent and turned by a
    random rotation (0.3 rad) on top of a common one (1.4 rad), ``q ⊗ exp(ψ)``."""
    from reference.generated import rotation_maps as rm
    from reference.plain.vectorise import plain

    rng = np.random.default_rng(seed)
    psi = 0.3 * rng.normal(size=(len(q), 3)) + np.array([0.4, -0.7, 1.1])
    turn, out = np.empty((4, len(q))), np.empty((4, len(q)))
    plain(rm.exp_quaternion)(psi.T, turn)
    plain(rm.quat_product)(np.asarray(q, dtype=float).T, turn, out)
    return x + 0.03 * np.ptp(x) * rng.normal(size=x.shape), out.T.copy()


def engine(model, x, q):
    """The engine's compiled evaluation, the families' calls inlined in it: ``S`` (N, 6) and U of the implicit
    algorithms' evaluation (:class:`reference.algorithms.implicit.NewtonSystem`, static, λ = 0), the element
    blocks of its Newton matrix with ``(c_m, c_c, c_k) = (0, 0, 1)`` on the free coordinates (ψ = 0), and the
    section resultants ``N``, ``M`` (E, 3) a run records (:func:`reference.outputs.derived_outputs`).  The cases
    have no force elements and no follower loads, so these are the elements' alone (λ = 0: no joint Hessian).
    These kernels are the ones the implicit algorithms and every run compile anyway: nothing compiles for this
    test alone."""
    from reference.algorithms.implicit import NewtonSystem
    from reference.jit import boundary
    from reference.joints.reactions import scratch
    from reference.outputs import OutputArrays, derived_outputs
    from reference.state import element_work

    assert model.force_elements.kind.shape[0] == 0 and not np.isin(model.loads.code, (1, 2)).any()
    N, m, J = len(x), model.n_constraints, model.joints.i.shape[0]
    system = NewtonSystem(model)
    U = system.evaluate(x, q, np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 6)), np.zeros(m), 0.0, False)
    K = system.matrix(x, q, np.zeros((N, 3)), 0.0, np.zeros(m), 0.0, 0.0, 1.0, ce=0.0).tocsr()
    forces, moments = np.zeros((model.n_elements, 3)), np.zeros((model.n_elements, 3))
    derived_outputs(boundary(OutputArrays(model.joints, model.time_functions, model.elements)), x, q, np.zeros(m),
                    0.0, np.arange(J), (np.zeros((J, 3)), np.zeros((J, 3)), forces, moments), element_work(model),
                    scratch(), np.zeros(model.n_elements))
    return system.work.S.copy(), U, K[:system.n_free, :system.n_free].toarray(), forces, moments, system.free


class TrussTwin:
    """The toy truss's adapter (the contract of :mod:`reference.plain.elements`): axial force
    ``N = EA (ℓ − L0)/L0`` along the chord ``d = x2 − x1``, energy ``½ EA L0 ε²``, tangent
    ``N/ℓ (I − n nᵀ) + EA/L0 n nᵀ`` (``n = d/ℓ``), in NumPy over the elements at once."""

    @staticmethod
    def _chord(data, sl, x):
        d = x[1] - x[0]
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        strain = (length - data.L0[sl]) / data.L0[sl]
        return d, length, strain, data.EA[sl] * strain

    def evaluate(self, data, sl, x, p):
        d, length, strain, N = self._chord(data, sl, x)
        s, axial = np.zeros((12, d.shape[1])), np.zeros((3, d.shape[1]))
        s[0:3], s[6:9], axial[0] = -(N * d) / length, N * d / length, N
        return s, 0.5 * data.EA[sl] * data.L0[sl] * strain * strain, axial, np.zeros_like(axial)

    def tangent(self, data, sl, x, p):
        d, length, _, N = self._chord(data, sl, x)
        nn = d[:, None] * d[None, :] / length**2
        k = N / length * (np.eye(3)[:, :, None] - nn) + data.EA[sl] / data.L0[sl] * nn
        K = np.zeros((12, 12, d.shape[1]))
        K[0:3, 0:3], K[6:9, 6:9], K[0:3, 6:9], K[6:9, 0:3] = k, k, -k, -k
        return K


def domain_of(case: str):
    """The case's Domain (:data:`CASES`; :data:`OUTSIDE`: the truss, its class given :class:`TrussTwin`)."""
    if case == OUTSIDE:
        from test_element_families import Truss, truss_domain

        Truss.plain = TrussTwin()
        return truss_domain("static")
    deck, overrides = CASES[case]
    return load_deck(MODELS / deck, overrides=overrides).domain


def errors(case: str) -> dict:
    """The reference path against :func:`engine` in the case's configurations: per configuration the largest
    difference of the forces, energy and resultants relative to their largest value in the deformed
    configuration (at rest they are round-off of zero), and of the tangent (free coordinates) relative to its
    own largest entry; with the sizes compared."""
    from reference.plain.elements import element_forces, element_resultants, element_tangent

    domain = domain_of(case)
    model, state = domain.model, domain.initial_conditions()
    configurations = {"rest": (state.x, state.q), "deformed": deformed(state.x, state.q)}
    ours, theirs = {}, {}
    for name, (x, q) in configurations.items():
        x, q = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(q, dtype=float)
        theirs[name] = engine(model, x, q)
        free = theirs[name][-1].reshape(-1)
        S, U = element_forces(model, x, q)
        forces, moments = element_resultants(model, x, q)
        ours[name] = (S, U, element_tangent(model, x, q)[free][:, free].toarray(), forces, moments)
    scale = [max(float(np.abs(a).max()), 1e-300) for a in theirs["deformed"][:5]]
    out = {"families": sorted({type(d).__name__ for d in model.elements if d.conn.shape[0]}),
           "elements": model.n_elements}
    for name in configurations:
        for k, key in enumerate(("forces", "energy", "tangent", "section_force", "section_moment")):
            a, b = np.asarray(ours[name][k]), np.asarray(theirs[name][k])
            reference = max(float(np.abs(b).max()), 1e-300) if key == "tangent" else scale[k]
            out[f"{name}_{key}"] = float(np.abs(a - b).max()) / reference
        out[f"{name}_scale_tangent"] = float(np.abs(theirs[name][2]).max())
    out["deformed_scale_forces"] = scale[0]
    return out


def check(result: dict) -> None:
    assert result["elements"] > 0
    assert result["deformed_scale_forces"] > 0.0 and result["deformed_scale_tangent"] > 0.0  # not zeros against zeros
    for key, value in result.items():
        if key.startswith(("rest_", "deformed_")) and "_scale_" not in key:
            assert value <= TOLERANCE, (key, value)


@pytest.mark.parametrize("case", COMPILED)
def test_beam2_against_the_compiled_family(case):
    result = errors(case)
    assert result["families"] == ["Beam2Data"]
    check(result)


@pytest.fixture(scope="module")
def uncompiled():
    from test_families import uncompiled_json

    return uncompiled_json(str(Path(__file__).resolve()), *[c for c in CASES if c not in COMPILED], OUTSIDE,
                           timeout=600)


@pytest.mark.parametrize("case", [c for c in CASES if c not in COMPILED])
def test_other_families_against_the_family_code(uncompiled, case):
    result = uncompiled[case]
    family = "Beam2SE3Data" if "se3" in case else "Beam3Data"
    assert family in result["families"]
    check(result)


def test_a_family_from_outside_with_its_own_adapter(uncompiled):
    """A family registered from outside the engine runs on the reference path with nothing but its adapter:
    the truss's forces, energy, tangent and axial forces equal its own family calls' (:class:`TrussTwin` is the
    same formulas in NumPy: 1e-12 relative, as the engine's families)."""
    result = uncompiled[OUTSIDE]
    assert result["families"] == ["TrussData"] and result["elements"] == 2
    check(result)


HELPERS = [("rotation_maps", name) for name in ("c_sinc", "c_cosc", "c_sinc3", "c_jinv", "c_asinc", "branch_sign")]
HELPERS += [("tangents", name) for name in ("c_cosc_d", "c_sinc3_d", "c_jinv_d")]
HELPERS += [("beam3", name) for name in ("c_sinc_d", "c_sinc_dd", "c_cosc_dd", "c_sinc3_dd")]
HELPERS += [("beam2_se3", "c_jinv_dd")]


CANCELLING = {"c_jinv_dd": 1e-13}
"""Helpers whose exact formula cancels so much that one ulp of ``cos`` moves it by more than a few ulps:
c_jinv_dd's numerator (terms of order a⁴ summing to order a⁶/3780 · 2a⁶(1 − cos a)²) measured 2.0e-14 of the
largest value at |a| = 2.4; the twin and the scalar function differ only in NumPy's ``cos`` against the C
library's."""


@pytest.mark.parametrize("module, name", HELPERS)
def test_helper_twins_take_each_elements_branch(module, name):
    """The select-rewritten twin of a branched helper (its series near 0, the exact formula beyond) against the
    scalar function at points of every branch, their thresholds and 0: within 4e-16 of the largest value (NumPy's
    sin and cos against the C library's in the exact formulas; measured at most 2.4e-16), :data:`CANCELLING`'s
    bound for those helpers."""
    import importlib

    from reference.plain.vectorise import plain

    function = getattr(importlib.import_module(f"reference.generated.{module}"), name)
    scalar = getattr(function, "py_func", function)
    rng = np.random.default_rng(3)
    a = np.concatenate([[0.0, -0.0, 0.029, 0.045, 0.05, 0.1, 1.0, 2.0, -1.0], rng.uniform(-0.12, 0.12, 200),
                        rng.uniform(-3.0, 3.0, 200)])
    expected = np.array([scalar(float(v)) for v in a])
    got = plain(function)(a)
    assert got.shape == a.shape and np.all(np.isfinite(got))
    assert np.abs(got - expected).max() <= CANCELLING.get(name, 4e-16) * np.abs(expected).max()


def test_atan2_quadrant_twin():
    """``atan2_quadrant``'s argument reduction (three selects and a swap) element by element, both arguments 0
    included: bit for bit the scalar function (the same arithmetic; no library call)."""
    from reference.generated import rotation_maps as rm
    from reference.plain.vectorise import plain

    rng = np.random.default_rng(4)
    y, x = np.abs(rng.normal(size=500)), np.abs(rng.normal(size=500))
    y[:3], x[2:5] = 0.0, 0.0
    expected = np.array([rm.atan2_quadrant.py_func(float(a), float(b)) for a, b in zip(y, x)])
    assert np.array_equal(plain(rm.atan2_quadrant)(y, x), expected)


def test_every_generated_function_has_an_array_twin():
    """Every function of reference/generated/ is straight-line code (its twin is its own code object, rebound)
    or a helper whose branches are rewritten into selects: none falls back to the element-by-element loop."""
    import importlib
    import types

    from reference.plain.vectorise import plain

    seen = 0
    for module in ("rotation_maps", "tangents", "beam2", "beam2_se3", "beam3", "forces", "joints"):
        generated = importlib.import_module(f"reference.generated.{module}")
        for value in vars(generated).values():
            function = getattr(value, "py_func", value)
            if isinstance(function, types.FunctionType) and function.__module__ == generated.__name__:
                twin = plain(value)
                assert not getattr(twin, "element_by_element", False), function.__name__
                seen += 1
    assert seen >= 40


def test_few_elements_take_the_element_loop():
    """:func:`~reference.plain.vectorise.twin` loops over fewer than LOOP_BELOW elements with the scalar function
    and vectorises from there on; both give Beam2's forces, strains and energy of the same 12 elements within
    1e-15 of their largest value (the loop calls the C library's sin, cos and sqrt, the vector twin NumPy's)."""
    from reference.generated import beam2
    from reference.plain.vectorise import LOOP_BELOW, element_loop, plain, twin

    assert twin(beam2.internal_forces, LOOP_BELOW - 1) is element_loop(beam2.internal_forces)
    assert twin(beam2.internal_forces, LOOP_BELOW) is plain(beam2.internal_forces)
    rng = np.random.default_rng(5)
    E = 12
    q1, q2 = rng.normal(size=(4, E)), rng.normal(size=(4, E))
    inputs = (rng.normal(size=(3, E)), rng.normal(size=(3, E)), q1 / np.linalg.norm(q1, axis=0),
              q2 / np.linalg.norm(q2, axis=0), rng.uniform(0.5, 2.0, E), 0.1 * rng.normal(size=(3, E)),
              rng.normal(size=(3, E)), rng.uniform(1.0, 10.0, (6, E)))
    results = []
    for function in (element_loop(beam2.internal_forces), plain(beam2.internal_forces)):
        s, strain, stress = np.empty((12, E)), np.empty((6, E)), np.empty((6, E))
        results.append((function(*inputs, s, strain, stress), s, strain, stress))
    for loop, vector in zip(*results):
        assert np.abs(loop - vector).max() <= 1e-15 * np.abs(vector).max()


def _nested(a, b):
    c = b
    if a > 0.0:
        c = 2.0 * b
        if a > 1.0:
            return c + a
    else:
        c, b = b - 1.0, c
    return c * b


def _looping(a):
    total = 0.0
    for k in range(3):
        total += a * k
    return total


def _running_sums(v, out):
    total = 0.0
    for k in range(3):
        total += _looping(v[k])
        out[k] = total
    return total


def test_rewrite_and_fallback():
    """A nested ``if``/``else`` with assignments and an early return is rewritten into selects with the scalar
    function's values; a loop is not rewritten, and its twin calls the scalar function element by element, the
    element's views of array arguments (its writes into an output land in the caller's array)."""
    from reference.plain.vectorise import plain

    a = np.array([-1.0, 0.0, 0.5, 1.0, 2.0, 3.0])
    b = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert not getattr(plain(_nested), "element_by_element", False)
    assert np.array_equal(plain(_nested)(a, b), [_nested(u, v) for u, v in zip(a, b)])
    assert getattr(plain(_looping), "element_by_element", False)
    assert np.array_equal(plain(_looping)(a), [_looping(u) for u in a])
    v, out = np.arange(12.0).reshape(3, 4), np.zeros((3, 4))
    totals = plain(_running_sums)(v, out)
    for e in range(4):
        expected = np.zeros(3)
        assert totals[e] == _running_sums(v[:, e], expected) and np.array_equal(out[:, e], expected)


def test_a_family_without_reference_functions_is_refused():
    from reference.plain.elements import adapter

    class Unknown:
        family = "truss_without_plain"

    with pytest.raises(ValueError, match="truss_without_plain.*no reference-path functions"):
        adapter(Unknown)


if __name__ == "__main__":
    print(json.dumps({case: errors(case) for case in sys.argv[1:]}))
