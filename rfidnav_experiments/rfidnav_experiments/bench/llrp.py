"""``./rfidnav bench llrp``: the llrp_reader driver's report-to-publish latency and the highest tag-report rate
it passes on from llrpkit's LLRP emulator without losing any.

The driver runs in its own process (as in a run) on a leased domain, connected to llrpkit's emulator, which runs on
an asyncio loop in a thread of this process so that every tag report it sends can be counted by EPC. This process
subscribes to /rfid/reads and counts the readings it receives by EPC. The rate rises in steps; each step has a
tag population of its own (the step number is in the EPCs), so every reading belongs to exactly one step whenever
it arrives, and a step's loss is what the emulator sent minus what arrived of that step's tags.

Latency of a reading: this process's receipt time (system clock) minus the reading's stamp, which the driver sets
to its node clock (the system clock: no use_sim_time) at the moment the report came from the reader. It covers the
driver's queue wait and batching (``batch_period_s``), serialisation and DDS, not the TCP hop from the emulator.
"""

from __future__ import annotations

import asyncio
import json
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Coroutine
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from llrpkit.emulator.core import EmulatedTag, LLRPEmulator
from llrpkit.protocol import messages
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rfidnav_bringup.api import DomainLease, NodeProcess, ReadinessError, child_environment
from rfidnav_common.install import resolve_executable
from rfidnav_drivers.parameters import LlrpReaderParameters
from rfidnav_msgs.msg import TagReadArray

ANTENNAS = (1, 2, 3, 4)
TAGS_PER_STEP = 20
IDLE_STEP = 0                 # the population between steps and during readiness: nobody counts its readings
IDLE_REPORTS_PER_S = 50.0     # keeps the link streaming between steps without loading anything
READY_TIMEOUT_S = 30.0
DRAIN_QUIET_S = 1.0           # a step's count unchanged this long (with readings missing): the rest is lost
DRAIN_TIMEOUT_S = 30.0
EMULATOR_TIMEOUT_S = 10.0
SATURATED = 0.95              # an emulator sending less than this share of the asked rate could go no faster
STOP_GRACE_S = 10.0           # the driver stops its inventory and closes the link on SIGINT (bounded by llrpkit)
# Reliable and deep enough for ~20 s of 50 Hz batches: a reading this subscriber's own queue overwrote would
# count against the driver.
READS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
DIAGNOSTICS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE)


def population(step: int) -> list[EmulatedTag]:
    """TAGS_PER_STEP 96-bit EPCs ending in the step and the tag index, spread over the antennas, all in view
    (the emulator hides tags weaker than -72 dBm at full power)."""
    return [EmulatedTag(epc=bytes.fromhex(f"E280BE4C00000000{step:04X}{index:04X}"),
                        antennas=(ANTENNAS[index % len(ANTENNAS)],), rssi_dbm=-50.0 - index % 5)
            for index in range(TAGS_PER_STEP)]


class CountingEmulator(LLRPEmulator):
    """llrpkit's emulator, counting by tag id (upper-case hex EPC, as the driver names tags) every tag report it
    sends. ``_send`` is llrpkit's private hook through which every RO_ACCESS_REPORT goes; no public API says what
    was sent, so a new llrpkit may need this revisited."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.sent: Counter[str] = Counter()
        self.sent_lock = threading.Lock()     # written on the emulator's thread, read on the main one

    async def _send(self, msg: Any, *, message_id: int = 0) -> None:
        # Without a client the parent drops the message: it was not sent, so it must not count as lost.
        if isinstance(msg, messages.RO_ACCESS_REPORT) and self._writer is not None:
            with self.sent_lock:
                for data in msg.tag_report_datas:
                    epc = data.epc_parameter.epc
                    self.sent[(epc if isinstance(epc, bytes) else epc.data).hex().upper()] += 1
        await super()._send(msg, message_id=message_id)

    def sent_of(self, tag_ids: set[str]) -> int:
        with self.sent_lock:
            return sum(self.sent[tag_id] for tag_id in tag_ids)


class EmulatorThread:
    """An asyncio loop in a thread of its own for the emulator: the main thread spins the ROS executor."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="bench-llrp-emulator", daemon=True)
        self.thread.start()
        self.emulator: CountingEmulator | None = None

    def run(self, coroutine: Coroutine[Any, Any, Any]) -> Any:
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(EMULATOR_TIMEOUT_S)

    def start(self) -> CountingEmulator:
        async def started() -> CountingEmulator:
            emulator = CountingEmulator(host="127.0.0.1", port=0, tags=population(IDLE_STEP),
                                        reads_per_sec=IDLE_REPORTS_PER_S, antenna_count=len(ANTENNAS), seed=1)
            await emulator.start()
            return emulator
        self.emulator = self.run(started())
        return self.emulator

    def switch(self, step: int, reports_per_s: float) -> float:
        """Give the emulator the population of ``step`` at this rate; the loop time of the switch. Done on the
        emulator's loop, between two iterations of its report loop, so no report straddles the switch."""
        emulator = self.emulator
        assert emulator is not None

        async def switched() -> float:
            emulator.tags = population(step)
            emulator.reads_per_sec = reports_per_s
            return asyncio.get_running_loop().time()
        return self.run(switched())

    def close(self) -> None:
        if self.emulator is not None:
            self.run(self.emulator.stop())
            self.emulator = None
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(EMULATOR_TIMEOUT_S)
        if not self.thread.is_alive():
            self.loop.close()


