"""Parameters of the driver nodes (llrp_reader, create_base, wifi_scanner): typed, with defaults and descriptions,
importable without rclpy so the orchestrator validates a robot profile's parameter files against the same class.
config/params/llrp_reader.yaml, create_base.yaml and wifi_scanner.yaml document them."""

from __future__ import annotations

from dataclasses import dataclass

from rfidnav_common.config import (
    DBM,
    DURATION_S,
    MAX_DURATION_S,
    PORT,
    POSITIVE,
    RATE_HZ,
    Limits,
    param,
)
from rfidnav_common.errors import ParameterError
from rfidnav_common.frames import FACINGS, Frame, antenna_frames
from rfidnav_common.node_registry import LimitsSpeed, NodeRegistration, PublishesAntennaPorts


@dataclass(frozen=True)
class LlrpReaderParameters(PublishesAntennaPorts):
    host: str = param("the reader's address (an Impinj Speedway / R700 in LLRP mode)", "192.168.1.10")
    port: int = param("LLRP TCP port", 5084, PORT)
    antennas: list[int] = param("antenna ports to inventory (empty: all the reader has); they must cover every "
                                "port the nodes reading /rfid/reads use (heading_controller: 1, 2 and 3)",
                                [1, 2, 3], PORT)
    session: int = param("Gen2 session 0-3 (0-1 for a moving robot: tags answer every round)", 0, Limits(0, 3))
    search_mode: int = param("Impinj search mode (0: reader default, 1: single target, 2: dual target, "
                             "3: single target with suppression); -1: leave unset", 2, Limits(-1, 3))
    mode_index: int = param("RF mode table index (-1: the reader's default)", -1, Limits(-1, 65535))
    tx_power_dbm: float = param("transmit power [dBm] (0: the reader's maximum)", 0.0, DBM)
    frame_id: str = param("frame of /rfid/reads (antenna poses are relative to it)", "base_link")
    antenna_positions: list[float] = param(
        "x, y, z in frame_id of the antenna on port 1, 2, ... [m], concatenated: those inventoried are published on "
        "/tf_static as frame antenna_frame_prefix + port (paper 001's robot: left and right 6 cm apart, the floor "
        "antenna low)", [0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0, 0.05])
    antenna_facing: list[str] = param("boresight of the antenna on port 1, 2, ...: up, down, left or right",
                                      ["up", "up", "down"], Limits(choices=FACINGS))
    antenna_frame_prefix: str = param("frame of antenna port N: PREFIX + N", "rfid_antenna_")
    batch_period_s: float = param("reads are published together every this long [s] (0: one message per report)",
                                  0.02, Limits(0.0, MAX_DURATION_S))
    connect_timeout_s: float = param("give a connection attempt up after this long [s]", 5.0, DURATION_S)
    reconnect_initial_s: float = param("first wait before reconnecting after a drop [s]", 0.5, DURATION_S)
    reconnect_max_s: float = param("longest wait between reconnection attempts (doubling up to it) [s]", 10.0,
                                   DURATION_S)
    keepalive_s: float = param("ask the reader for a keepalive this often, to notice a dead link [s]", 1.0,
                               DURATION_S)

    def validate(self) -> None:
        if not self.host:
            raise ParameterError("host", "required (the reader's address)")
        if len(self.antenna_positions) % 3:
            raise ParameterError("antenna_positions", f"expected 3 numbers (x, y, z) per antenna, got "
                                                      f"{len(self.antenna_positions)}")
        if len(self.antenna_positions) != 3 * len(self.antenna_facing):
            raise ParameterError("", f"antenna_positions places {len(self.antenna_positions) // 3} antennas, "
                                     f"antenna_facing {len(self.antenna_facing)}: one of them is wrong (one entry "
                                     "per antenna on port 1, 2, ...; antenna_positions: 3 numbers)")
        if self.reconnect_max_s < self.reconnect_initial_s:
            raise ParameterError("", "reconnect_max_s must be at least reconnect_initial_s")

    def antenna_frames(self) -> list[Frame]:
        """The frames of the antennas inventoried (``antennas``; empty: every one described); a port without
        antenna_positions / antenna_facing has none (``undescribed_ports``)."""
        described = antenna_frames(self.frame_id, self.antenna_frame_prefix, range(1, len(self.antenna_facing) + 1),
                                   self.antenna_positions, self.antenna_facing)
        return [frame for port, frame in enumerate(described, start=1) if not self.antennas or port in self.antennas]

    def undescribed_ports(self) -> list[int]:
        return [port for port in self.antennas if port > len(self.antenna_facing)]

    def published_antenna_ports(self) -> tuple[str, tuple[int, ...]]:
        """The parameter naming the antenna ports whose reads reach /rfid/reads, and those ports (empty: every
        port the reader has, known only once it is connected). The scenario checks its consumers against them."""
        return "antennas", tuple(self.antennas)


