"""Open calibrations: a paper's unstated settings fitted to its first experiment, every other held out."""
