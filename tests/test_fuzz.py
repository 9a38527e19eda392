"""1,000 mutated decks (``tests/fuzz_decks.py``; ``make fuzz`` runs 10,000): each is a one-line
DeckError or a model that runs — no other exception, no warning, no hang."""

from __future__ import annotations

import fuzz_decks


def test_one_thousand_mutated_decks_give_a_clean_error_or_a_valid_model(tmp_path):
    res = fuzz_decks.run(1000, seed=2026, workdir=tmp_path)
    assert not res["failures"], "\n".join(f"case {f['case']} ({f['base']}): {f['problem']}" for f in res["failures"][:10])
    # the mutator reaches both answers, so the property is tested on each
    assert res["error"] > 300 and res["accepted"] > 100, res


def test_every_key_and_kind_the_reader_knows_is_in_the_vocabulary():
    """A key added to the reader (``rd.keys(..., required=[...], optional=[...])``, the tables of time
    functions, springs and algorithms) must enter :data:`fuzz_decks.VOCABULARY`, so that it is fuzzed."""
    import ast
    import inspect

    from reference.algorithms import ALGORITHMS
    from reference.forces import KINDS as SPRING_KINDS
    from reference.io import deck, deck_connectors, deck_solution
    from reference.joints.joint import ROWS as JOINT_KINDS

    keys = set(deck.TOP_LEVEL) | set(deck.SECTION_KEYS)
    for module in (deck, deck_connectors, deck_solution):
        for node in ast.walk(ast.parse(inspect.getsource(module))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "keys":
                for kw in node.keywords:
                    if kw.arg in ("required", "optional"):
                        keys |= {c.value for c in ast.walk(kw.value)
                                 if isinstance(c, ast.Constant) and isinstance(c.value, str)}
    for _, required, optional in deck.TIME_FUNCTIONS.values():
        keys |= set(required) | set(optional)
    for required, optional in deck_connectors.SPRING_KEYS.values():
        keys |= set(required) | set(optional)
    for algorithm in ALGORITHMS.values():
        keys |= set(algorithm.deck_required) | set(algorithm.deck_optional)
    vocabulary = fuzz_decks.VOCABULARY
    tables = {name.rstrip("[]").rstrip(".*") for name in vocabulary}
    missing = keys - tables - {k for table in vocabulary.values() for k in table}
    assert not missing, f"deck keys the fuzzer never writes: {sorted(missing)}"
    kinds = {"joints[]": JOINT_KINDS, "springs[]": SPRING_KINDS, "time_functions.*": deck.TIME_FUNCTIONS}
    for table, known in kinds.items():
        assert set(known) <= set(vocabulary[table]["kind"]), table
    assert set(ALGORITHMS) <= set(vocabulary["solver"]["algorithm"])


def test_a_dt_override_of_a_static_deck_is_the_readers_one_line(tmp_path, capsys):
    """Fuzz case 4366 (``--results``): ``embedded_beam_static.toml`` with the override dt = 1e-4.  A static run
    steps by t_end / load_steps (0.1) whatever dt says: ``flexmbs run --dt 1e-4`` ran 20 load steps and,
    the output interval scaled by the 1000 × smaller "step", wrote 2 outputs instead of 21, exit 0; the
    harness, shortening t_end to 3 × dt, met "t_end = 0.0003 is not a whole number of steps of dt = 0.1".
    Now `flexmbs run --dt` refuses it in one line (exit 2); the harness shortens t_end by the algorithm's own
    step, so the case runs (the engine's own callers pass a static deck's step as dt and are not refused)."""
    from flexmbs.cli import main

    deck = fuzz_decks.ROOT / "models" / "embedded_beam_static.toml"
    assert fuzz_decks.check(deck, {"dt": 1e-4}, tmp_path / "results.h5") in ("error", "accepted")
    assert main(["run", str(deck), "--dt", "1e-4", "--out", str(tmp_path / "out"), "--no-vtk"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"flexmbs: error: {deck}: dt override (--dt): algorithm = \"static\" has no time step to "
                   "override; drop --dt; its load step is t_end / load_steps: set solver.load_steps"), err
