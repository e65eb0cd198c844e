"""llrpkit's LLRP reader emulator on loopback, in an asyncio loop of its own, and a scenario routed to its tags."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from llrpkit.emulator.core import EmulatedTag, LLRPEmulator
from llrpkit.protocol import messages, params

from support.runs import WORKSPACE

WAIT_S = 30.0    # generous: two loaded cores, and a reconnection waits out a back-off


class EmulatorLoop:
    """An asyncio loop in its own thread for LLRPEmulator instances (the node's loop is another thread)."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="llrp-emulator", daemon=True)
        self.thread.start()
        self.running: list[LLRPEmulator] = []

    def run(self, coroutine: Coroutine[Any, Any, Any]) -> Any:
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(WAIT_S)

    def start(self, tags: list[EmulatedTag], port: int = 0) -> LLRPEmulator:
        async def started() -> LLRPEmulator:
            emulator = LLRPEmulator(host="127.0.0.1", port=port, tags=tags, reads_per_sec=100.0, antenna_count=4)
            await emulator.start()
            return emulator
        emulator = self.run(started())
        self.running.append(emulator)
        return emulator

    def stop(self, emulator: LLRPEmulator) -> None:
        self.run(emulator.stop())
        self.running.remove(emulator)

    def close(self) -> None:
        for emulator in list(self.running):
            self.stop(emulator)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(WAIT_S)
        self.loop.close()

TARGET = "E2000017010B016210000101"     # the route's ceiling tag, seen by the two receiving antennas

FLOOR = "E2000017010B016210000102"      # its arrival floor tag, on the downward antenna

FLOOR_AFTER_REPORTS = 1000              # ~5 s at 200 reports/s after the route starts: the robot steers on the
                                        # target before it arrives

HOP_DWELL_REPORTS = 40                  # 0.2 s per channel at 200 reports/s, as an FCC reader dwells 0.2-0.4 s
HOP_CHANNELS = 50                       # the emulator's FCC hop table


class DelayedFloorTag(LLRPEmulator):
    """The emulator with the floor tag coming into view only FLOOR_AFTER_REPORTS reports after ``arm()``, hopping
    channels as a reader does: HOP_DWELL_REPORTS reports on each channel of its hop table in turn (llrpkit's
    emulator draws each report's channel at random, so left and right reads of one 20 ms batch would hardly ever
    share a channel, and the controller steers only on pairs that do). ``_send`` is llrpkit's private hook through
    which every report goes; counting there is the only way to know what was sent."""

    reports = 0
    floor_at: int | None = None      # the report that brings the floor tag into view, once armed

    def arm(self) -> None:
        """Bring the floor tag into view FLOOR_AFTER_REPORTS reports from now (call on the emulator's loop)."""
        self.floor_at = self.reports + FLOOR_AFTER_REPORTS

    async def _send(self, msg, *, message_id: int = 0) -> None:
        if isinstance(msg, messages.RO_ACCESS_REPORT):
            self.reports += 1
            if self.reports == self.floor_at:
                self.tags = [*self.tags, EmulatedTag(epc=bytes.fromhex(FLOOR), antennas=(3,), rssi_dbm=-60.0)]
            channel = 1 + (self.reports // HOP_DWELL_REPORTS) % HOP_CHANNELS
            for report in msg.tag_report_datas:
                report.channel_index = params.ChannelIndex(channel_index=channel)
        await super()._send(msg, message_id=message_id)


@contextmanager
def floor_tag_once_following(runs: Path, loop: EmulatorLoop) -> Iterator[None]:
    """While a run goes to ``runs``: arm the DelayedFloorTag emulator on ``loop`` once heading_controller logged
    that it follows the route, so the floor tag comes into view a fixed number of reports into the route however
    long the graph took to come up (a loaded machine: a minute). The log file is the only signal from inside the
    run's leased domain; it is polled."""
    emulator = next(e for e in loop.running if isinstance(e, DelayedFloorTag))
    done = threading.Event()

    def watch() -> None:
        while not done.wait(0.2):
            logs = list(runs.glob("*/logs/heading_controller.log"))
            if logs and "following " in logs[0].read_text():
                loop.loop.call_soon_threadsafe(emulator.arm)
                return

    watcher = threading.Thread(target=watch, name="arm-floor-tag", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        watcher.join()


def emulated_route(folder: Path, loop: EmulatorLoop, metrics: str) -> tuple[Path, Path]:
    """Start the emulator (the target tag on antennas 1 and 2, its floor tag on 3 once armed: see
    floor_tag_once_following) on ``loop`` and write
    a line_follow_90 scenario routed to the target (paper 001's controller, ``metrics``) and llrp_reader
    parameters for the emulator: (scenario, reader parameter file). The parameters are the shipped
    config/params/llrp_reader.yaml but for the reader's address (the emulator's, on loopback), so the run uses the
    antennas the robot profiles ship with."""
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
    shipped = (WORKSPACE / "config/params/llrp_reader.yaml").read_text().splitlines()
    address = {"    host: 192.168.1.10": "    host: 127.0.0.1", "    port: 5084": f"    port: {emulator.port}"}
    lines = [next((new + line[len(old):] for old, new in address.items() if line.startswith(old + " ")), line)
             for line in shipped]
    changed = [(old, new) for old, new in zip(shipped, lines) if old != new]
    assert len(changed) == 2, changed          # the address, and nothing else
    params = folder / "llrp_reader.yaml"
    params.write_text("\n".join(lines) + "\n")
    return scenario, params
