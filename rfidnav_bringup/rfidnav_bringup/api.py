"""The public run API of rfidnav_bringup: what packages above it (the experiments' DDS benchmarks) may use to run a
scenario's graph or a node process of their own. Everything else in this package may change without notice."""

from __future__ import annotations

from rfidnav_bringup.errors import ReadinessError
from rfidnav_bringup.orchestrator import Orchestrator
from rfidnav_bringup.processes import DomainLease, NodeProcess, child_environment, cpu_hogs
from rfidnav_bringup.run_plan import RunOptions
from rfidnav_bringup.summary import RunSummary

__all__ = ["DomainLease", "NodeProcess", "Orchestrator", "ReadinessError", "RunOptions", "RunSummary",
           "child_environment", "cpu_hogs"]
