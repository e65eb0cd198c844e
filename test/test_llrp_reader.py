"""llrp_reader: the conversions of llrp_reports (units, EPC, I/Q, channel frequencies, back-off), and the node
against llrpkit's LLRP reader emulator on loopback -- reads from the emulated tag population, a dropped and
restored connection, an unreachable reader, a silent link that stops answering, a clean stop."""

from __future__ import annotations

import math
import socket
from collections.abc import Iterator
from typing import Any

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from llrpkit.emulator.core import EmulatedTag
from llrpkit.inventory import TagReport
from llrpkit.protocol import messages, params
from llrpkit.reader import Reader
from rclpy.parameter import Parameter

from rfidnav_common.ros import SENSOR_QOS
from rfidnav_drivers.llrp_reader_node import LlrpReaderNode
from rfidnav_drivers.llrp_reports import (
    Backoff,
    frequency_of,
    frequency_table_hz,
    iq_of,
    phase_rad_of,
    reader_frequency_table_hz,
    reading_of,
    tag_id_of,
)
from rfidnav_msgs.msg import TagReadArray, TagReading
from support.graph import Graph
from support.llrp import WAIT_S, EmulatorLoop

pytestmark = pytest.mark.tier("node")

TWO_PI = 2.0 * math.pi
# The emulator's hop table (FCC): 50 channels from 902.75 MHz in 500 kHz steps, channel index 1-50.
EMULATOR_TABLE_HZ = tuple(902.75e6 + 0.5e6 * k for k in range(50))
# Five tags on antennas 1 and 2 with distinct RSSIs, and one on antenna 3 only, which the node does not inventory.
POPULATION = {bytes.fromhex(f"E2801160600002000000000{k}"): (antennas, rssi)
              for k, antennas, rssi in [(1, (1,), -45.0), (2, (2,), -52.0), (3, (1, 2), -59.0), (4, (1,), -66.0),
                                        (5, (2,), -70.0)]}
ANTENNA_3_ONLY = bytes.fromhex("E28011606000020000000099")
NEW_TAG = bytes.fromhex("E280116060000200000000AA")   # only the emulator that replaces the dropped one has it


def tags_of(population: dict[bytes, tuple[tuple[int, ...], float]]) -> list[EmulatedTag]:
    return [EmulatedTag(epc=epc, antennas=antennas, rssi_dbm=rssi) for epc, (antennas, rssi) in population.items()]


# --------------------------------------------------------------------------------------------- conversions

@pytest.mark.tier("unit")
def test_phase_degrees_become_radians_in_the_half_open_turn() -> None:
    assert phase_rad_of(0.0) == 0.0
    assert phase_rad_of(90.0) == pytest.approx(math.pi / 2)
    assert phase_rad_of(180.0) == pytest.approx(math.pi)
    assert phase_rad_of(360.0) == 0.0, "a full turn is 0, not 2*pi"
    top = phase_rad_of(4095 * 360.0 / 4096)             # llrpkit's largest value (Impinj units 0-4095)
    assert top < TWO_PI and top == pytest.approx(TWO_PI * 4095 / 4096)
    assert phase_rad_of(-1e-17) == 0.0, "a rounding step below 0 must not come out as 2*pi"
    assert phase_rad_of(-90.0) == pytest.approx(1.5 * math.pi)
    assert math.isnan(phase_rad_of(None)) and math.isnan(phase_rad_of(math.nan))


@pytest.mark.tier("unit")
def test_epc_is_upper_case_hex_and_iq_follow_the_simulator_convention() -> None:
    assert tag_id_of(bytes.fromhex("e2801160600002abcdef0012")) == "E2801160600002ABCDEF0012"
    i, q = iq_of(-60.0, math.pi / 3)
    assert math.hypot(i, q) == pytest.approx(1e-3)      # 10^(-60/20)
    assert math.atan2(q, i) == pytest.approx(math.pi / 3)
    assert all(math.isnan(v) for v in iq_of(math.nan, 1.0) + iq_of(-50.0, math.nan))


