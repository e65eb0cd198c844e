"""``./rfidnav bench llrp``: the llrp_reader driver in its own process against llrpkit's emulator, two short low-rate
steps -- the figures come back with their keys, nothing is lost, the latencies are plausible."""

from __future__ import annotations

import json

import pytest

from rfidnav_experiments.bench.llrp import bench_llrp

pytestmark = pytest.mark.tier("graph")

STEP_KEYS = {"asked_reports_per_s", "sent_reports_per_s", "sent", "received", "lost", "latency_p50_ms",
             "latency_p99_ms", "latency_max_ms"}


def test_the_llrp_bench_loses_nothing_at_low_rates_and_reports_plausible_latencies(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_llrp(True, seconds_per_step=2.0, rates=(150, 50)) == 0
    figures = json.loads(capsys.readouterr().out)
    assert {"latency_p50_ms", "latency_p99_ms", "max_lossless_reports_per_s", "steps"} <= set(figures)
    steps = figures["steps"]
    assert [step["asked_reports_per_s"] for step in steps] == [50, 150], "steps run from the lowest rate up"
    for step in steps:
        assert set(step) == STEP_KEYS
        assert step["sent"] > 0 and step["received"] == step["sent"] and step["lost"] == 0, step
        # The emulator paces itself against a running due time: at these rates it keeps up (2 s: +-1 report).
        assert step["sent_reports_per_s"] == pytest.approx(step["asked_reports_per_s"], rel=0.2), step
        # Batches every 20 ms: a reading waits about half that; far under a second even on a loaded machine.
        assert 0.0 < step["latency_p50_ms"] <= step["latency_p99_ms"] <= step["latency_max_ms"] < 1000.0, step
    assert (figures["latency_p50_ms"], figures["latency_p99_ms"]) == (steps[0]["latency_p50_ms"],
                                                                      steps[0]["latency_p99_ms"])
    assert figures["max_lossless_reports_per_s"] == max(step["sent_reports_per_s"] for step in steps)
    assert figures["driver_dropped_reads"] == 0
