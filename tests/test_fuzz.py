"""1,000 mutated decks (``tests/fuzz_decks.py``; ``make fuzz`` runs 10,000): each is a one-line
DeckError or a model that runs — no other exception, no warning, no hang."""

from __future__ import annotations

import fuzz_decks


def test_one_thousand_mutated_decks_give_a_clean_error_or_a_valid_model(tmp_path):
    res = fuzz_decks.run(1000, seed=2026, workdir=tmp_path)
    assert not res["failures"], "\n".join(f"case {f['case']} ({f['base']}): {f['problem']}" for f in res["failures"][:10])
    # the mutator reaches both answers, so the property is tested on each
    assert res["error"] > 300 and res["accepted"] > 100, res
