"""What a run's summary.json says when the mission's node and ground truth disagree, or when it cannot be written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import rfidnav_bringup.report
from rfidnav_bringup.orchestrator import Orchestrator
from rfidnav_bringup.run_plan import RunOptions
from rfidnav_scenario.scenario import load_scenario

pytestmark = pytest.mark.tier("node")


def finished_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, metrics: dict) -> Orchestrator:
    """An orchestrator of building_floor whose mission's node reported success, with ``metrics`` from its bag."""
    orchestrator = Orchestrator(load_scenario("building_floor"), RunOptions(out_dir=tmp_path))
    (orchestrator.run_dir / "bag").mkdir(parents=True)
    (orchestrator.run_dir / "bag" / "metadata.yaml").write_text("{}")
    orchestrator.outcome.success, orchestrator.outcome.message = True, "reached J4"
    monkeypatch.setattr(rfidnav_bringup.report, "run_metrics", lambda _run, _robot=None: metrics)
    return orchestrator


def test_a_success_that_ground_truth_contradicts_is_reported_as_a_failure(tmp_path: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    orchestrator = finished_run(tmp_path, monkeypatch, {"success": False, "final_distance_m": 3.25})
    summary = orchestrator.write_summary()
    assert summary.success is False and orchestrator.exit_code == 1
    assert summary.document["message"] == ("reached J4, says the mission's node; but ground truth did not reach the "
                                           "goal (metrics.success false, 3.25 m from it)")
    assert json.loads((orchestrator.run_dir / "summary.json").read_text())["success"] is False


def test_a_success_that_ground_truth_confirms_stays_a_success(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    orchestrator = finished_run(tmp_path, monkeypatch, {"success": True, "final_distance_m": 0.1})
    assert orchestrator.write_summary().success is True and orchestrator.exit_code == 0


def test_a_summary_that_cannot_be_written_is_said_in_one_line_and_the_outcome_kept(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    orchestrator = finished_run(tmp_path, monkeypatch, {"success": True, "final_distance_m": 0.1})

    def disk_full(*_args, **_kwargs) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("rfidnav_bringup.summary.write_atomically", disk_full)
    summary = orchestrator.write_summary()
    assert summary.success is True
    assert f"summary.json not written in {orchestrator.run_dir}: No space left on device" in capsys.readouterr().out
    assert not (orchestrator.run_dir / "summary.json").exists()


def test_a_success_whose_track_crossed_a_wall_is_reported_as_a_failure_naming_the_count(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    orchestrator = finished_run(tmp_path, monkeypatch, {"success": True, "final_distance_m": 0.1, "wall_crossings": 3})
    summary = orchestrator.write_summary()
    assert summary.success is False and orchestrator.exit_code == 1
    assert summary.document["message"] == ("reached J4, says the mission's node; but ground truth made 3 wall "
                                           "crossings (metrics.wall_crossings)")
