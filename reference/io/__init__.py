"""Input and output: model decks, the results file, ParaView export."""
