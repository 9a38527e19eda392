"""The reference path: the model and its algorithms in plain NumPy, from the same generated physics.

The compiled path (:mod:`reference.algorithms`, numba) inlines the whole model evaluation into each
algorithm's kernel; this package writes the same equations once more, to be read and to check the fast path
against (tests/test_two_paths.py), and runs short jobs without compiling anything (``[solver] backend``).

- :mod:`reference.plain.model`: :class:`~reference.plain.model.Evaluation`, the equations of one model (forces,
  joints' rows, tangent, mass), from :mod:`reference.plain.elements`, :mod:`reference.plain.loads` and
  :mod:`reference.plain.constraints`, which call the generated functions of ``reference/generated/`` through
  :mod:`reference.plain.vectorise` (every element at once, no numba);
- :mod:`reference.plain.park`: one step of Park's staggered algorithm, a function per stage of the paper's
  Fig. 10; the implicit and linear algorithms: :mod:`reference.plain.algorithms` (their twins);
- :mod:`reference.plain.backend`: which path runs a job (``compiled``, ``reference``, ``auto``) and
  :mod:`reference.plain.outputs`, the records' derived outputs on this path.

No kernel module imports this package, so editing it recompiles nothing.
"""
