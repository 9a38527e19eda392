"""A numba kernel's plain Python form, for code that runs once while a model is built or checked.

Calling a numba dispatcher from Python compiles it on first use (seconds to minutes per kernel on a small
machine, docs/benchmarks.md "First run"); a model's rest states, its joints' redundancy check or a time
function read once need no compiled code.  :func:`scalar_twin` gives the kernel's own Python function
with every kernel it calls replaced by that kernel's Python form in turn, so that numba never compiles:
the same code on Python floats, called one item at a time (the element-wise NumPy form of the generated
physics is :func:`reference.plain.vectorise.plain`).

This module imports nothing from the engine, so any module may use it without an import cycle; the
build-time helpers of kernel modules do (the element families' rest states, :mod:`reference.joints.setup`,
the load arms of :mod:`reference.interactions`), so an edit here changes those kernels' cache keys
(:mod:`reference.kernel_cache`) and compiles them again.
"""

from __future__ import annotations

import functools
import types

import numpy as np

ENGINE = "reference."
"""The package whose modules a kernel may call into by attribute (``rm.log_quaternion``)."""


def global_names(code: types.CodeType) -> set:
    """The global names ``code`` and the code objects nested in it read."""
    found = set(code.co_names)
    for constant in code.co_consts:
        if isinstance(constant, types.CodeType):
            found |= global_names(constant)
    return found


def _is_kernel(value) -> bool:
    """True for a numba dispatcher of a Python function, or a Python function (under ``NUMBA_DISABLE_JIT``)."""
    return isinstance(getattr(value, "py_func", value), types.FunctionType)


class _ScalarModule:
    """An engine module seen by a scalar twin: its kernels read through it are their scalar twins
    (``rm.log_quaternion(…)`` in a kernel calls the Python form), every other attribute is the module's."""

    def __init__(self, module: types.ModuleType):
        self._module = module

    def __getattr__(self, name: str):
        value = getattr(self._module, name)
        return scalar_twin(value) if _is_kernel(value) else value


@functools.cache
def _scalar_module(module: types.ModuleType) -> _ScalarModule:
    return _ScalarModule(module)


@functools.cache
def scalar_twin(function) -> types.FunctionType:
    """The plain Python function of a kernel (a numba dispatcher, or the function under ``NUMBA_DISABLE_JIT``)
    with every kernel it calls replaced by its own scalar twin, recursively (also a kernel called through its
    engine module, ``rm.log_quaternion``): numba never compiles it.  For
    code run once per model or per item (rest states, the time functions, the constraints at t = 0),
    called with the kernel's own arguments."""
    py = getattr(function, "py_func", function)
    namespace = dict(py.__globals__)
    for name in global_names(py.__code__):
        value = namespace.get(name)
        if isinstance(value, types.ModuleType) and value.__name__.startswith(ENGINE):
            namespace[name] = _scalar_module(value)
        elif value is not None and value is not function and _is_kernel(value):
            namespace[name] = scalar_twin(value)
    return types.FunctionType(py.__code__, namespace, py.__name__, py.__defaults__, py.__closure__)


PYTHON_ITEMS = 512
"""Items (elements, joints) up to which :func:`build_time_form` gives the Python form: below it the Python loop
costs less than compiling the kernel; above it a model would pay the loop at every ``Domain.solve`` (which
rebuilds the model) and the compilation only once (the cost per element: docs/benchmarks.md §12)."""


def build_time_form(kernel, items: int):
    """The form of a build-time kernel for a model of ``items`` elements or joints: :func:`scalar_twin` up to
    :data:`PYTHON_ITEMS` (nothing to compile), else the compiled kernel.  Both give the same numbers bit for bit
    (tests/test_first_run.py), so the size only moves the cost."""
    return scalar_twin(kernel) if items <= PYTHON_ITEMS else kernel


REMEMBERED = 16
"""Meshes whose rest states :func:`remembered` keeps per function (the oldest is dropped first)."""


def remembered(function):
    """``function`` of float arrays returning a tuple of arrays, with its results kept for the arguments' values
    (:data:`REMEMBERED` of them): ``Domain.solve`` rebuilds the model at every call, and a study that solves one
    mesh again and again (a sweep, a benchmark, the sensitivities' runs) would otherwise evaluate its rest states
    in Python each time.  The results are the same numbers (``function`` is a function of its arguments' values);
    each call returns copies, so a caller may change them."""
    memory: dict = {}

    @functools.wraps(function)
    def call(*arrays):
        arrays = tuple(np.ascontiguousarray(a, dtype=float) for a in arrays)
        key = tuple((a.shape, a.tobytes()) for a in arrays)
        found = memory.get(key)
        if found is None:
            found = function(*arrays)
            if len(memory) >= REMEMBERED:
                memory.pop(next(iter(memory)))
            memory[key] = found
        return tuple(np.array(part, copy=True) for part in found)
    return call


__all__ = ["PYTHON_ITEMS", "REMEMBERED", "build_time_form", "global_names", "remembered", "scalar_twin"]
