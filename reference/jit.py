"""The one place that decides how hot kernels are compiled.

Kernels are plain Python functions decorated with :func:`kernel`; numba
compiles them (cached on disk) unless ``NUMBA_DISABLE_JIT=1`` is set, in which
case they run as ordinary Python — slower, but every line can be stepped
through in a debugger.  numba reads that variable itself.
"""

from __future__ import annotations

import numba


def kernel(func):
    """Compile ``func`` in nopython mode with an on-disk cache."""
    return numba.njit(cache=True, fastmath=False)(func)
