"""The one place that decides how hot kernels are compiled.

Kernels are plain Python functions decorated with :func:`kernel`; numba
compiles them (cached on disk) unless ``NUMBA_DISABLE_JIT=1`` is set, in which
case they run as ordinary Python — slower, but every line can be stepped
through in a debugger.  numba reads that variable itself.

numba counts references to arrays with atomic updates: passing an array
view (``x[i]``, ``w[0:12]``) or the Model (a tuple of some seventy arrays) to a
compiled function, or reading ``model.nodes.free`` inside a loop, costs two atomic
updates per array and call or iteration — more than the Beam2 element's
arithmetic and most of a joint's step (docs/benchmarks.md §5).  So the step's
helpers are :func:`inlined` (the same Python function compiled to be inlined
where it is called; numba then drops the updates), and a kernel binds the
Model's arrays it needs to local names once, before its loops.  An inlined
helper's arguments still cost the updates, once per call, for every array in
them: a helper called every step or every Newton iteration takes the Model's
groups it needs (``model.nodes``, ``model.loads``, …), not the Model: a helper that takes the
Model pays the updates of all its arrays at every call, even one that does nothing with them
(:func:`reference.evaluation.forces.model_forces`; docs/benchmarks.md §10).

Loops over independent items are :func:`parallel_kernel` loops (``prange``): every element family's
element loop and tangent blocks, the explicit step's node loops (kick, drift, the step's sums, the
force reset, the element → node gather) and the implicit residual's and tangent's node loops.  Their
results never depend on the thread count, by the rules of :mod:`reference.parallel`: a parallel loop
writes per-item rows only, the element → node accumulation is a per-node gather in element order, and
sums are taken over fixed chunks whose partial sums are added in order.  Whether a loop takes its
parallel form depends on the model's size only (``reference.parallel.PARALLEL_NODES``,
``reference.elements.driver.PARALLEL_ELEMENTS``).  Joints, master/slave joints, loads and force elements stay
serial.  A Beam2 mesh below
``PARALLEL_NODES`` nodes takes its element loop and its element → node sum in one serial pass (no parallel
launch, no round trip of the rows through the work array; :func:`reference.elements.beam2_blocks.soa_forces`).
The choice is the model's size, never the thread count read inside a kernel: ``numba.get_num_threads()`` in
compiled code makes every kernel that inlines it uncacheable (numba: "dynamic globals"), and each run then
compiles the step again.

An index the compiler cannot prove non-negative (``u[u0 + e]`` with ``u0`` an argument) costs numba's
negative-index wrap-around select on every access, and in a loop meant to vectorise, the vectorisation: a
vector kernel takes its own arrays (a row ``blocked[b]``) rather than an offset into a larger one.

**Thread count** (:func:`threads`): ``FLEXMBS_THREADS`` when set (the override, capped at numba's
pool, ``NUMBA_NUM_THREADS``); otherwise every core the process may use (:func:`available_cores`) for a
model of at least :data:`DEFAULT_PARALLEL_NODES` nodes, and one thread below: a small model's loop
costs about what starting a parallel region costs, so it gains little from a second thread
(docs/benchmarks.md §5).  The crossover itself needs an idle core to be measured, so the threshold is
chosen on the high side.  On a machine shared with other jobs set ``FLEXMBS_THREADS=1``: a thread that
another process holds up stalls every parallel region, and a two-thread step then costs more than the
one-thread step.

Calling a compiled kernel from Python unboxes its arguments, and numba does that markedly
slower for named tuples than for plain nested tuples of the same arrays (docs/benchmarks.md §10).  The implicit
algorithms make hundreds of such calls per solve (an evaluation, a factorisation, a chunk of
steps, the derived outputs of a record), so those kernels take their named tuples through
:func:`boundary` (the same arrays as plain nested tuples, made once per run by the caller) and name them
again on entry with :func:`named`, which costs nothing in compiled code (a copy of pointers;
on a named tuple it is the identity).  So does the explicit step kernel, called once per output
(:meth:`reference.algorithms.staggered.ExplicitRun.arguments`).

numba's on-disk cache checks only the source file that defines a function, not the files of the
functions it calls and inlines: after an edit of, say, ``reference/interactions.py`` the cached step kernel
of ``reference/algorithms/staggered.py`` would silently keep running the old time functions.  So every
kernel here is cached by :mod:`reference.kernel_cache`, keyed by the engine modules its own module imports
(directly or not) and by the element families it is compiled for: an edit compiles again the kernels that
can reach the edited file, and only those.  ``NUMBA_CACHE_DIR`` moves the cache folder.
"""

