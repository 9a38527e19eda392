"""The verification's own code, kept out of the engine: closed-form solutions (:mod:`.analytic`) and
observables written for particular decks (:mod:`.observables`)."""
