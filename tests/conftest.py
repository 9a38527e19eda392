"""Shared builders for the tests."""

from __future__ import annotations

import os

# One BLAS thread per test process: `make test` runs one pytest-xdist worker per core, and BLAS threads on top
# of them oversubscribe the cores (a 198-coordinate static path's dense stability counts, LDLᵀ of the
# tangent at every load level, ran 0.7–1.3 s instead of 0.02 s on a loaded two-core machine).  Set before
# numpy loads OpenBLAS; the subprocesses the tests start inherit it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# numba's thread pool: at least three threads, so that tests/test_parallel_steps.py can run the parallel loops
# on 1, 2 and 3 of them (the runs themselves use FLEXMBS_THREADS or reference.jit.threads(), capped at the cores)
os.environ.setdefault("NUMBA_NUM_THREADS", str(max(3, os.cpu_count() or 1)))

import numpy as np  # noqa: E402
import pytest

from reference.domain import Domain
from reference.elements import Section


def cantilever(n_elements: int, section: Section, length: float = 1.0, axis2=(0.0, 1.0, 0.0)):
    """A straight cantilever along +x clamped at x = 0: ``(domain, nodes)``."""
    from reference.interactions import Clamp

    d = Domain("cantilever")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (length, 0.0, 0.0), n_elements, section, axis2=axis2)
    d.add_interaction(Clamp(nodes[0]))
    return d, nodes


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
