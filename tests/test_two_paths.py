"""The two paths agree: every gallery deck's short horizon run on the compiled kernels and on the reference path.

The reference path (``reference/plain/``, ``[solver] backend = "reference"``) evaluates the same generated
physics in plain NumPy; the explicit step is the same arithmetic in another order (sums, the Cholesky
pivots), so the two agree to round-off: every history of the results (positions, rotations, velocities,
multipliers, energies, constraint norms, reactions, section resultants) within :data:`EXPLICIT_RTOL` of its
largest value over the run.

The implicit and linear algorithms (static, generalized-α, modes, buckling, arc length) are compared within
their Newton tolerance in tests/test_plain_implicit.py, which owns them; a deck of those is skipped here with
that reason.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from reference.io.results import Results
from reference.io.deck import load_deck

ROOT = Path(__file__).resolve().parents[1]
DECKS = sorted((ROOT / "models").glob("*.toml"))
EXPLICIT = "staggered_central_difference"

STEPS, EVERY = 40, 10
"""The short horizon: 40 steps of the deck's own step, an output every 10 (the first step's half kick, the
constraint stage and the energy bookkeeping all run; 40 steps of round-off stay near 1e-15)."""

EXPLICIT_RTOL = 1e-10
"""The explicit paths' agreement, relative to each history's largest value (issue 37; measured ≲ 1e-13: a
different order of the same sums)."""

HISTORIES = (*(name for name in Results.ARRAYS if name != "time"), "energy")


def _run(deck: Path, backend: str) -> Results:
    domain = load_deck(deck).domain
    dt = domain.solver.dt
    domain = load_deck(deck, overrides={"t_end": STEPS * dt, "solver.output_every": EVERY}).domain
    domain.solver.backend = backend
    return domain.solve()


def _floor(results: Results, name: str) -> float:
    """The physical scale of a history that may be pure round-off (a well-kept constraint, the moment of a
    spherical joint): the model's size [m] for ‖Φ‖, its speeds [m/s] (linear, and angular times the size) for
    ‖B V + Φ_t‖, the matching force times the size for a moment [N m]; 0 for every other history."""
    size = float(np.abs(results.positions).max())
    largest = lambda values: float(np.nanmax(np.abs(values), initial=0.0)) if values is not None else 0.0  # noqa: E731
    return {"constraint_violation": size,
            "velocity_constraint_violation": largest(results.velocities) + size * largest(results.angular_velocities),
            "reaction_moments": size * largest(results.reaction_forces),
            "section_moments": size * largest(results.section_forces)}.get(name, 0.0)


def _algorithm(deck: Path) -> str:
    return load_deck(deck).domain.solver.algorithm


REDUCED_DECKS = [d for d in DECKS if "reduce = " in d.read_text(encoding="utf-8")]
"""Decks with a reduced beam: they run on the reference path only (checked against the full beam and Exudyn in
tests/test_reduced_coupled.py, test_reduced_crosscheck.py and test_reduced_spinup.py)."""
EXPLICIT_DECKS = [d for d in DECKS if _algorithm(d) == EXPLICIT and d not in REDUCED_DECKS]


@pytest.mark.parametrize("deck", REDUCED_DECKS, ids=[d.stem for d in REDUCED_DECKS])
def test_a_reduced_deck_refuses_the_compiled_path_in_one_line(deck):
    """Set from the Python API too (the deck reader refuses ``backend = "compiled"`` itself): the compiled
    kernels have no reduced body, and running the full beam instead would be a silent change of model."""
    domain = load_deck(deck, overrides={"t_end": load_deck(deck).domain.solver.dt}).domain
    domain.solver.backend = "compiled"
    with pytest.raises(ValueError, match=r"^solver backend: reduced beam .* runs on the reference path only") as e:
        domain.solve()
    assert "\n" not in str(e.value)


def test_every_other_gallery_deck_is_compared_within_the_newton_tolerance():
    """The implicit and linear decks are compared on both paths in tests/test_plain_implicit.py (within the
    Newton tolerance, not round-off): each is named there."""
    implicit = (ROOT / "tests" / "test_plain_implicit.py").read_text(encoding="utf-8")
    missing = [d.stem for d in DECKS if d not in EXPLICIT_DECKS + REDUCED_DECKS and f"{d.stem}" not in implicit]
    assert not missing, f"gallery decks compared on neither path: {missing}"


@pytest.mark.parametrize("deck", EXPLICIT_DECKS, ids=[d.stem for d in EXPLICIT_DECKS])
def test_gallery_deck_on_both_paths(deck):
    compiled, plain = _run(deck, "compiled"), _run(deck, "reference")
    assert (compiled.attrs["backend"], plain.attrs["backend"]) == ("compiled", "reference")
    assert compiled.status == plain.status == "completed"
    np.testing.assert_array_equal(plain.time, compiled.time)
    for name in HISTORIES:
        ours, theirs = getattr(plain, name), getattr(compiled, name)
        pairs = [(k, ours[k], theirs[k]) for k in theirs] if name == "energy" else [(name, ours, theirs)]
        for label, a, b in pairs:
            if b is None:
                assert a is None, label
                continue
            a, b = np.asarray(a), np.asarray(b)
            assert a.shape == b.shape, label
            scale = max(np.nanmax(np.abs(b), initial=0.0), _floor(compiled, name))
            # NaN where the compiled path writes NaN (a master/slave joint's reaction), nowhere else
            np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=label)
            error = np.nanmax(np.abs(a - b), initial=0.0)
            assert error <= EXPLICIT_RTOL * scale or error <= 1e-300, f"{label}: {error:.3g} of {scale:.3g}"


def test_the_command_line_offers_the_readers_backends():
    from flexmbs.cli import BACKEND_CHOICES
    from reference.plain.backend import BACKENDS

    assert BACKEND_CHOICES == BACKENDS


def test_a_backend_the_engine_does_not_know_is_one_line_from_the_deck_and_the_api():
    from reference.io.deck_reader import DeckError

    deck = ROOT / "models" / "three_bar.toml"
    with pytest.raises(DeckError) as refused:
        load_deck(deck, overrides={"solver.backend": "numba"})
    assert "solver.backend: unknown backend 'numba'" in str(refused.value) and "\n" not in str(refused.value)
    domain = load_deck(deck, overrides={"t_end": 1e-3}).domain
    domain.solver.backend = "fast"
    with pytest.raises(ValueError, match=r"^solver backend: unknown backend 'fast'; use one of 'compiled'"):
        domain.solve()


def test_auto_takes_the_reference_path_for_a_short_run_only_and_says_why(tmp_path, capsys):
    """The three-bar's 50 steps: reference, printed before the run and recorded in the results file; its own 10 s
    (50,000 steps, about 300 s in NumPy): compiled.  The decision reads the job only, so it is the same each time."""
    import h5py

    from flexmbs.cli import main
    from reference.plain.backend import for_domain

    deck = ROOT / "models" / "three_bar.toml"
    assert main(["run", str(deck), "--t-end", "0.01", "--backend", "auto", "--no-vtk", "--out", str(tmp_path)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("backend: reference (about ") and "for 50 steps of 7 nodes" in first
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["backend"] == "reference" and first == f"backend: reference ({f.attrs['backend_reason']})"
    whole = load_deck(deck).domain
    whole.solver.backend = "auto"
    assert for_domain(whole).backend == "compiled" and for_domain(whole) == for_domain(whole)
