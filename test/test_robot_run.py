"""A whole run with the create2_llrp robot profile and no simulator at all: `create_base` on a fake Create 2 behind
a pseudo-terminal, `llrp_reader` on llrpkit's LLRP emulator, paper 001's heading_controller between them, in real
time (no /clock). The run is recorded like a simulated one, and `report` and `bag info` work on its bag
(~40 s of wall time)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from support.fake_create import FakeCreate
from support.llrp import EmulatorLoop, emulated_route, floor_tag_once_following
from support.runs import WORKSPACE, run_cli, run_scenario

pytestmark = pytest.mark.tier("graph")


@pytest.fixture(scope="module")
def robot_run(tmp_path_factory) -> Iterator[tuple[Path, FakeCreate]]:
    folder = tmp_path_factory.mktemp("robot")
    loop = EmulatorLoop()
    create = FakeCreate()
    try:
        scenario, reader = emulated_route(folder, loop, "[tracking]")   # not computed: no ground truth
        base = folder / "create_base.yaml"
        base.write_text((WORKSPACE / "config/params/create_base.yaml").read_text()
                        .replace("port: /dev/ttyUSB0", f"port: {create.slave_path}"))
        assert create.slave_path in base.read_text()
        with floor_tag_once_following(folder / "runs", loop):
            run = run_scenario(folder / "runs", str(scenario), "--robot", "create2_llrp",
                               "--params", f"rfid_reader={reader}", "--params", f"robot_sim={base}")
        yield run, create
    finally:
        create.close()
        loop.close()


def test_the_route_is_followed_on_the_fake_create_in_real_time(robot_run: tuple[Path, FakeCreate]) -> None:
    run, create = robot_run
    summary = json.loads((run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in summary["nodes"].values())
    graph = json.loads((run / "graph.json").read_text())
    assert {"create_base", "llrp_reader", "heading_controller"} <= set(graph["nodes"])
    assert "robot_sim" not in graph["nodes"] and "/clock" not in graph["nodes"]["heading_controller"]["subscriptions"]
    # Drive Direct (right, left) as signed mm/s: the controller drove forward through create_base.
    speeds = [(int.from_bytes(bytes(c.args[0:2]), "big", signed=True),
               int.from_bytes(bytes(c.args[2:4]), "big", signed=True)) for c in create.received() if c.opcode == 145]
    assert any(right > 0 and left > 0 for right, left in speeds)
    assert summary["metrics"]["odom_path_length_m"] > 0.2           # the fake's encoders, through /odom


def test_report_bag_info_and_replay_work_on_the_robots_bag(robot_run: tuple[Path, FakeCreate]) -> None:
    run, _ = robot_run
    report = run_cli("report", str(run), "--json")
    assert report.returncode == 0, report.stderr
    assert json.loads(report.stdout)["metrics"]["odom_path_length_m"] > 0.2
    assert (run / "trajectory.png").stat().st_size > 10_000
    info = run_cli("bag", "info", str(run), "--json")
    assert info.returncode == 0, info.stderr
    topics = {topic["name"] for topic in json.loads(info.stdout)["topics"]}
    assert {"/rfid/reads", "/cmd_vel", "/odom", "/diagnostics"} <= topics and "/sim/ground_truth" not in topics
    replay = run_cli("replay", str(run), "--topics", "/rfid/reads", "/odom", "--rate", "10")
    assert replay.returncode == 0, replay.stdout + replay.stderr