from __future__ import annotations

import os
import time

import numba
import numba.core.event
import numpy as np
from numba import prange, types
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic

from reference.kernel_cache import ROOT as CACHE_ROOT, enable as cached

__all__ = ["CompileTimer", "available_cores", "boundary", "kernel", "inlined", "named", "parallel_kernel", "prange",
           "threads", "use_threads", "vector_kernel"]

THREADS_ENV = "FLEXMBS_THREADS"
DEFAULT_PARALLEL_NODES = 8192
"""Nodes from which a run takes every available core by default (below it, one thread); see the
module docstring."""


if not os.environ.get("NUMBA_CACHE_DIR"):
    numba.config.CACHE_DIR = str(CACHE_ROOT)


class CompileTimer(numba.core.event.Listener):
    """Wall time [s] numba spends compiling kernels while it listens (``with CompileTimer() as timer:``).

    It counts the outermost ``numba:compile`` events only (a kernel compiles the kernels it calls inside
    its own event); loading a kernel from the on-disk cache is not compilation and is not counted.
    ``announce`` (no arguments) is called once, when the first compilation starts: on a first run, the
    command line says why nothing seems to happen for a minute.
    """

    def __init__(self, announce=None):
        self.seconds, self.kernels, self._depth, self._start, self._announce = 0.0, 0, 0, 0.0, announce

    def on_start(self, event) -> None:
        if self._depth == 0:
            if self._announce is not None:
                self._announce()
                self._announce = None
            self._start = time.perf_counter()
        self._depth += 1

    def on_end(self, event) -> None:
        self._depth -= 1
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._start
            self.kernels += 1

    def __enter__(self) -> "CompileTimer":
        numba.core.event.register("numba:compile", self)
        return self

    def __exit__(self, *exc) -> None:
        numba.core.event.unregister("numba:compile", self)


def kernel(func):
    """Compile ``func`` in nopython mode with an on-disk cache."""
    return cached(numba.njit(fastmath=False)(func))


def inlined(func):
    """``func`` (a :func:`kernel` or a plain function) compiled to be inlined at every call site.

    With ``NUMBA_DISABLE_JIT=1`` it is the plain Python function.
    """
    py_func = getattr(func, "py_func", func)
    if numba.config.DISABLE_JIT:
        return py_func
    return cached(numba.njit(fastmath=False, inline="always")(py_func))


def vector_kernel(func):
    """:func:`kernel` for loops the compiler is to vectorise across elements (``generated/beam2_soa.py``):
    numpy's error model, so that a float division carries no zero-divisor check and exception branch
    (which keeps LLVM from vectorising the loop); x/0 gives inf or nan instead of raising. The same
    IEEE arithmetic otherwise: results are bit for bit those of :func:`kernel`."""
    return cached(numba.njit(fastmath=False, error_model="numpy")(func))


def parallel_kernel(func):
    """Compile ``func`` with its ``prange`` loops parallel (numba ``parallel=True``), cached."""
    return cached(numba.njit(fastmath=False, parallel=True)(func))


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity), at most the threads numba starts."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, numba.config.NUMBA_NUM_THREADS))


def threads(nodes: int | None = None) -> int:
    """Threads of the parallel kernels: ``FLEXMBS_THREADS`` if set (at most the cores numba uses), else
    :func:`available_cores` for a model of at least :data:`DEFAULT_PARALLEL_NODES` nodes and 1 for a
    smaller one (or when ``nodes`` is not given).

    Raises
    ------
    ValueError
        When the variable is not a positive integer.
    """
    text = os.environ.get(THREADS_ENV, "").strip()
    if not text:
        return available_cores() if nodes is not None and nodes >= DEFAULT_PARALLEL_NODES else 1
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"{THREADS_ENV}={text!r}: expected a positive integer (threads of the parallel kernels)")
    return min(int(text), numba.config.NUMBA_NUM_THREADS)


