"""The swap end to end: `./rfidnav run ... --robot sim_base_llrp` puts the llrp_reader driver, reading from llrpkit's
LLRP emulator on loopback with the shipped parameters (but the address), in the place of the reader simulator, and
paper 001's heading_controller follows a route of the emulated tags with the simulated base (~30 s of wall time at
RTF 1)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from rfidnav_bag.bags import read_messages
from rfidnav_common.config import node_parameter_values
from rfidnav_drivers.parameters import LlrpReaderParameters
from support.llrp import FLOOR, TARGET, EmulatorLoop, emulated_route, floor_tag_once_following
from support.runs import WORKSPACE, run_scenario

pytestmark = pytest.mark.tier("graph")


@pytest.fixture(scope="module")
def swap_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("llrp_swap")
    loop = EmulatorLoop()
    try:
        scenario, params = emulated_route(folder, loop, "[]")    # tracking needs the tags' true positions
        with floor_tag_once_following(folder / "runs", loop):
            return run_scenario(folder / "runs", str(scenario), "--robot", "sim_base_llrp", "--params",
                                f"rfid_reader={params}", "--rtf", "1", "--seed", "1")
    finally:
        loop.close()


def test_the_heading_controller_reaches_the_emulated_tag_through_the_llrp_driver(swap_run: Path) -> None:
    summary = json.loads((swap_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in summary["nodes"].values())
    graph = json.loads((swap_run / "graph.json").read_text())
    assert "llrp_reader" in graph["nodes"] and "rfid_reader_sim" not in graph["nodes"]
    assert "/rfid/reads" in graph["nodes"]["heading_controller"]["subscriptions"]
    # The shipped reader parameters but the address: the ports the controller reads, 1, 2 and 3, untouched.
    used = yaml.safe_load((swap_run / "params" / "rfid_reader.yaml").read_text())["llrp_reader"]["ros__parameters"]
    shipped = node_parameter_values(LlrpReaderParameters, WORKSPACE / "config/params/llrp_reader.yaml", "llrp_reader")
    assert used["antennas"] == shipped["antennas"] == [1, 2, 3]


def test_the_bag_holds_the_drivers_reads_and_the_steering_they_caused(swap_run: Path) -> None:
    tags, antennas, turning, topics = set(), set(), [], set()
    for topic, _, msg in read_messages(swap_run / "bag", ["/rfid/reads", "/cmd_vel", "/diagnostics"]):
        topics.add(topic)
        if topic == "/rfid/reads":
            tags.update(r.tag_id for r in msg.readings)
            antennas.update(r.antenna for r in msg.readings)
        elif topic == "/cmd_vel":
            turning.append(msg.angular.z)
    assert topics == {"/rfid/reads", "/cmd_vel", "/diagnostics"}
    assert tags == {TARGET, FLOOR} and antennas == {1, 2, 3}
    # The emulator's phases are random, so the fuzzy controller turns both ways on them before it arrives.
    assert min(turning) < -0.01 and max(turning) > 0.01