@pytest.mark.tier("unit")
def test_a_tag_report_becomes_a_reading() -> None:
    table = (865.7e6, 866.3e6, 866.9e6, 867.5e6)
    report = TagReport(epc=bytes.fromhex("e2801160600002aa"), antenna=2, rssi_dbm=-55.5, channel_index=3,
                       phase_deg=90.0)
    reading = reading_of(report, table)
    assert (reading.tag_id, reading.antenna, reading.rssi_dbm) == ("E2801160600002AA", 2, -55.5)
    assert reading.phase_rad == pytest.approx(math.pi / 2) and reading.frequency_hz == 866.9e6
    assert reading.i == pytest.approx(0.0, abs=1e-12) and reading.q == pytest.approx(10 ** (-55.5 / 20))
    bare = reading_of(TagReport(epc=b"\x01\x02"), table)   # a report without the optional fields
    assert bare.tag_id == "0102" and bare.antenna == 0
    assert all(math.isnan(v) for v in (bare.rssi_dbm, bare.phase_rad, bare.i, bare.q, bare.frequency_hz))


@pytest.mark.tier("unit")
def test_channel_frequency_lookup_and_a_missing_index() -> None:
    table = frequency_table_hz(params.FrequencyInformation(hopping=True, frequency_hop_tables=[
        params.FrequencyHopTable(hop_table_id=1, frequency=[902_750 + 500 * k for k in range(50)])]))
    assert table == pytest.approx(EMULATOR_TABLE_HZ)
    assert frequency_of(1, table) == 902.75e6 and frequency_of(50, table) == 927.25e6
    for missing in (None, 0, 51, -1):
        assert math.isnan(frequency_of(missing, table)), missing
    assert math.isnan(frequency_of(1, ()))
    fixed = frequency_table_hz(params.FrequencyInformation(
        hopping=False, fixed_frequency_table=params.FixedFrequencyTable(frequency=[865_700, 866_300])))
    assert fixed == (865.7e6, 866.3e6)
    only = frequency_table_hz(params.FrequencyInformation(hopping=True, frequency_hop_tables=[
        params.FrequencyHopTable(hop_table_id=7, frequency=[915_250])]))
    assert only == (915.25e6,)
    ambiguous = frequency_table_hz(params.FrequencyInformation(hopping=True, frequency_hop_tables=[
        params.FrequencyHopTable(hop_table_id=2, frequency=[915_250]),
        params.FrequencyHopTable(hop_table_id=3, frequency=[920_250])]))
    assert ambiguous == (), "no table is known to be the one the channel indexes"
    assert frequency_table_hz(params.FrequencyInformation(hopping=False)) == ()
    assert frequency_table_hz(None) == ()


@pytest.mark.tier("unit")
def test_backoff_doubles_up_to_the_cap_and_starts_over_after_a_reset() -> None:
    backoff = Backoff(0.5, 10.0)
    assert [backoff.next_delay() for _ in range(7)] == [0.5, 1.0, 2.0, 4.0, 8.0, 10.0, 10.0]
    for _ in range(5000):                                 # a reader that stays away for days: no overflow
        assert backoff.next_delay() == 10.0
    backoff.reset()
    assert [backoff.next_delay() for _ in range(3)] == [0.5, 1.0, 2.0]
    assert Backoff(1.0, 1.0).next_delay() == 1.0
    for initial, cap in [(0.0, 1.0), (-1.0, 1.0), (2.0, 1.0), (math.nan, 1.0), (1.0, math.inf)]:
        with pytest.raises(ValueError):
            Backoff(initial, cap)


# -------------------------------------------------------------------------------------------- the emulator


@pytest.fixture
def emulators() -> Iterator[EmulatorLoop]:
    emulator_loop = EmulatorLoop()
    try:
        yield emulator_loop
    finally:
        emulator_loop.close()


