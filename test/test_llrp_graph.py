"""The swap end to end: `./rfidnav run ... --robot sim_base_llrp` puts the llrp_reader driver, reading from llrpkit's
LLRP emulator on loopback, in the place of the reader simulator, and paper 001's heading_controller follows a
route of the emulated tags with the simulated base (~30 s of wall time at RTF 1)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from llrpkit.emulator.core import EmulatedTag, LLRPEmulator
from llrpkit.protocol import messages

from rfidnav_bag.bags import read_messages
from test_graph import WORKSPACE, run_scenario
from test_llrp_reader import EmulatorLoop

TARGET = "E2000017010B016210000101"     # the route's ceiling tag, seen by the two receiving antennas
FLOOR = "E2000017010B016210000102"      # its arrival floor tag, on the downward antenna
FLOOR_AFTER_REPORTS = 3000              # ~15 s at 200 reports/s: the robot steers on the target before it arrives


class DelayedFloorTag(LLRPEmulator):
    """The emulator with the floor tag coming into view only after FLOOR_AFTER_REPORTS reports. ``_send`` is
    llrpkit's private hook through which every report goes; counting there is the only way to know what was
    sent."""

    reports = 0

    async def _send(self, msg, *, message_id: int = 0) -> None:
        if isinstance(msg, messages.RO_ACCESS_REPORT):
            self.reports += 1
            if self.reports == FLOOR_AFTER_REPORTS:
                self.tags = [*self.tags, EmulatedTag(epc=bytes.fromhex(FLOOR), antennas=(3,), rssi_dbm=-60.0)]
        await super()._send(msg, message_id=message_id)


def emulated_route(folder: Path, loop: EmulatorLoop, metrics: str) -> tuple[Path, Path]:
    """Start the emulator (the target tag on antennas 1 and 2, its floor tag on 3 later) on ``loop`` and write
    a line_follow_90 scenario routed to the target (paper 001's controller, ``metrics``) and llrp_reader
    parameters for the emulator: (scenario, reader parameter file)."""
    async def started() -> LLRPEmulator:
        emulator = DelayedFloorTag(host="127.0.0.1", port=0, reads_per_sec=200.0, antenna_count=4,
                                   tags=[EmulatedTag(epc=bytes.fromhex(TARGET), antennas=(1, 2), rssi_dbm=-50.0)])
        await emulator.start()
        return emulator
    emulator = loop.run(started())
    loop.running.append(emulator)
    route_map = folder / "route.yaml"
    route_map.write_text(f"name: emulated\narrival_tags: {{'{TARGET}': '{FLOOR}'}}\n")
    scenario = folder / "emulated_route.yaml"
    scenario.write_text(
        (WORKSPACE / "config/scenarios/line_follow_90.yaml").read_text()
        .replace("../worlds/line_follow.yaml", str(WORKSPACE / "config/worlds/line_follow.yaml"))
        .replace("../maps/line_follow.yaml", str(route_map))
        .replace("../params/", str(WORKSPACE / "config/params") + "/")
        .replace("flc_tuned.yaml", "flc_paper.yaml")
        .replace("goal: {tag_ids: [C1, C2]}", f"goal: {{tag_ids: ['{TARGET}']}}")
        .replace("metrics: [tracking]", f"metrics: {metrics}"))
    params = folder / "llrp_reader.yaml"
    params.write_text((WORKSPACE / "config/params/llrp_reader.yaml").read_text()
                      .replace("host: 192.168.1.10", "host: 127.0.0.1")
                      .replace("port: 5084", f"port: {emulator.port}")
                      .replace("antennas: [1, 2]", "antennas: [1, 2, 3]"))
    assert f"port: {emulator.port}" in params.read_text() and "antennas: [1, 2, 3]" in params.read_text()
    return scenario, params


@pytest.fixture(scope="module")
def swap_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("llrp_swap")
    loop = EmulatorLoop()
    try:
        scenario, params = emulated_route(folder, loop, "[]")    # tracking needs the tags' true positions
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
