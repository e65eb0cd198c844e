"""A simulated thermometer: the smallest sensor simulator that follows docs/extending.md."""
