"""The iRobot Create 2 / Roomba 600+ Open Interface (OI) as pure functions: the bytes create_base sends, the
sensor reply it reads, the wheel-speed limit, encoder wrap-around and the wheel odometry.

No rclpy here, so every conversion is unit-tested without a robot and the node stays a thin adapter. Facts from
the iRobot Create 2 Open Interface specification: opcodes below; multi-byte values are big-endian; Drive Direct
takes signed mm/s in -500..500, right wheel first; encoder counts are 16-bit and roll over.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

from rfidnav_common import base_safety as safety

# ------------------------------------------------------------------------------------------------ opcodes
START = 128          # enter the OI (Passive mode); required before any other command
SAFE = 131           # Safe mode: driving allowed, the base itself stops on cliffs and wheel drops
FULL = 132           # Full mode: driving allowed, no safety reaction by the base
STOP = 173           # leave the OI (Off mode): the base stops listening to drive commands
DRIVE_DIRECT = 145   # [right high, right low, left high, left low], signed mm/s
SENSORS = 142        # [packet id]: one packet (unused: Query List asks for several in one round trip)
QUERY_LIST = 149     # [n, id1..idn]: the packets' bytes in order, no header, no checksum

MODE_OPCODES = {"safe": SAFE, "full": FULL}
MAX_WHEEL_MM_S = 500                 # the OI's Drive Direct range

# ------------------------------------------------------------------------------------------------ packets
BUMPS_AND_WHEEL_DROPS = 7            # bit0 bump right, bit1 bump left, bit2 wheel drop right, bit3 wheel drop left
CLIFF_LEFT, CLIFF_FRONT_LEFT, CLIFF_FRONT_RIGHT, CLIFF_RIGHT = 9, 10, 11, 12   # 0/1 each
LEFT_ENCODER, RIGHT_ENCODER = 43, 44  # unsigned 16-bit counts, rolling over 65535 -> 0 (and back)
PACKET_SIZES = {BUMPS_AND_WHEEL_DROPS: 1, CLIFF_LEFT: 1, CLIFF_FRONT_LEFT: 1, CLIFF_FRONT_RIGHT: 1, CLIFF_RIGHT: 1,
                LEFT_ENCODER: 2, RIGHT_ENCODER: 2}
SENSOR_PACKETS: tuple[int, ...] = (BUMPS_AND_WHEEL_DROPS, CLIFF_LEFT, CLIFF_FRONT_LEFT, CLIFF_FRONT_RIGHT,
                                   CLIFF_RIGHT, LEFT_ENCODER, RIGHT_ENCODER)
ENCODER_MODULUS = 1 << 16

def query_list_command(packets: tuple[int, ...] = SENSOR_PACKETS) -> bytes:
    """Query List for ``packets``: one request and one fixed-size reply per sensor cycle, so a reply is read
    by its length alone (the OI's replies carry no header to resynchronise on)."""
    return bytes([QUERY_LIST, len(packets), *packets])


def reply_size(packets: tuple[int, ...] = SENSOR_PACKETS) -> int:
    """Bytes of the Query List reply for ``packets`` (9 for SENSOR_PACKETS)."""
    return sum(PACKET_SIZES[packet] for packet in packets)


def mode_command(mode: str) -> bytes:
    """Start then Safe or Full: the OI ignores drive commands until it is in one of those two modes."""
    return bytes([START, MODE_OPCODES[mode]])


def drive_direct_command(right_mps: float, left_mps: float) -> bytes:
    """Drive Direct with the wheel speeds in m/s, right first as the OI wants it; each is rounded to mm/s and
    clamped to the OI's +-500 (a last guard: wheel_speeds already keeps them within the configured limit)."""
    def mm_s(speed_mps: float) -> int:
        if not math.isfinite(speed_mps):
            raise ValueError(f"drive_direct_command: wheel speed {speed_mps} is not finite")
        return max(-MAX_WHEEL_MM_S, min(MAX_WHEEL_MM_S, round(max(-1.0, min(1.0, speed_mps)) * 1000.0)))
    return struct.pack(">Bhh", DRIVE_DIRECT, mm_s(right_mps), mm_s(left_mps))


STOP_DRIVING = drive_direct_command(0.0, 0.0)


@dataclass(frozen=True)
class WheelSpeeds:
    left_mps: float
    right_mps: float


def wheel_speeds(linear_mps: float, angular_radps: float, wheel_base_m: float, max_wheel_mps: float) -> WheelSpeeds:
    """Differential-drive wheel speeds v -+ w*b/2 of a body velocity, both scaled down by the same factor when
    either would exceed ``max_wheel_mps``: the robot then drives the commanded arc (same curvature) more
    slowly, rather than a different arc, which clamping each wheel on its own would give. Any finite command
    gives finite speeds (the faster wheel's |v| + |w b/2| is formed halved, so 1e308 m/s does not overflow)."""
    if not (math.isfinite(linear_mps) and math.isfinite(angular_radps)):
        raise ValueError(f"wheel_speeds: ({linear_mps}, {angular_radps}) is not a finite velocity")
    half = angular_radps * (wheel_base_m / 2.0)
    half_fastest = abs(linear_mps) / 2.0 + abs(half) / 2.0
    if half_fastest > max_wheel_mps / 2.0:
        scale = max_wheel_mps / 2.0 / half_fastest
        linear_mps, half = linear_mps * scale, half * scale
    return WheelSpeeds(linear_mps - half, linear_mps + half)


@dataclass(frozen=True)
class SensorState:
    """One Query List reply of SENSOR_PACKETS."""
    bump_left: bool
    bump_right: bool
    wheel_drop_left: bool
    wheel_drop_right: bool
    cliff_left: bool
    cliff_front_left: bool
    cliff_front_right: bool
    cliff_right: bool
    left_count: int           # raw 16-bit encoder counts
    right_count: int

    def conditions(self) -> dict[str, bool]:
        """Each safety condition (BaseEvent name, rfidnav_common.base_safety) and whether it holds."""
        return {safety.BUMP_LEFT: self.bump_left, safety.BUMP_RIGHT: self.bump_right,
                safety.CLIFF_LEFT: self.cliff_left, safety.CLIFF_FRONT_LEFT: self.cliff_front_left,
                safety.CLIFF_FRONT_RIGHT: self.cliff_front_right, safety.CLIFF_RIGHT: self.cliff_right,
                safety.WHEEL_DROP_LEFT: self.wheel_drop_left, safety.WHEEL_DROP_RIGHT: self.wheel_drop_right}


def decode_sensors(reply: bytes) -> SensorState:
    """The reply to ``query_list_command()``; a ValueError for a reply of the wrong length or with values no
    packet can hold (reserved bump bits set, a cliff byte other than 0/1): that is a reply read out of step
    with the stream, whose encoder counts must not reach the odometry."""
    expected = reply_size()
    if len(reply) != expected:
        raise ValueError(f"sensor reply of {len(reply)} bytes, expected {expected}")
    bumps, cliff_l, cliff_fl, cliff_fr, cliff_r, left, right = struct.unpack(">BBBBBHH", reply)
    if bumps & 0xF0 or any(c > 1 for c in (cliff_l, cliff_fl, cliff_fr, cliff_r)):
        raise ValueError(f"sensor reply out of step: {reply.hex(' ')}")
    return SensorState(bump_left=bool(bumps & 0x02), bump_right=bool(bumps & 0x01),
                       wheel_drop_left=bool(bumps & 0x08), wheel_drop_right=bool(bumps & 0x04),
                       cliff_left=bool(cliff_l), cliff_front_left=bool(cliff_fl), cliff_front_right=bool(cliff_fr),
                       cliff_right=bool(cliff_r), left_count=left, right_count=right)


def encoder_delta(previous: int, current: int) -> int:
    """Signed counts travelled between two 16-bit readings, across the rollover either way (65535 -> 0 going
    forward, 0 -> 65535 backing up): the shortest way round, which is right while a wheel turns less than half
    the counter (32768 counts, ~14.6 m) between two readings."""
    return (current - previous + ENCODER_MODULUS // 2) % ENCODER_MODULUS - ENCODER_MODULUS // 2


@dataclass(frozen=True)
class WheelGeometry:
    wheel_base_m: float = 0.235
    wheel_diameter_m: float = 0.072
    counts_per_rev: float = 508.8

    @property
    def metres_per_count(self) -> float:
        return math.pi * self.wheel_diameter_m / self.counts_per_rev


@dataclass(frozen=True)
class Pose:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


def integrate(pose: Pose, left_m: float, right_m: float, wheel_base_m: float) -> Pose:
    """Unicycle step for wheel travels ``left_m`` and ``right_m``: forward (l + r)/2 along the mid-step heading,
    turn (r - l)/b. The mid-step heading makes a constant-curvature step exact in distance and second-order in
    position, so odometry does not depend on how often the base is asked."""
    distance = (left_m + right_m) / 2.0
    turn = (right_m - left_m) / wheel_base_m
    heading = pose.yaw + turn / 2.0
    yaw = math.atan2(math.sin(pose.yaw + turn), math.cos(pose.yaw + turn))
    return Pose(pose.x + distance * math.cos(heading), pose.y + distance * math.sin(heading), yaw)


@dataclass(frozen=True)
class OdometryStep:
    pose: Pose
    linear_mps: float         # body velocity over the step (0 when the step has no duration)
    angular_radps: float


@dataclass
class EncoderOdometry:
    """Wheel odometry from successive encoder readings: the first reading only sets the reference (the counts
    at start-up are wherever the base left them), every later one moves the pose by the wrapped deltas."""
    geometry: WheelGeometry = field(default_factory=WheelGeometry)
    pose: Pose = field(default_factory=Pose)
    last_counts: tuple[int, int] | None = None

    def update(self, left_count: int, right_count: int, dt_s: float) -> OdometryStep:
        if self.last_counts is None:
            self.last_counts = (left_count, right_count)
            return OdometryStep(self.pose, 0.0, 0.0)
        per_count = self.geometry.metres_per_count
        left_m = encoder_delta(self.last_counts[0], left_count) * per_count
        right_m = encoder_delta(self.last_counts[1], right_count) * per_count
        self.last_counts = (left_count, right_count)
        self.pose = integrate(self.pose, left_m, right_m, self.geometry.wheel_base_m)
        if dt_s <= 0.0:
            return OdometryStep(self.pose, 0.0, 0.0)
        return OdometryStep(self.pose, (left_m + right_m) / 2.0 / dt_s,
                            (right_m - left_m) / self.geometry.wheel_base_m / dt_s)


def counts_for(distance_m: float, geometry: WheelGeometry) -> float:
    """Encoder counts for a wheel travel (the inverse of metres_per_count), for simulators and tests."""
    return distance_m / geometry.metres_per_count
