"""The runs over DDS of the benchmarks that drive the node graph (bench rtf, bench survey)."""

from __future__ import annotations

import sys
from contextlib import redirect_stdout

from rfidnav_bringup.api import Orchestrator, RunOptions, RunSummary
from rfidnav_scenario.scenario import Scenario


def quiet_run(scenario: Scenario, options: RunOptions) -> RunSummary:
    """One run of ``scenario``, its own lines on stderr (stdout carries the benchmark's figures); Ctrl-C stops the
    benchmark, not only the run in progress."""
    orchestrator = Orchestrator(scenario, options)
    with redirect_stdout(sys.stderr):
        summary = orchestrator.run()
    if orchestrator.interrupted:
        raise KeyboardInterrupt
    return summary
