"""The reduced bodies of a deck (issue 39): :func:`reduced_bodies` builds each beam marked ``reduce``.

The algorithms do not run reduced bodies yet, so :func:`reference.io.deck.load_deck` refuses a deck that
reduces a beam (:func:`reference.io.deck_reduce.read_reduce`); this module reads the deck past that refusal
and returns the bodies, for their modes and invariants.  It is apart from :mod:`reference.io.deck_reduce`
because that module is imported by the deck reader and this one imports the reader.
"""

from __future__ import annotations

from reference.io.deck import load_deck
from reference.io.deck_reduce import collecting, reduced_body
from reference.reduced.body import ReducedBody


def reduced_bodies(path, overrides: dict | None = None) -> dict[str, ReducedBody]:
    """The reduced bodies of the deck at ``path`` (with ``overrides``, as :func:`reference.io.deck.load_deck`),
    by beam label: each beam marked ``reduce`` as a :class:`~reference.reduced.body.ReducedBody` (its
    ``modes``, ``inv`` and ``interfaces``, :func:`reference.io.deck_reduce.reduced_body`).

    Raises
    ------
    reference.io.deck_reader.DeckError
        One line, for any problem of the deck other than the refusal to run a reduced beam.
    """
    with collecting() as found:
        load_deck(path, overrides)
    return {label: reduced_body(reduction) for label, reduction in found.items()}
