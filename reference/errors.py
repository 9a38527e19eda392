"""The error a run raises when it fails, apart from the solution loop that raises it.

:meth:`reference.domain.Domain.solve_at` and the solution loop (:func:`reference.solution.solve`) both raise
:class:`SolverDiverged`; the command line and the cross-check catch it.  It is its own module so that the Domain,
which raises it, does not import the loop.
"""

from __future__ import annotations


class SolverDiverged(RuntimeError):
    """The run failed or blew up; the results written so far are kept."""
