"""CalculiX decks, runs and result parsing."""