class ReadsProbe:
    """This process's end of DDS: the readings per step and their latencies, and the driver's diagnostics."""

    def __init__(self, context: Context, step_of: dict[str, int]) -> None:
        self.step_of = step_of
        self.received: Counter[int] = Counter()
        self.latencies_ms: dict[int, list[float]] = {}
        self.messages = 0
        self.statuses: list[DiagnosticStatus] = []
        self.node = Node("bench_llrp_probe", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.node.create_subscription(TagReadArray, "/rfid/reads", self.on_reads, READS_QOS)
        self.node.create_subscription(DiagnosticArray, "/diagnostics",
                                      lambda msg: self.statuses.extend(msg.status), DIAGNOSTICS_QOS)

    def on_reads(self, msg: TagReadArray) -> None:
        # The receipt time first, before any work of this callback adds to it.
        now_ns = time.time_ns()
        self.messages += 1
        for reading in msg.readings:
            step = self.step_of.get(reading.tag_id)
            if step is None:
                continue
            self.received[step] += 1
            stamp_ns = reading.stamp.sec * 1_000_000_000 + reading.stamp.nanosec
            self.latencies_ms.setdefault(step, []).append((now_ns - stamp_ns) * 1e-6)

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, deadline - time.monotonic())))

    def wait_ready(self, driver: NodeProcess) -> None:
        """Until the driver says OK (streaming) and a /rfid/reads message arrived (this subscription matched)."""
        deadline = time.monotonic() + READY_TIMEOUT_S
        while not (self.messages and any(s.level == DiagnosticStatus.OK for s in self.statuses)):
            if not driver.running:
                raise ReadinessError(f"llrp_reader exited ({driver.exit_code}):\n{driver.last_lines()}")
            if time.monotonic() > deadline:
                said = self.statuses[-1].message if self.statuses else "no /diagnostics"
                raise ReadinessError(f"llrp_reader: not streaming after {READY_TIMEOUT_S:g} s ({said}):\n"
                                     f"{driver.last_lines()}")
            self.executor.spin_once(timeout_sec=0.1)

    def drain(self, step: int, sent: int) -> None:
        """Until every reading of ``step`` arrived, or its count stood still for DRAIN_QUIET_S."""
        last, changed = self.received[step], time.monotonic()
        deadline = changed + DRAIN_TIMEOUT_S
        while self.received[step] < sent and time.monotonic() - changed < DRAIN_QUIET_S:
            if time.monotonic() > deadline:
                return
            self.executor.spin_once(timeout_sec=0.05)
            if self.received[step] != last:
                last, changed = self.received[step], time.monotonic()

    def next_status(self, timeout_s: float) -> DiagnosticStatus | None:
        """The next /diagnostics status (the driver publishes one a second), so its counters cover every step."""
        seen = len(self.statuses)
        deadline = time.monotonic() + timeout_s
        while len(self.statuses) == seen and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        return self.statuses[-1] if len(self.statuses) > seen else None

    def close(self) -> None:
        self.node.destroy_node()
        self.executor.shutdown()


def percentile_ms(values: list[float], q: float) -> float | None:
    return round(float(np.percentile(values, q)), 3) if values else None


