"""Shared builders for the tests."""

from __future__ import annotations

import numpy as np
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
