"""flexmbs reference engine: the paper's computational engine in readable Python.

The entry point is :class:`reference.domain.Domain`.
"""

from reference.domain import Domain

__all__ = ["Domain"]