def measure(seconds_per_step: float, rates: tuple[float, ...]) -> dict[str, Any]:
    # Ascending, so that the steps show where loss starts; step numbers from 1 (0 is the idle population).
    steps = list(enumerate(sorted(rates), start=1))
    tag_ids = {step: {tag.epc.hex().upper() for tag in population(step)} for step, _ in steps}
    step_of = {tag_id: step for step, ids in tag_ids.items() for tag_id in ids}
    batch_period_s = LlrpReaderParameters().batch_period_s
    lease = DomainLease()
    emulators = EmulatorThread()
    try:
        emulator = emulators.start()
        with tempfile.TemporaryDirectory(prefix="bench_llrp_") as folder:
            driver = NodeProcess(
                "llrp_reader",
                [*resolve_executable("rfidnav_drivers", "llrp_reader"), "--ros-args", "-p", "host:=127.0.0.1",
                 "-p", f"port:={emulator.port}", "-p", f"antennas:=[{','.join(map(str, ANTENNAS))}]",
                 "-p", f"batch_period_s:={batch_period_s}"],
                Path(folder) / "llrp_reader.log", child_environment(lease.domain_id))
            context = Context()
            rclpy.init(context=context, domain_id=lease.domain_id)
            probe = ReadsProbe(context, step_of)
            try:
                driver.start()
                probe.wait_ready(driver)
                rows = [run_step(emulators, emulator, probe, step, rate, seconds_per_step, tag_ids[step])
                        for step, rate in steps]
                status = probe.next_status(timeout_s=3.0)
            finally:
                driver.stop(STOP_GRACE_S)
                probe.close()
                context.try_shutdown()
    finally:
        emulators.close()
        lease.close()
    lowest = rows[0]
    lossless = [row["sent_reports_per_s"] for row in rows if row["lost"] == 0]
    dropped = {kv.key: kv.value for kv in status.values}.get("dropped_reads") if status is not None else None
    # The emulator (Python, sharing this process's GIL with the subscriber) may not reach the asked rate: when the
    # top step lost nothing, the highest lossless rate is a bound of the emulator, not of the driver.
    top = rows[-1]
    return {"latency_p50_ms": lowest["latency_p50_ms"], "latency_p99_ms": lowest["latency_p99_ms"],
            "max_lossless_reports_per_s": max(lossless) if lossless else None,
            "emulator_bound": top["lost"] == 0 and top["sent_reports_per_s"] < SATURATED * top["asked_reports_per_s"],
            "batch_period_s": batch_period_s, "tags_per_step": TAGS_PER_STEP, "step_duration_s": seconds_per_step,
            "driver_dropped_reads": int(dropped) if dropped is not None else None, "steps": rows}


def run_step(emulators: EmulatorThread, emulator: CountingEmulator, probe: ReadsProbe, step: int, rate: float,
             seconds: float, tag_ids: set[str]) -> dict[str, Any]:
    started = emulators.switch(step, rate)
    probe.spin_for(seconds)
    ended = emulators.switch(IDLE_STEP, IDLE_REPORTS_PER_S)
    # After the switch the emulator sends none of this step's tags: its count is final. Draining after every step,
    # not only the last, keeps one step's backlog out of the next one's latencies.
    sent = emulator.sent_of(tag_ids)
    probe.drain(step, sent)
    latencies = probe.latencies_ms.get(step, [])
    return {"asked_reports_per_s": rate, "sent_reports_per_s": round(sent / (ended - started), 1), "sent": sent,
            "received": probe.received[step], "lost": sent - probe.received[step],
            "latency_p50_ms": percentile_ms(latencies, 50), "latency_p99_ms": percentile_ms(latencies, 99),
            "latency_max_ms": round(max(latencies), 3) if latencies else None}


def table(figures: dict[str, Any]) -> str:
    def ms(value: float | None) -> str:
        return "-" if value is None else f"{value:.2f}"
    lines = [f"llrp_reader from llrpkit's emulator ({figures['tags_per_step']} tags, batches of "
             f"{figures['batch_period_s']:g} s, {figures['step_duration_s']:g} s per step):",
             f"{'asked/s':>9} {'sent/s':>9} {'sent':>8} {'received':>9} {'lost':>6} {'p50 ms':>8} {'p99 ms':>8} "
             f"{'max ms':>8}"]
    lines += [f"{row['asked_reports_per_s']:>9g} {row['sent_reports_per_s']:>9.1f} {row['sent']:>8} "
              f"{row['received']:>9} {row['lost']:>6} {ms(row['latency_p50_ms']):>8} {ms(row['latency_p99_ms']):>8} "
              f"{ms(row['latency_max_ms']):>8}" for row in figures["steps"]]
    best = figures["max_lossless_reports_per_s"]
    lines.append(f"report-to-subscriber latency at the lowest rate: p50 {ms(figures['latency_p50_ms'])} ms, p99 "
                 f"{ms(figures['latency_p99_ms'])} ms; highest lossless rate: "
                 + ("none" if best is None else f"{best:.0f} reports/s (as sent)")
                 + (" -- the emulator's ceiling, no step lost anything" if figures["emulator_bound"] else ""))
    return "\n".join(lines)


def bench_llrp(as_json: bool, seconds_per_step: float = 4.0,
               rates: tuple[float, ...] = (100, 300, 1000, 3000, 10000)) -> int:
    figures = measure(seconds_per_step, rates)
    print(json.dumps(figures) if as_json else table(figures))
    return 0

