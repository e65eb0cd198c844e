"""llrp_reader: an LLRP UHF RFID reader (Impinj Speedway / R700) with peak RSSI and RF phase, publishing
/rfid/reads (rfidnav_msgs/TagReadArray) and its link state on /diagnostics -- the hardware counterpart of
rfid_reader_sim.

The reader is driven with llrpkit (asyncio) on an event loop in a background thread, ReaderLink: connect (within
``connect_timeout_s``), ask the reader for a KEEPALIVE every ``keepalive_s``, run one continuous inventory (the
configured antennas, session, search mode, RF mode and power, with Impinj peak RSSI and phase) and turn each tag
report into a llrp_reports.Reading. Any connection loss or reader error is logged once, shown on /diagnostics,
and followed by a reconnection after the back-off schedule (``reconnect_initial_s`` doubling up to
``reconnect_max_s``, reset once the inventory runs): the node never exits for a reader problem.

Threading: only the ROS side calls rclpy. The loop thread appends readings, log lines and its state to
thread-safe containers (deques, a lock); a timer of the node drains them every ``batch_period_s`` and publishes.
rclpy's publish and logging would likely be callable from the loop thread, but keeping every rclpy call on the
executor's thread needs no such argument, keeps destroy_node simple (the loop is stopped before any ROS entity
goes), and a guard condition to wake the executor is no alternative: the EventsExecutor run_node uses refuses
guard conditions ("Guard conditions not supported").

While streaming, every batch period publishes one TagReadArray -- empty when nothing was heard, as
rfid_reader_sim publishes an empty round -- so silence on /rfid/reads means the reader is down, not that no tag
is in view. With ``batch_period_s`` 0 each report is its own message (the queue is polled every DRAIN_PERIOD_S).
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from llrpkit.exceptions import (
    CapabilityError,
    LLRPConnectionError,
    LLRPStatusError,
    LLRPTimeoutError,
    MessageEncodeError,
)
from llrpkit.protocol import enums
from llrpkit.reader import Reader
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, run_node
from rfidnav_common.transforms import publish_static_frames
from rfidnav_drivers.llrp_reports import Backoff, Reading, reader_frequency_table_hz, reading_of
from rfidnav_drivers.parameters import LlrpReaderParameters
from rfidnav_msgs.msg import TagReadArray, TagReading

# What can end a connection or an attempt, all retried: the link (refused, lost, dead: no answer in time), the
# reader refusing a request (LLRPStatusError: e.g. an RF mode it does not have), llrpkit refusing the
# configuration against the reader's capabilities or the wire format (CapabilityError, MessageEncodeError).
READER_ERRORS = (LLRPConnectionError, LLRPTimeoutError, LLRPStatusError, CapabilityError, MessageEncodeError)
DRAIN_PERIOD_S = 0.005        # queue polling with batch_period_s 0 (one message per report)
DIAGNOSTICS_PERIOD_S = 1.0    # /diagnostics at least this often, and on every change of state
MAX_QUEUED_READS = 10_000     # readings waiting for the ROS side; beyond, the oldest are dropped (and counted)
SILENT_PERIODS = 3            # a reader silent this many keepalive periods is asked for its identification
STOP_TIMEOUT_S = 5.0          # destroy_node waits this long for the inventory to stop and the link to close

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


@dataclass(frozen=True)
class LinkState:
    """What /diagnostics says about the link."""

    level: bytes = WARN
    message: str = "starting"
    model: str = ""
    firmware: str = ""
    reads_total: int = 0
    reconnects: int = 0          # connections established after the first one (each follows a loss or failure)
    last_error: str = ""
    dropped_reads: int = 0       # readings the ROS side did not take in time (MAX_QUEUED_READS)


class ReaderLink:
    """The reader session on an asyncio loop in a background thread; the ROS side reads ``state()`` and takes
    ``readings`` (monotonic receipt time, Reading), ``changes`` (each new LinkState but a new read count, so a
    state that lasted less than a batch period is published too) and ``logs`` (level name, text)."""

    def __init__(self, params: LlrpReaderParameters) -> None:
        self.params = params
        self.endpoint = f"{params.host}:{params.port}"
        self.readings: deque[tuple[float, Reading]] = deque(maxlen=MAX_QUEUED_READS)
        self.changes: deque[LinkState] = deque(maxlen=1000)
        self.logs: deque[tuple[str, str]] = deque(maxlen=1000)
        self.streaming = False
        self.probes = 0              # liveness probes answered (tests watch it)
        self._lock = threading.Lock()
        self._state = LinkState(message=f"connecting to {self.endpoint}")
        self._loop = asyncio.new_event_loop()
        self._task: asyncio.Task[None] | None = None
        self._thread = threading.Thread(target=self._thread_main, name=f"llrp-{self.endpoint}", daemon=True)
        self._stopping = False
        self._last_heard = 0.0       # loop time of the last report or probe answer

    # ------------------------------------------------------------------------------------ both threads
    def state(self) -> LinkState:
        with self._lock:
            return self._state

    def _update(self, **values: Any) -> None:
        with self._lock:
            self._state = replace(self._state, **values)
            self.changes.append(self._state)

    def _count_read(self, dropped: bool) -> None:
        # Not a change: the read count reaches /diagnostics with the periodic status.
        with self._lock:
            self._state = replace(self._state, reads_total=self._state.reads_total + 1,
                                  dropped_reads=self._state.dropped_reads + int(dropped))

    def start(self) -> None:
        self._task = self._loop.create_task(self._run())
        self._thread.start()

    def stop(self) -> None:
        """Stop the inventory, close the connection and join the thread (idempotent)."""
        self._stopping = True
        if self._task is not None and self._thread.is_alive():
            # Cancelling the session task runs llrpkit's inventory clean-up (STOP_ROSPEC, DELETE_ROSPEC) and
            # then our close (CLOSE_CONNECTION), each bounded by llrpkit's own timeouts.
            self._loop.call_soon_threadsafe(self._task.cancel)
            self._thread.join(STOP_TIMEOUT_S)
        if not self._thread.is_alive() and not self._loop.is_closed():
            self._loop.close()

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    # ------------------------------------------------------------------------------------- loop thread
    def _thread_main(self) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._task)
        except asyncio.CancelledError:
            pass                       # stop(): the normal end
        except Exception as error:     # noqa: BLE001 -- a bug, not a reader problem: say so rather than vanish
            self._update(level=ERROR, message=f"driver stopped by an internal error: {error!r}; restart the node",
                         last_error=repr(error))
            self.logs.append(("fatal", f"driver thread stopped by an internal error: {error!r}"))
        finally:
            self.streaming = False
            self._loop.run_until_complete(self._loop.shutdown_asyncgens())

    async def _run(self) -> None:
        params = self.params
        backoff = Backoff(params.reconnect_initial_s, params.reconnect_max_s)
        connections = 0
        logged_error = ""            # the failure last logged: a reader that stays away is logged once
        while not self._stopping:
            self._update(level=WARN, message=f"reconnecting to {self.endpoint} (retry {backoff.failures})"
                         if backoff.failures else f"connecting to {self.endpoint}")
            reader = Reader(params.host, params.port, response_timeout=params.connect_timeout_s,
                            connect_timeout=params.connect_timeout_s)
            connected = False
            try:
                await reader.connect()
                # The reader sends a KEEPALIVE every period and llrpkit acknowledges each: a reader with link
                # monitoring (Impinj) drops a client whose acknowledgements stop, so a dead link does not leave it
                # refusing our reconnection ("a client connection already exists"). This end notices a dead link
                # in _watch.
                await reader.set_keepalive(max(1, round(params.keepalive_s * 1000)))
                connected = True
                connections += 1
                self._update(model=str(reader.model_number), firmware=reader.firmware,
                             reconnects=connections - 1,
                             message=f"connected to {self.endpoint}; starting the inventory")
                self.logs.append(("info", f"connected to {self.endpoint} (model {reader.model_number}, firmware "
                                          f"{reader.firmware}); inventory on antennas {params.antennas or 'all'}"))
                await self._stream(reader, backoff)
                error_text = "inventory stream ended"      # llrpkit's endless inventory does not end by itself
            except READER_ERRORS as error:
                error_text = f"{type(error).__name__}: {error}"
            finally:
                was_streaming = self.streaming
                self.streaming = False
                with contextlib.suppress(*READER_ERRORS, OSError):
                    await reader.close()
            if self._stopping:
                break
            delay = backoff.next_delay()
            what = ("connection lost" if was_streaming else "the inventory did not start" if connected
                    else "connection attempt failed")
            self._update(level=ERROR, message=f"{what}: {error_text}; retrying in {delay:.1f} s",
                         last_error=error_text)
            if was_streaming or error_text != logged_error:
                self.logs.append(("error", f"{self.endpoint}: {what}: {error_text}; retrying in {delay:.1f} s "
                                           f"(then up to every {params.reconnect_max_s:g} s; the same failure "
                                           f"is not logged again)"))
                logged_error = error_text
            await asyncio.sleep(delay)

    async def _stream(self, reader: Reader, backoff: Backoff) -> None:
        """Run the inventory and the liveness watch until one fails (its llrpkit error is raised)."""
        loop = asyncio.get_running_loop()
        self._last_heard = loop.time()
        table_hz = reader_frequency_table_hz(reader.capabilities)
        tasks = {asyncio.create_task(self._pump(reader, table_hz, backoff)),
                 asyncio.create_task(self._watch(reader, backoff))}
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
        for task in done:
            task.result()

    async def _pump(self, reader: Reader, table_hz: tuple[float, ...], backoff: Backoff) -> None:
        params = self.params
        tags = reader.inventory(
            antennas=params.antennas, session=params.session,
            search_mode=params.search_mode if params.search_mode >= 0 else None,
            mode_index=params.mode_index if params.mode_index >= 0 else None,
            # 0: no RFTransmitter, so the reader transmits at its default, the maximum on Impinj readers. Asking
            # for the table's maximum instead would also pin channel 1 in fixed-frequency regions (llrpkit sends
            # the power with hop table 1, channel 1).
            tx_power_dbm=params.tx_power_dbm if params.tx_power_dbm > 0.0 else None,
            include_phase=True)
        loop = asyncio.get_running_loop()
        async with contextlib.aclosing(tags):
            async for report in tags:
                self._last_heard = loop.time()
                self._count_read(dropped=len(self.readings) == MAX_QUEUED_READS)
                self.readings.append((time.monotonic(), reading_of(report, table_hz)))
                if not self.streaming:
                    self._mark_streaming(backoff)

    async def _watch(self, reader: Reader, backoff: Backoff) -> None:
        """Notice a dead link while no tag is in view: reports prove the link alive; after SILENT_PERIODS
        keepalive periods without one, the reader must answer a GET_READER_CONFIG (identification) within the
        response timeout, or llrpkit raises LLRPTimeoutError / LLRPConnectionError and the link is renewed."""
        loop = asyncio.get_running_loop()
        period = self.params.keepalive_s
        while True:
            await asyncio.sleep(period)
            if loop.time() - self._last_heard < SILENT_PERIODS * period:
                continue
            await reader.get_config(enums.GetReaderConfigRequestedData.Identification)
            self._last_heard = loop.time()
            self.probes += 1
            if not self.streaming:
                # The inventory was accepted (a refused ROSpec raises at once) and the reader answers: it runs,
                # with no tag in view.
                self._mark_streaming(backoff)

    def _mark_streaming(self, backoff: Backoff) -> None:
        self.streaming = True
        backoff.reset()
        self._update(level=DiagnosticStatus.OK, message=f"streaming from {self.endpoint}")


class LlrpReaderNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("llrp_reader", **node_options)
        self.params: LlrpReaderParameters = declare_parameters(self, LlrpReaderParameters)
        self.endpoint = f"{self.params.host}:{self.params.port}"
        self.reads_pub = self.create_publisher(TagReadArray, "rfid/reads", SENSOR_QOS)
        publish_static_frames(self, self.params.antenna_frames())
        undescribed = self.params.undescribed_ports()
        if undescribed:
            self.get_logger().warning(f"antenna ports {undescribed} have no antenna_positions / antenna_facing: no "
                                      f"frame for them on /tf_static")
        # Reliable like the other streams; diagnostic_aggregator's default subscription (reliable) matches it.
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", SENSOR_QOS)
        self.link = ReaderLink(self.params)
        # The steady clock: the reader's reports come in real time, whatever clock the node's stamps follow
        # (with use_sim_time and no /clock a sim-time timer would never drain them).
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(self.params.batch_period_s or DRAIN_PERIOD_S, self.drain, clock=steady)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics, clock=steady)
        self.link.start()
        self.get_logger().info(f"reading {self.endpoint}, antennas {self.params.antennas or 'all'}, batches of "
                               f"{self.params.batch_period_s:g} s on /rfid/reads")

    def drain(self) -> None:
        """Take what the loop thread queued: log its lines, publish the readings and any change of state."""
        while self.link.logs:
            self.log(*self.link.logs.popleft())
        queued: list[tuple[float, Reading]] = []
        while self.link.readings:
            queued.append(self.link.readings.popleft())
        if queued or (self.params.batch_period_s > 0.0 and self.link.streaming):
            self.publish_reads(queued)
        while self.link.changes:
            self.publish_diagnostics(self.link.changes.popleft())

    def log(self, level: str, text: str) -> None:
        # One call per severity: rclpy's logger refuses a call site whose severity changes between calls.
        logger = self.get_logger()
        if level == "info":
            logger.info(text)
        elif level == "error":
            logger.error(text)
        else:
            logger.fatal(text)

    def publish_reads(self, queued: list[tuple[float, Reading]]) -> None:
        now = self.get_clock().now()
        now_mono = time.monotonic()
        # Each reading is stamped with the node clock when it was received (now minus the time it waited in the
        # queue): the reader's own timestamps (first_seen_us) are on the reader's clock, which nothing keeps in
        # step with the robot's, while the receipt time is within the LAN latency (~1 ms) of the read and
        # comparable with every other sensor's stamps.
        readings = [self.tag_reading(reading, now, now_mono - received) for received, reading in queued]
        if self.params.batch_period_s > 0.0:
            self.reads_pub.publish(self.reads_message(readings, now))
        else:
            for reading in readings:
                self.reads_pub.publish(self.reads_message([reading], now))

    @staticmethod
    def tag_reading(reading: Reading, now: Time, age_s: float) -> TagReading:
        stamp = now - Duration(nanoseconds=min(round(age_s * 1e9), now.nanoseconds))
        return TagReading(stamp=stamp.to_msg(), tag_id=reading.tag_id, antenna=reading.antenna,
                          rssi_dbm=reading.rssi_dbm, phase_rad=reading.phase_rad, i=reading.i, q=reading.q,
                          frequency_hz=reading.frequency_hz)

    def reads_message(self, readings: list[TagReading], now: Time) -> TagReadArray:
        msg = TagReadArray(readings=readings)
        msg.header.stamp = now.to_msg()
        msg.header.frame_id = self.params.frame_id
        return msg

    def publish_diagnostics(self, state: LinkState | None = None) -> None:
        """One DiagnosticStatus of ``state`` (default: the current one)."""
        state = state or self.link.state()
        values = {"model": state.model, "firmware": state.firmware, "reads_total": str(state.reads_total),
                  "reconnects": str(state.reconnects), "last_error": state.last_error,
                  "dropped_reads": str(state.dropped_reads)}
        status = DiagnosticStatus(level=state.level, name=f"llrp_reader: {self.endpoint}", message=state.message,
                                  hardware_id=self.endpoint,
                                  values=[KeyValue(key=k, value=v) for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_pub.publish(msg)

    def destroy_node(self) -> None:
        # The loop first: it stops the inventory and closes the connection while the node is still whole.
        self.link.stop()
        if self.link.alive:
            self.get_logger().error(f"the reader session did not stop within {STOP_TIMEOUT_S:g} s; abandoning it")
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(LlrpReaderNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
