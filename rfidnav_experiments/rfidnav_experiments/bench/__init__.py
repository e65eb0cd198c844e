"""Benchmarks that print figures (JSON with --json): never asserted in timed tests."""
