"""Parameters of the driver nodes (llrp_reader, create_base, wifi_scanner): typed, with defaults and descriptions,
importable without rclpy so the orchestrator validates a robot profile's parameter files against the same class.
config/params/llrp_reader.yaml, create_base.yaml and wifi_scanner.yaml document them."""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.config import param, require_positive
from rfidnav_common.errors import ParameterError
from rfidnav_common.frames import FACINGS, Frame, antenna_frames


@dataclass(frozen=True)
class LlrpReaderParameters:
    host: str = param("the reader's address (an Impinj Speedway / R700 in LLRP mode)", "192.168.1.10")
    port: int = param("LLRP TCP port", 5084)
    antennas: list[int] = param("antenna ports to inventory (empty: all the reader has); they must cover every "
                                "port the nodes reading /rfid/reads use (heading_controller: 1, 2 and 3)",
                                [1, 2, 3])
    session: int = param("Gen2 session 0-3 (0-1 for a moving robot: tags answer every round)", 0)
    search_mode: int = param("Impinj search mode (0: reader default, 1: single target, 2: dual target, "
                             "3: single target with suppression); -1: leave unset", 2)
    mode_index: int = param("RF mode table index (-1: the reader's default)", -1)
    tx_power_dbm: float = param("transmit power [dBm] (0: the reader's maximum)", 0.0)
    frame_id: str = param("frame of /rfid/reads (antenna poses are relative to it)", "base_link")
    antenna_positions: list[float] = param(
        "x, y, z in frame_id of the antenna on port 1, 2, ... [m], concatenated: those inventoried are published on "
        "/tf_static as frame antenna_frame_prefix + port (paper 001's robot: left and right 6 cm apart, the floor "
        "antenna low)", [0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0, 0.05])
    antenna_facing: list[str] = param("boresight of the antenna on port 1, 2, ...: up, down, left or right",
                                      ["up", "up", "down"])
    antenna_frame_prefix: str = param("frame of antenna port N: PREFIX + N", "rfid_antenna_")
    batch_period_s: float = param("reads are published together every this long [s] (0: one message per report)",
                                  0.02)
    connect_timeout_s: float = param("give a connection attempt up after this long [s]", 5.0)
    reconnect_initial_s: float = param("first wait before reconnecting after a drop [s]", 0.5)
    reconnect_max_s: float = param("longest wait between reconnection attempts (doubling up to it) [s]", 10.0)
    keepalive_s: float = param("ask the reader for a keepalive this often, to notice a dead link [s]", 1.0)

    def validate(self) -> None:
        if not self.host:
            raise ParameterError("host", "required (the reader's address)")
        if not 1 <= self.port <= 65535:
            raise ParameterError("port", f"a TCP port is 1..65535, got {self.port}")
        if any(not 1 <= a <= 65535 for a in self.antennas):
            raise ParameterError("antennas", f"ports are 1..65535, got {self.antennas}")
        if len(self.antenna_positions) != 3 * len(self.antenna_facing):
            raise ParameterError("antenna_positions", f"expected 3 numbers per antenna_facing entry "
                                 f"({3 * len(self.antenna_facing)}), got {len(self.antenna_positions)}")
        unknown = [facing for facing in self.antenna_facing if facing not in FACINGS]
        if unknown:
            raise ParameterError("antenna_facing", f"{unknown} not among {', '.join(FACINGS)}")
        if not 0 <= self.session <= 3:
            raise ParameterError("session", f"0..3, got {self.session}")
        require_positive(self, "connect_timeout_s", "reconnect_initial_s", "reconnect_max_s", "keepalive_s")
        if self.reconnect_max_s < self.reconnect_initial_s:
            raise ParameterError("", "reconnect_max_s must be at least reconnect_initial_s")
        if not (math.isfinite(self.batch_period_s) and self.batch_period_s >= 0.0):
            raise ParameterError("batch_period_s", f"must not be negative, got {self.batch_period_s}")

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


@dataclass(frozen=True)
class CreateBaseParameters:
    port: str = param("serial port of the Open Interface (a USB serial cable: /dev/ttyUSB0)", "/dev/ttyUSB0")
    baud: int = param("OI baud rate (Create 2 / Roomba 600+: 115200)", 115200)
    mode: str = param("OI mode: safe (the base itself stops on cliffs and wheel drops) or full", "safe")
    sensor_rate_hz: float = param("sensor queries (bumps, cliffs, wheel drops, encoders) per second", 50.0)
    max_wheel_speed_mps: float = param("wheel speed limit [m/s] (the OI's is 0.5)", 0.5)
    wheel_base_m: float = param("distance between the wheels [m] (Create 2: 0.235)", 0.235)
    wheel_diameter_m: float = param("wheel diameter [m] (Create 2: 0.072)", 0.072)
    counts_per_rev: float = param("encoder counts per wheel revolution (Create 2: 508.8)", 508.8)
    command_timeout_s: float = param("watchdog: stop when no /cmd_vel arrived for this long [s]", 0.5)
    odom_frame: str = param("frame of /odom", "odom")
    base_frame: str = param("the robot's frame (child of /odom)", "base_link")
    publish_tf: bool = param("publish odom -> base_link on /tf with each /odom (REP 105)", True)

    def validate(self) -> None:
        if not self.port:
            raise ParameterError("port", "required (the serial device of the Open Interface)")
        if self.mode not in ("safe", "full"):
            raise ParameterError("mode", f"'safe' or 'full', got '{self.mode}'")
        if self.baud <= 0:
            raise ParameterError("baud", f"must be positive, got {self.baud}")
        require_positive(self, "sensor_rate_hz", "max_wheel_speed_mps", "wheel_base_m", "wheel_diameter_m",
                         "counts_per_rev", "command_timeout_s")
        if self.max_wheel_speed_mps > 0.5:
            raise ParameterError("max_wheel_speed_mps", "the Open Interface takes at most 0.5, got "
                                 f"{self.max_wheel_speed_mps}")


@dataclass(frozen=True)
class WifiScannerParameters:
    interface: str = param("wireless interface to scan (see `iw dev`)", "wlan0")
    period_s: float = param("time between scans [s] (a full scan takes 2-4 s)", 5.0)
    trigger: bool = param("run `iw dev IFACE scan` (fresh results, needs CAP_NET_ADMIN) rather than `scan dump` "
                          "(the results of the system's last scan, no privilege)", True)
    iw_path: str = param("the iw program", "iw")
    timeout_s: float = param("give a scan up after this long [s]", 15.0)
    frame_id: str = param("frame of /wifi/scan (the WiFi antenna)", "base_link")

    def validate(self) -> None:
        if not self.interface:
            raise ParameterError("interface", "required (e.g. wlan0)")
        require_positive(self, "period_s", "timeout_s")
