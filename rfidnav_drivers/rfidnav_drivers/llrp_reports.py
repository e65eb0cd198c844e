"""What llrp_reader makes of an LLRP reader's tag reports, without rclpy: one Reading per llrpkit TagReport in the
units of rfidnav_msgs/TagReading, the channel-to-frequency table from the reader's capabilities, and the
reconnection back-off schedule.

Units. llrpkit gives the Impinj RF phase angle (0-4095 over one turn) as degrees in [0, 360) and the Impinj peak
RSSI (centi-dBm) as dBm. The reading carries the phase in radians in [0, 2*pi) and the baseband I/Q the simulator
uses (rfidnav_sim.rfid_model): amplitude a = 10^(rssi_dbm / 20), i = a*cos(phase), q = a*sin(phase).

Frequency. A report names its channel by a 1-based index into the reader's frequency table (LLRP ChannelIndex):
the hop table in a frequency-hopping region (FCC: 50 channels 902.75-927.25 MHz), the fixed frequency table
otherwise (ETSI: 4 channels), both in kHz in GET_READER_CAPABILITIES_RESPONSE. A read whose channel is not in
the table (no index reported, an index past its end, a reader with several hop tables and none the one llrpkit
selects) gets frequency_hz = NaN, never 0 or a guess: ranging from phase divides by the frequency, and a NaN is
what the rfidnav consumers already drop and count as a bad read, where a 0 would give an infinite range and a
wrong channel a silently wrong one. Likewise a report without RSSI or phase gets NaN there and in I/Q.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from llrpkit.inventory import TagReport
from llrpkit.protocol import params
from llrpkit.reader import ReaderCapabilities

TWO_PI = 2.0 * math.pi
# The hop table llrpkit's inventory names in its RFTransmitter (build_rospec's hop_table_id), and the only one an
# Impinj reader has in a hopping region.
HOP_TABLE_ID = 1


@dataclass(frozen=True)
class Reading:
    """One tag seen by one antenna, as rfidnav_msgs/TagReading carries it (without the stamp)."""

    tag_id: str          # EPC as upper-case hex
    antenna: int         # antenna port, 1-based as on the reader (0: the report named none)
    rssi_dbm: float      # peak RSSI [dBm] (NaN: not reported)
    phase_rad: float     # carrier phase [rad] in [0, 2*pi) (NaN: not reported)
    i: float             # a*cos(phase), a = 10^(rssi_dbm/20)
    q: float             # a*sin(phase)
    frequency_hz: float  # carrier frequency of the read's channel [Hz] (NaN: channel not in the reader's table)


def tag_id_of(epc: bytes) -> str:
    """The EPC as upper-case hex, the tag ids of rfidnav maps ("E2801160600002...")."""
    return epc.hex().upper()


def phase_rad_of(phase_deg: float | None) -> float:
    """Degrees (llrpkit: 0-360) to radians in [0, 2*pi); 360 degrees is 0. NaN when the report had no phase."""
    if phase_deg is None or not math.isfinite(phase_deg):
        return math.nan
    phase = math.radians(phase_deg) % TWO_PI
    # A value a rounding step below 0 (or 2*pi itself) comes out of % as 2*pi: the half-open interval wants 0.
    return 0.0 if phase >= TWO_PI else phase


def iq_of(rssi_dbm: float, phase_rad: float) -> tuple[float, float]:
    """Baseband (i, q) of a read with this RSSI and phase: amplitude 10^(rssi_dbm/20), the simulator's convention."""
    amplitude = 10.0 ** (rssi_dbm / 20.0)
    return amplitude * math.cos(phase_rad), amplitude * math.sin(phase_rad)


def frequency_table_hz(info: params.FrequencyInformation | None) -> tuple[float, ...]:
    """The channel frequencies [Hz] a report's 1-based channel index points into, from the capabilities'
    FrequencyInformation: hop table HOP_TABLE_ID (or the only hop table) when hopping, the fixed table otherwise;
    empty when that table is not there (every read then gets NaN)."""
    if info is None:
        return ()
    if info.hopping:
        tables = {table.hop_table_id: table for table in info.frequency_hop_tables}
        table = tables.get(HOP_TABLE_ID) or (info.frequency_hop_tables[0] if len(tables) == 1 else None)
        khz = table.frequency if table is not None else []
    else:
        khz = info.fixed_frequency_table.frequency if info.fixed_frequency_table is not None else []
    return tuple(f * 1e3 for f in khz)


def reader_frequency_table_hz(capabilities: ReaderCapabilities) -> tuple[float, ...]:
    """frequency_table_hz of a connected reader. llrpkit's ReaderCapabilities keeps only the fixed table, so the
    hop tables are read from the raw GET_READER_CAPABILITIES_RESPONSE it exposes."""
    regulatory = capabilities.raw.regulatory_capabilities
    uhf = regulatory.uhf_band_capabilities if regulatory is not None else None
    return frequency_table_hz(uhf.frequency_information if uhf is not None else None)


def frequency_of(channel_index: int | None, table_hz: Sequence[float]) -> float:
    """The frequency [Hz] of a 1-based channel index; NaN when there is none or the table does not cover it."""
    if channel_index is None or not 1 <= channel_index <= len(table_hz):
        return math.nan
    return float(table_hz[channel_index - 1])


def reading_of(report: TagReport, table_hz: Sequence[float]) -> Reading:
    """The Reading of one llrpkit TagReport, with the frequency from the reader's table (frequency_table_hz)."""
    rssi = float(report.rssi_dbm) if report.rssi_dbm is not None else math.nan
    phase = phase_rad_of(report.phase_deg)
    i, q = iq_of(rssi, phase)
    return Reading(tag_id=tag_id_of(report.epc), antenna=report.antenna or 0, rssi_dbm=rssi, phase_rad=phase,
                   i=i, q=q, frequency_hz=frequency_of(report.channel_index, table_hz))


class Backoff:
    """Waits between reconnection attempts: ``initial_s`` after the first failure, doubling with each further
    failure up to ``max_s``; ``reset`` (once a connection works again) starts over at ``initial_s``."""

    def __init__(self, initial_s: float, max_s: float) -> None:
        if not (math.isfinite(initial_s) and initial_s > 0.0):
            raise ValueError(f"initial_s: must be positive, got {initial_s}")
        if not (math.isfinite(max_s) and max_s >= initial_s):
            raise ValueError(f"max_s: must be at least initial_s ({initial_s}), got {max_s}")
        self.initial_s = initial_s
        self.max_s = max_s
        self.failures = 0

    def next_delay(self) -> float:
        """The wait before the next attempt, counting one more failure."""
        # min() before the power would overflow a float after ~1000 failures of a reader that stays away.
        delay = min(self.max_s, self.initial_s * 2.0 ** min(self.failures, 64))
        self.failures += 1
        return delay

    def reset(self) -> None:
        self.failures = 0
