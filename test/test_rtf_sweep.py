"""bench rtf: which RTF counts as usable (the sweep itself runs the real graph; see README for figures)."""

from __future__ import annotations

import json

import pytest

from rfidnav_experiments.bench.rtf import SweepRow, highest_usable_rtf, report

pytestmark = pytest.mark.tier("unit")


def row(rtf: float, rmse_cm: float | None, success: bool = True) -> SweepRow:
    return SweepRow(rtf, success, None if rmse_cm is None else rmse_cm / 100, 40.0 * rtf, 100.0 / rtf, (f"run{rtf:g}",))


def test_highest_rtf_stops_at_the_first_run_beyond_the_tolerance():
    rows = [row(1, 2.0), row(2, 2.1), row(3, 2.19), row(5, 2.3), row(8, 2.0)]
    assert highest_usable_rtf(rows, 0.10).rtf == 3      # 8 is within again, but 5 is not: 3 it is


def test_a_failed_run_is_not_usable_whatever_its_rmse():
    assert highest_usable_rtf([row(1, 2.0), row(2, 1.0, success=False)], 0.10).rtf == 1


def test_a_failed_reference_leaves_no_usable_rtf():
    assert highest_usable_rtf([row(1, None, success=False), row(2, 2.0)], 0.10) is None


def test_a_scenario_without_a_tracked_route_is_usable_up_to_its_first_failed_run():
    assert highest_usable_rtf([row(1, None), row(5, None), row(8, None, success=False)], 0.10).rtf == 5


def test_report_names_the_highest_rtf_and_its_cpu():
    rows = [row(1, 2.0), row(2, 2.1), row(5, 3.0)]
    document = json.loads(report("hallway", rows, 0.10, as_json=True))
    assert document["highest_rtf"] == 2 and document["graph_cpu_percent_of_one_core_there"] == pytest.approx(80.0)
    text = report("hallway", rows, 0.10, as_json=False)
    assert "highest RTF within 10% of the RTF 1 RMSE: 2, graph CPU 80.0% of one core" in text


def test_an_unbounded_rtf_is_written_max_so_the_json_is_strict() -> None:
    unbounded = SweepRow(float("inf"), True, 0.02, 150.0, 30.0, ("run",))
    document = json.loads(report("hallway", [unbounded], 0.10, as_json=True),
                          parse_constant=lambda name: pytest.fail(f"{name} is not JSON"))
    assert document["highest_rtf"] == "max" and document["rows"][0]["rtf"] == "max"