OI_BAUDS = (300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 28800, 38400, 57600, 115200)   # the OI's baud codes 0-11


@dataclass(frozen=True)
class CreateBaseParameters(LimitsSpeed):
    port: str = param("serial port of the Open Interface (a USB serial cable: /dev/ttyUSB0)", "/dev/ttyUSB0")
    baud: int = param("OI baud rate (Create 2 / Roomba 600+: 115200)", 115200, Limits(choices=OI_BAUDS))
    mode: str = param("OI mode: safe (the base itself stops on cliffs and wheel drops) or full", "safe",
                      Limits(choices=("safe", "full")))
    sensor_rate_hz: float = param("sensor queries (bumps, cliffs, wheel drops, encoders) per second", 50.0,
                                  RATE_HZ)
    max_wheel_speed_mps: float = param("wheel speed limit [m/s] (the OI's is 0.5)", 0.5,
                                       Limits(0.0, 0.5, low_open=True))
    wheel_base_m: float = param("distance between the wheels [m] (Create 2: 0.235)", 0.235, POSITIVE)
    wheel_diameter_m: float = param("wheel diameter [m] (Create 2: 0.072)", 0.072, POSITIVE)
    counts_per_rev: float = param("encoder counts per wheel revolution (Create 2: 508.8)", 508.8, POSITIVE)
    command_timeout_s: float = param("watchdog: stop when no /cmd_vel arrived for this long [s]", 0.5, DURATION_S)
    odom_frame: str = param("frame of /odom", "odom")
    base_frame: str = param("the robot's frame (child of /odom)", "base_link")
    publish_tf: bool = param("publish odom -> base_link on /tf with each /odom (REP 105)", True)

    def speed_limit(self) -> tuple[str, float]:
        """The parameter that bounds the forward speed the base drives, and its value: no node may command more."""
        return "max_wheel_speed_mps", self.max_wheel_speed_mps

    def validate(self) -> None:
        if not self.port:
            raise ParameterError("port", "required (the serial device of the Open Interface)")


@dataclass(frozen=True)
class WifiScannerParameters:
    interface: str = param("wireless interface to scan (see `iw dev`)", "wlan0")
    period_s: float = param("time between scans [s] (a full scan takes 2-4 s)", 5.0, DURATION_S)
    trigger: bool = param("run `iw dev IFACE scan` (fresh results, needs CAP_NET_ADMIN) rather than `scan dump` "
                          "(the results of the system's last scan, no privilege)", True)
    iw_path: str = param("the iw program", "iw")
    timeout_s: float = param("give a scan up after this long [s]", 15.0, DURATION_S)
    frame_id: str = param("frame of /wifi/scan (the WiFi antenna)", "base_link")

    def validate(self) -> None:
        if not self.interface:
            raise ParameterError("interface", "required (e.g. wlan0)")


# The node executables of this package, as the rfidnav.nodes entry points of its setup.py register them
# (rfidnav_common.node_registry).
LLRP_READER = NodeRegistration("llrp_reader", LlrpReaderParameters, stepped=False)
CREATE_BASE = NodeRegistration("create_base", CreateBaseParameters, stepped=False)
WIFI_SCANNER = NodeRegistration("wifi_scanner", WifiScannerParameters, stepped=False)