@pytest.mark.tier("unit")
def test_the_emulator_reports_its_hop_table_in_its_capabilities(emulators: EmulatorLoop) -> None:
    emulator = emulators.start(tags_of(POPULATION))

    async def table() -> tuple[float, ...]:
        async with Reader("127.0.0.1", emulator.port) as reader:
            return reader_frequency_table_hz(reader.capabilities)
    assert emulators.run(table()) == pytest.approx(EMULATOR_TABLE_HZ)


# ----------------------------------------------------------------------------------------------- the node

class ReaderProbe:
    """The node under test and what it publishes on /rfid/reads and /diagnostics."""

    def __init__(self, graph: Graph, port: int, **overrides: Any) -> None:
        self.graph = graph
        values = {"host": "127.0.0.1", "port": port, "antennas": [1, 2], "connect_timeout_s": 2.0,
                  "reconnect_initial_s": 0.1, "reconnect_max_s": 0.4, "keepalive_s": 0.5, "frame_id": "reader",
                  **overrides}
        self.node: LlrpReaderNode = graph.add(LlrpReaderNode(context=graph.context, parameter_overrides=[
            Parameter(name, value=value) for name, value in values.items()]))
        self.messages: list[TagReadArray] = []
        self.statuses: list[DiagnosticStatus] = []
        graph.probe.create_subscription(TagReadArray, "/rfid/reads", self.messages.append, SENSOR_QOS)
        graph.probe.create_subscription(DiagnosticArray, "/diagnostics",
                                        lambda m: self.statuses.extend(m.status), SENSOR_QOS)
        graph.spin_until(lambda: self.statuses, "the first /diagnostics", timeout_s=WAIT_S)

    def readings(self, since: int = 0) -> list[TagReading]:
        return [r for m in self.messages[since:] for r in m.readings]

    def seen(self, since: int = 0) -> set[bytes]:
        return {bytes.fromhex(r.tag_id) for r in self.readings(since)}

    @property
    def status(self) -> DiagnosticStatus:
        return self.statuses[-1]

    def value(self, key: str, status: DiagnosticStatus | None = None) -> str:
        return {kv.key: kv.value for kv in (status or self.status).values}[key]

    def wait_status(self, level: bytes, what: str, since: int = 0, words: str = "") -> DiagnosticStatus:
        """The first status from index ``since`` on with this level (and these words in its message): a state may
        last only milliseconds (a refused connection), so not only the latest status is looked at."""
        def found() -> DiagnosticStatus | None:
            return next((s for s in self.statuses[since:] if s.level == level and words in s.message), None)
        self.graph.spin_until(lambda: found() is not None, what, timeout_s=WAIT_S)
        return found()


def check_readings(readings: list[TagReading], population: dict[bytes, tuple[tuple[int, ...], float]]) -> None:
    """Every reading is of a tag in the population, by an antenna that tag is on, with its RSSI (the emulator
    adds Gaussian noise of 1.5 dB), a phase in [0, 2*pi), I/Q of that phase and RSSI, a channel of the table."""
    for r in readings:
        epc = bytes.fromhex(r.tag_id)
        assert r.tag_id == r.tag_id.upper() and epc in population, r.tag_id
        antennas, rssi = population[epc]
        assert r.antenna in antennas, (r.tag_id, r.antenna)
        assert abs(r.rssi_dbm - rssi) < 8.0, (r.tag_id, r.rssi_dbm, rssi)
        assert 0.0 <= r.phase_rad < TWO_PI, r.phase_rad
        assert math.atan2(r.q, r.i) % TWO_PI == pytest.approx(r.phase_rad, abs=1e-9)
        assert math.hypot(r.i, r.q) == pytest.approx(10 ** (r.rssi_dbm / 20), rel=1e-9)
        assert any(r.frequency_hz == pytest.approx(f) for f in EMULATOR_TABLE_HZ), r.frequency_hz


