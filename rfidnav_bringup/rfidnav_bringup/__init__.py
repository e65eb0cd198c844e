"""Orchestration of rfidnav: the CLI, scenarios, node processes, the orchestrator, metrics and reports."""
