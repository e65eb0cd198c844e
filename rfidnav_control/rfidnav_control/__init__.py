"""Controllers of rfidnav: the fuzzy heading controller (paper 001), spiral search and go-to (paper 003), sonar
wall following (paper 004)."""