def test_the_node_publishes_the_emulated_population(graph: Graph, emulators: EmulatorLoop) -> None:
    emulator = emulators.start(tags_of(POPULATION) + [EmulatedTag(epc=ANTENNA_3_ONLY, antennas=(3,))])
    reader = ReaderProbe(graph, emulator.port)
    reader.wait_status(DiagnosticStatus.OK, "diagnostics OK (streaming)")
    assert reader.status.name == f"llrp_reader: 127.0.0.1:{emulator.port}"
    assert (reader.value("model"), reader.value("firmware")) == ("700", "llrpkit-emu 0.1")
    graph.spin_until(lambda: reader.seen() == set(POPULATION) and len(reader.readings()) >= 200,
                     "200 reads and every tag of the population", timeout_s=WAIT_S)
    readings = reader.readings()
    check_readings(readings, POPULATION)
    assert ANTENNA_3_ONLY.hex().upper() not in {r.tag_id for r in readings}, "antenna 3 is not inventoried"
    assert {r.antenna for r in readings} == {1, 2}
    for epc, (_, rssi) in POPULATION.items():
        mean = [r.rssi_dbm for r in readings if r.tag_id == epc.hex().upper()]
        assert sum(mean) / len(mean) == pytest.approx(rssi, abs=1.5), epc.hex()
    for msg in reader.messages:
        assert msg.header.frame_id == "reader"
        for r in msg.readings:       # stamped when received, no later than the message
            assert (r.stamp.sec, r.stamp.nanosec) <= (msg.header.stamp.sec, msg.header.stamp.nanosec)
    graph.spin_until(lambda: int(reader.value("reads_total")) >= len(readings), "reads_total to count them",
                     timeout_s=WAIT_S)
    assert reader.value("reconnects") == "0" and reader.value("last_error") == ""


def test_the_node_notices_a_dropped_connection_and_reconnects(graph: Graph, emulators: EmulatorLoop) -> None:
    emulator = emulators.start(tags_of(POPULATION))
    port = emulator.port
    reader = ReaderProbe(graph, port)
    graph.spin_until(lambda: reader.seen() == set(POPULATION), "every tag of the population", timeout_s=WAIT_S)

    assert reader.status.level == DiagnosticStatus.OK
    dropped = len(reader.statuses)
    emulators.stop(emulator)                                  # the reader goes away
    lost = reader.wait_status(DiagnosticStatus.ERROR, "diagnostics to leave OK for ERROR after the drop", dropped)
    assert "connection lost" in lost.message and reader.value("last_error", lost), lost
    assert all(s.level != DiagnosticStatus.OK for s in reader.statuses[reader.statuses.index(lost):])
    retrying = len(reader.statuses)
    reader.wait_status(DiagnosticStatus.WARN, "a reconnection attempt (WARN)", retrying, "reconnecting")
    assert reader.node.link.alive

    population = {**POPULATION, NEW_TAG: ((1,), -50.0)}
    emulators.start(tags_of(population), port=port)           # back, on the same port
    back = reader.wait_status(DiagnosticStatus.OK, "diagnostics back to OK after the reconnection", retrying)
    assert int(reader.value("reconnects", back)) >= 1 and "streaming" in back.message
    since = len(reader.messages)
    graph.spin_until(lambda: NEW_TAG in reader.seen(since) and len(reader.readings(since)) >= 50,
                     "reads from the new connection", timeout_s=WAIT_S)
    check_readings(reader.readings(), population)
    assert len(graph.logged("llrp_reader", "connection lost")) == 1, "the loss is logged once"
    assert len(graph.logged("llrp_reader", "connected to")) == 2


