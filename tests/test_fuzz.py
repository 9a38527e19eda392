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
