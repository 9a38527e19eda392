"""The compile profile charges numba's compile time to the dispatcher and phase it was spent in
(reference/compile_profile.py, docs/benchmarks.md §18)."""

from __future__ import annotations

import time

import numba
import pytest
from numba.core import codegen

from reference.compile_profile import LLVM_STEPS, CompileProfile

pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing compiles with NUMBA_DISABLE_JIT=1")


def test_a_callee_is_charged_to_itself_and_every_second_once():
    """A kernel and the kernel it calls (compiled inside the caller's type inference), both new to this
    process and not cached: each is charged its own numba passes and LLVM steps; the charged seconds add up to
    no more than the wall time of the compilation (each second goes to one frame only); the numba methods
    the profile wraps are restored on exit."""

    @numba.njit
    def callee(x):
        return x * x + 1.0

    @numba.njit
    def caller(x):
        return callee(x) + callee(2.0 * x)

    originals = {name: codegen.CPUCodeLibrary.__dict__[name] for name in LLVM_STEPS}
    start = time.perf_counter()
    with CompileProfile() as profile:
        assert caller(3.0) == 10.0 + 37.0
    wall = time.perf_counter() - start
    assert {name: codegen.CPUCodeLibrary.__dict__[name] for name in LLVM_STEPS} == originals

    names = {name.rsplit(".", 1)[-1]: name for name in profile.seconds}
    assert {"caller", "callee"} <= set(names)
    for short in ("caller", "callee"):
        phases = profile.seconds[names[short]]
        assert phases["numba: nopython_type_inference"] > 0.0
        assert phases["numba: native_lowering"] > 0.0
        assert phases["llvm: function passes"] > 0.0 and phases["llvm: module passes"] > 0.0
        assert len(profile.signatures[names[short]]) == 1
    # every charged second lies inside the profiled block, and none is charged twice (1 ms: timer resolution)
    assert sum(profile.phases().values()) <= wall + 1e-3
    assert "caller" in profile.table() and "numba: nopython_type_inference" in profile.table()