def free_port() -> int:
    """A port nothing listens on (bound then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_an_unreachable_reader_gives_error_diagnostics_and_retries(graph: Graph) -> None:
    reader = ReaderProbe(graph, free_port(), reconnect_max_s=0.2)
    failed = reader.wait_status(DiagnosticStatus.ERROR, "ERROR diagnostics for a closed port")
    assert "cannot connect" in reader.value("last_error", failed), failed
    errors_before = sum(1 for s in reader.statuses if s.level == DiagnosticStatus.ERROR)
    graph.spin_until(lambda: sum(1 for s in reader.statuses if s.level == DiagnosticStatus.ERROR) >= errors_before + 3,
                     "three more failed attempts", timeout_s=WAIT_S)
    levels = {s.level for s in reader.statuses}
    assert levels == {DiagnosticStatus.WARN, DiagnosticStatus.ERROR}, levels
    assert any("reconnecting" in s.message for s in reader.statuses)
    assert reader.node.link.alive and not reader.messages, "no reads, and still trying"
    assert len(graph.logged("llrp_reader", "cannot connect")) == 1, "the same failure is logged once"
    assert reader.value("reconnects") == "0" and reader.value("model") == ""


def test_a_silent_reader_is_probed_and_a_dead_link_renewed(graph: Graph, emulators: EmulatorLoop) -> None:
    # No tag on the inventoried antennas: nothing but keepalives comes, so the node has to ask.
    emulator = emulators.start([EmulatedTag(epc=ANTENNA_3_ONLY, antennas=(3,))])
    reader = ReaderProbe(graph, emulator.port, keepalive_s=0.2, connect_timeout_s=1.0)
    reader.wait_status(DiagnosticStatus.OK, "OK once the silent reader answers a probe")
    graph.spin_until(lambda: reader.node.link.probes >= 3, "three answered probes", timeout_s=WAIT_S)
    assert reader.status.level == DiagnosticStatus.OK and not reader.readings()
    assert all(m.readings == [] for m in reader.messages) and reader.messages, "empty batches while streaming"
    # The reader stops answering (the link is dead while the socket stays open).
    dropped = len(reader.statuses)
    emulators.loop.call_soon_threadsafe(emulator.drop_next, messages.GET_READER_CONFIG)
    dead = reader.wait_status(DiagnosticStatus.ERROR, "ERROR when a probe is not answered", dropped)
    assert "LLRPTimeoutError" in reader.value("last_error", dead) and "connection lost" in dead.message, dead
    back = reader.wait_status(DiagnosticStatus.OK, "OK again on a new connection", reader.statuses.index(dead))
    assert reader.value("reconnects", back) == "1"


def test_one_message_per_report_and_a_clean_stop(graph: Graph, emulators: EmulatorLoop) -> None:
    emulator = emulators.start(tags_of(POPULATION))
    reader = ReaderProbe(graph, emulator.port, batch_period_s=0.0)
    graph.spin_until(lambda: len(reader.messages) >= 50, "50 messages", timeout_s=WAIT_S)
    assert all(len(m.readings) == 1 for m in reader.messages)
    check_readings(reader.readings(), POPULATION)
    node = reader.node
    graph.executor.remove_node(node)
    graph.nodes.remove(node)
    node.destroy_node()
    assert not node.link.alive, "destroy_node joins the reader thread"
    # The emulator saw the connection closed: a new client is accepted (it refuses a second one).
    async def connect_and_close() -> None:
        async with Reader("127.0.0.1", emulator.port):
            pass
    emulators.run(connect_and_close())


def test_a_refused_inventory_is_reported_and_retried_without_a_reset_backoff(graph: Graph,
                                                                              emulators: EmulatorLoop) -> None:
    emulator = emulators.start(tags_of(POPULATION))          # its power table: 10-30 dBm
    reader = ReaderProbe(graph, emulator.port, tx_power_dbm=5.0, reconnect_initial_s=0.05, reconnect_max_s=0.8)
    failed = reader.wait_status(DiagnosticStatus.ERROR, "ERROR for a power below the reader's minimum",
                                words="the inventory did not start")
    assert "CapabilityError" in reader.value("last_error", failed) and "5.0 dBm" in failed.message, failed
    graph.spin_until(lambda: sum(1 for s in reader.statuses if "retrying in 0.8 s" in s.message) >= 2,
                     "the back-off to reach its cap (connecting does not reset it; streaming would)",
                     timeout_s=WAIT_S)
    assert not reader.messages and reader.node.link.alive
    assert all(s.level != DiagnosticStatus.OK for s in reader.statuses)
    assert len(graph.logged("llrp_reader", "the inventory did not start")) == 1
