"""In-process experiments of rfidnav: the runners, the papers' reproductions, the benchmarks and their CLI verbs."""
