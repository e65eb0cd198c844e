"""Orchestration of rfidnav: scenarios, process runner, MCAP recorder and player, metrics, reports, experiments, CLI."""
