"""The summary of a run (rfidnav_bringup.summary) alone: its outcome from the mission's result, the CPU the graph used
while the mission ran, summary.json and its printed form."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

import rfidnav_bringup.report
from rfidnav_bringup.processes import NodeProcess
from rfidnav_bringup.summary import (
    MissionOutcome,
    RunFacts,
    cpu_seconds,
    mission_cpu,
    print_summary,
    write_run_summary,
)
from rfidnav_common.errors import RfidnavError

pytestmark = pytest.mark.tier("unit")

FACTS = RunFacts("hallway", 7, "max", {"mode": "stepped"},
                 {"id": 51, "partition": "rfidnav-0123456789abcdef", "discovery": "localhost"})


def processes(tmp_path: Path) -> dict[str, NodeProcess]:
    """Processes as a run leaves them: the recorder exited cleanly, the controller was restarted once (never started
    here: only their records are read)."""
    recorder = NodeProcess("recorder", ["recorder"], tmp_path / "recorder.log", {}, exit_code=0)
    controller = NodeProcess("heading_controller", ["controller"], tmp_path / "c.log", {}, respawn=True,
                             max_respawns=2, restarts=1, exit_code=-2)
    return {"recorder": recorder, "heading_controller": controller}


def finished(**changes) -> MissionOutcome:
    outcome = MissionOutcome(success=True, message="reached H7", started_wall=100.0, ended_wall=110.0,
                             started_sim_s=2.0, ended_sim_s=42.5,
                             cpu_at_start={"recorder": 1.0, "heading_controller": 2.0, "orchestrator": 0.5},
                             cpu_at_end={"recorder": 3.0, "heading_controller": 1.0, "orchestrator": 1.5})
    for key, value in changes.items():
        setattr(outcome, key, value)
    return outcome


@pytest.mark.parametrize("result, interrupted, message, success, final_message", [
    (SimpleNamespace(success=True, message="reached H7"), False, "not started", True, "reached H7"),
    (SimpleNamespace(success=False, message="target unheard"), False, "not started", False, "target unheard"),
    (SimpleNamespace(success=True, message="reached H7"), True, "interrupted (Ctrl-C)", False, "interrupted (Ctrl-C)"),
    (SimpleNamespace(success=False, message="cancelled"), False, "timeout after 420.0 s of sim time", False,
     "timeout after 420.0 s of sim time"),
])
def test_the_mission_s_result_is_a_success_only_if_nothing_ended_the_mission_first(
        result, interrupted: bool, message: str, success: bool, final_message: str) -> None:
    outcome = MissionOutcome(message=message)
    outcome.conclude(result, interrupted)
    assert (outcome.success, outcome.message, outcome.result) == (success, final_message, result)


def test_the_mission_s_cpu_is_per_process_and_a_restarted_one_is_left_out_of_the_total() -> None:
    cpu = mission_cpu(finished())
    assert cpu is not None
    assert cpu["mission_wall_s"] == 10.0
    # heading_controller restarted: its counter began again, lower than at the start.
    assert cpu["process_cpu_s"] == {"recorder": 2.0, "heading_controller": None, "orchestrator": 1.0}
    assert cpu["graph_cpu_s"] == 3.0 and cpu["graph_cpu_percent_of_one_core"] == 30.0


def test_a_mission_that_never_ended_has_no_cpu_figure() -> None:
    assert mission_cpu(MissionOutcome()) is None
    assert mission_cpu(finished(ended_wall=None)) is None


def test_cpu_seconds_counts_each_process_and_the_orchestrator(tmp_path: Path) -> None:
    seconds = cpu_seconds(processes(tmp_path))
    assert list(seconds) == ["recorder", "heading_controller", "orchestrator"]
    assert seconds["recorder"] is None   # never started here
    assert seconds["orchestrator"] > 0


def test_summary_json_holds_the_outcome_the_run_s_facts_and_each_process(tmp_path: Path) -> None:
    said: list[str] = []
    summary = write_run_summary(tmp_path, FACTS, finished(), processes(tmp_path), said.append)
    document = json.loads((tmp_path / "summary.json").read_text())
    assert document == summary.document and summary.success and summary.run_dir == tmp_path
    assert list(document) == ["scenario", "success", "message", "seed", "rtf", "clock", "ros_domain",
                              "sim_duration_s", "wall_duration_s", "metrics", "cpu", "nodes", "bag", "run_dir"]
    assert (document["scenario"], document["seed"], document["rtf"]) == ("hallway", 7, "max")
    assert document["sim_duration_s"] == 40.5 and document["wall_duration_s"] == 10.0
    assert document["nodes"] == {"recorder": {"restarts": 0, "exit_code": 0},
                                 "heading_controller": {"restarts": 1, "exit_code": -2}}
    assert document["metrics"] == {} and document["bag"] == str(tmp_path)   # no bag: the run's folder
    assert not said


def test_metrics_that_cannot_be_computed_are_said_and_left_out(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "metadata.yaml").write_text("{}")

    def damaged(_run: Path, _robot: str | None = None) -> dict:
        raise RfidnavError("the bag has no /sim/ground_truth")

    monkeypatch.setattr(rfidnav_bringup.report, "run_metrics", damaged)
    said: list[str] = []
    summary = write_run_summary(tmp_path, FACTS, finished(), processes(tmp_path), said.append)
    assert said == ["metrics not computed: the bag has no /sim/ground_truth"]
    assert summary.document["metrics"] == {} and summary.document["bag"] == str(tmp_path / "bag")



def test_an_interrupted_run_leaves_its_metrics_to_report_and_says_so(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "metadata.yaml").write_text("{}")
    read: list[Path] = []
    monkeypatch.setattr(rfidnav_bringup.report, "run_metrics",
                        lambda run, _robot=None: read.append(run) or {"rmse_m": 0.1})
    said: list[str] = []
    summary = write_run_summary(tmp_path, FACTS, finished(), processes(tmp_path), said.append, interrupted=True)
    assert read == [] and summary.document["metrics"] == {}
    assert said == [f"metrics not computed for an interrupted run: ./rfidnav report {tmp_path} computes them"]

def test_the_printed_summary_aligns_one_row_per_fact(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    summary = write_run_summary(tmp_path, FACTS, finished(), processes(tmp_path), print)
    print_summary(summary)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "  scenario                 hallway"
    assert "  node heading_controller  exit -2, restarts 1" in lines
    assert "  graph CPU in mission     30.0% of one core" in "\n".join(lines)
    assert lines[-1] == f"  summary                  {tmp_path / 'summary.json'}"
