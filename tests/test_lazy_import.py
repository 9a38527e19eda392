"""A process imports what its command needs (issue 36: a warm ``flexmbs run`` spent most of its time importing).

``reference`` and ``reference.algorithms`` resolve their public names on first use (PEP 562 ``__getattr__``,
and the algorithm registry :data:`reference.algorithms.ALGORITHMS` from ``"module:Class"`` strings): importing
the engine loads neither numba nor an algorithm, and reading a deck loads the algorithm it names and not the
others.  Each check runs in a fresh interpreter, since this process has imported everything already.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

ALGORITHM_MODULES = ("reference.algorithms.staggered", "reference.algorithms.static",
                     "reference.algorithms.generalized_alpha", "reference.algorithms.linear",
                     "reference.algorithms.arc_length")
"""The modules that define the registry's algorithms (:data:`reference.algorithms.WHERE`)."""


def loaded(code: str) -> set[str]:
    """The modules a fresh interpreter has imported after running ``code`` (``python -c``)."""
    script = f"{code}\nimport sys\nprint(sorted(sys.modules))"
    out = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=600,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr[-2000:]
    return set(ast.literal_eval(out.stdout.strip().splitlines()[-1]))


def test_importing_the_engine_loads_no_numba_and_no_algorithm():
    """``import reference`` and ``import reference.algorithms`` load the registry's strings only: no numba (whose
    import alone is most of a second on a loaded machine) and none of the algorithms' modules."""
    modules = loaded("import reference, reference.algorithms")
    assert "numba" not in modules and "scipy" not in modules
    assert not modules & set(ALGORITHM_MODULES)


@pytest.mark.parametrize("deck, algorithm", [("embedded_beam_static", "reference.algorithms.static"),
                                             ("three_bar", "reference.algorithms.staggered")])
def test_reading_a_deck_loads_its_algorithm_and_not_the_others(deck, algorithm):
    """The deck reader looks the deck's algorithm up by name: its module is imported; the explicit step, the
    generalized-α integrator and the arc length are not, unless named (the static algorithm imports the arc length,
    which traces a limit point it reaches: reference.algorithms.limit_point).  Two compiled decks: a deck on ``backend = "auto"`` loads every algorithm while the reader
    checks the backend, since reference.plain.backend's list of twins imports them all."""
    modules = loaded(f"from reference.io.deck import load_deck\nload_deck('models/{deck}.toml').domain.algorithm()")
    assert algorithm in modules
    others = {"reference.algorithms.staggered", "reference.algorithms.generalized_alpha",
              "reference.algorithms.arc_length", "reference.algorithms.static",
              "reference.algorithms.linear"} - {algorithm}
    if algorithm == "reference.algorithms.static":
        others.discard("reference.algorithms.arc_length")  # static traces a limit point by arc length
    assert not modules & others, sorted(modules & others)


def test_the_registry_and_the_packages_names_resolve_to_what_they_name():
    """Every registry entry is the class whose ``name`` is its key; every name in ``__all__`` of the two packages
    resolves (an entry that pointed at a moved class would fail here, not in a user's run); an unknown name is an
    AttributeError, as for any module."""
    import reference
    import reference.algorithms as algorithms
    from reference.algorithms.base import Algorithm

    for name, cls in algorithms.ALGORITHMS.items():
        assert issubclass(cls, Algorithm) and cls.name == name
    assert len(algorithms.ALGORITHMS) == len(algorithms.WHERE) == 6
    for package in (reference, algorithms):
        for name in package.__all__:
            assert getattr(package, name) is not None, name
        assert set(package.__all__) <= set(dir(package))
        with pytest.raises(AttributeError):
            getattr(package, "no_such_name")
    assert algorithms.ALGORITHMS["static"] is algorithms.Static
    with pytest.raises(KeyError):
        algorithms.ALGORITHMS["no_such_algorithm"]
