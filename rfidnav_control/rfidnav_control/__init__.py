"""Controllers of rfidnav: the phase-difference fuzzy heading controller (paper 001)."""
