"""In-process runners: the same pure cores as the nodes, wired without DDS, for many seeds fast."""