def use_threads(n: int | None = None, nodes: int | None = None) -> int:
    """Set the parallel kernels' thread count for the calling thread (default :func:`threads` for a model of
    ``nodes`` nodes); return it."""
    n = threads(nodes) if n is None else max(1, min(int(n), numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(n)
    return n


try:  # for the importing thread; ``Algorithm.advance`` sets it again for the thread it runs on
    use_threads()
except ValueError:  # a bad FLEXMBS_THREADS is reported where the thread count is used
    pass


_TYPES: dict = {}
"""Key of an object's numba type (:func:`_plain`) → (numba type of its plain copy, its own numba type)."""
_NAMED_TYPES: dict = {}
"""(numba type of a plain copy made by :func:`boundary`, the named tuple's class) → its numba type
(two classes may have the same plain type)."""


TAG = "_plain_tag"
"""A named tuple class with this attribute set (to a unique name) keeps a tag in its plain copy."""


def _tag(cls) -> np.ndarray:
    """An empty array whose record dtype carries the class's tag: it makes the plain type unique."""
    return np.empty(0, dtype=np.dtype([(getattr(cls, TAG), np.uint8)]))


def _plain(obj):
    """``obj`` with every (named) tuple in it a plain tuple, and a key of its numba type.

    Two named tuple classes of the same field types have the same plain type, so a kernel compiled for
    one would be taken for the other (in the process and from the on-disk cache): the element families'
    data are such classes (``conn``, ``index``, ``offset``, … of the same dimensions).  A class with
    :data:`TAG` set gets, as its first item, an empty array whose record dtype is named by the tag.
    """
    if isinstance(obj, tuple):
        parts = [_plain(e) for e in obj]
        plain = tuple(p for p, _ in parts)
        if getattr(type(obj), TAG, None):
            plain = (_tag(type(obj)),) + plain
        return plain, (type(obj), tuple(k for _, k in parts))
    if isinstance(obj, np.ndarray):
        f = obj.flags
        return obj, (obj.dtype.str, obj.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    return obj, type(obj)


def boundary(obj):
    """``obj`` (a named tuple of arrays, scalars and named tuples) as plain nested tuples of the same
    arrays, for a kernel that calls :func:`named` on it; the identity with ``NUMBA_DISABLE_JIT=1``.

    The arrays are shared: what the kernel writes into them, ``obj`` sees.  Making the copy walks the
    whole Model (docs/benchmarks.md §10): a caller that passes the same object again keeps its copy
    (nothing here keeps the object, or its arrays, alive).
    """
    if numba.config.DISABLE_JIT:
        return obj
    plain, key = _plain(obj)
    if key not in _TYPES:
        _TYPES[key] = numba.typeof(plain), numba.typeof(obj)
        _NAMED_TYPES[_TYPES[key][0], type(obj)] = _TYPES[key][1]
    return plain


def _rebuild(context, builder, plain_type, named_type, value):
    if isinstance(named_type, types.BaseTuple):
        plain_items = tuple(plain_type)
        skip = len(plain_items) - len(named_type)  # 1: the tag of a tagged class (:func:`_plain`)
        items = [_rebuild(context, builder, p, n, builder.extract_value(value, i + skip))
                 for i, (p, n) in enumerate(zip(plain_items[skip:], named_type))]
        return context.make_tuple(builder, named_type, items)
    return value


@intrinsic
def _named(typingctx, value, cls):
    if isinstance(value, types.BaseNamedTuple):
        target = value
    else:
        target = _NAMED_TYPES.get((value, getattr(cls, "instance_class", None)))
    if target is None:
        return None  # not made by boundary() from a ``cls``: numba reports a typing error

    def codegen(context, builder, signature, arguments):
        result = _rebuild(context, builder, signature.args[0], signature.return_type, arguments[0])
        return impl_ret_borrowed(context, builder, signature.return_type, result)

    return target(value, cls), codegen


def _same(value, cls):
    return value


named = _same if numba.config.DISABLE_JIT else _named
"""``named(value, cls)`` inside a kernel: the ``cls`` named tuple that ``value`` (made by
:func:`boundary`) stands for; a named tuple passes unchanged.  With ``NUMBA_DISABLE_JIT=1``:
the identity."""
