"""Every number and frame a node takes from a message, a service request or an action goal, checked before use.

A value is refused (:class:`BadInput`, naming the field and the value) when it is NaN or infinite, or finite but
beyond what any robot of this suite produces: a coordinate beyond MAX_COORDINATE_M, an RSS outside RSS_DBM, a
carrier frequency outside RF_FREQUENCY_HZ, a quaternion that is not a rotation. A message is refused too when its
header names another frame than the one the node expects (REP 105: /odom in ``odom`` with child ``base_link``,
ground truth and estimates in ``map``, the robot's sensors in their mounting frames: rfidnav_common.frames). A
node drops what is refused -- the whole message, or one read of a round -- and counts it in its :class:`Drops`,
which warns once at the first drop of each input and then at most every WARN_PERIOD_S with the count.

Phases and angles are wrapped, not refused, whatever their size (``math.fmod`` and ``math.remainder`` are exact for
any finite value). Velocity commands beyond the robot's limits are clamped (:func:`velocity`: both components
scaled by one factor, so the robot drives the commanded arc more slowly) and counted as clamped; a non-finite
one is dropped. No rclpy here: messages are read by their fields only.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from rfidnav_common.errors import RfidnavError
from rfidnav_common.frames import BASE_FRAME, COMPASS_FRAMES, ODOM_FRAME, READER_FRAME, WIFI_FRAME
from rfidnav_common.geometry import quaternion_to_yaw, wrap_angle

# Any position, pose or distance [m]: 100 km is beyond any building or campus a robot of this suite maps, and the
# squares and sums of such values stay far from overflowing (1e308 m does not: its square is infinite).
MAX_COORDINATE_M = 1e5
# Received power [dBm]: below -150 no receiver hears anything (thermal noise over 1 Hz is -174 dBm, real channels
# are far wider); above +30 more than a legal transmitter radiates would arrive at the antenna.
RSS_DBM = (-150.0, 30.0)
# How far a message's stamp may be from the node's clock [s]: more than any lag of a run's graph (the stepped clock
# lets an observer lag a second; a free-running clock a few), less than any stamp from another run or era.
STAMP_TOLERANCE_S = 60.0
# Carrier frequencies [Hz]: LF RFID (125 kHz) to millimetre-wave WiFi (60 GHz), with room on both sides.
RF_FREQUENCY_HZ = (1e3, 1e11)
# A unit quaternion, as every publisher normalises it; further from norm 1 than this it is not a rotation.
QUATERNION_NORM_TOLERANCE = 0.05
WARN_PERIOD_S = 5.0
TWO_PI = 2.0 * math.pi


class BadInput(RfidnavError, ValueError):
    """A value or frame a node cannot use; the message names the field and what is wrong with it. A ValueError
    too, as the cores' own checks raise."""


def number(value: Any, field: str) -> float:
    """``value`` as a finite float, or BadInput."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BadInput(f"{field}: expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise BadInput(f"{field}: {value} is not finite")
    return number


def bounded(value: Any, field: str, low: float, high: float, unit: str) -> float:
    """A finite number within [low, high], or BadInput naming the range."""
    checked = number(value, field)
    if not low <= checked <= high:
        raise BadInput(f"{field}: {checked:g} {unit} is outside [{low:g}, {high:g}] {unit}")
    return checked


def coordinate(value: Any, field: str) -> float:
    """A position component [m] within +-MAX_COORDINATE_M."""
    return bounded(value, field, -MAX_COORDINATE_M, MAX_COORDINATE_M, "m")


def length(value: Any, field: str) -> float:
    """A distance [m] in [0, MAX_COORDINATE_M]."""
    return bounded(value, field, 0.0, MAX_COORDINATE_M, "m")


def point(x: Any, y: Any, field: str) -> tuple[float, float]:
    return coordinate(x, f"{field}.x"), coordinate(y, f"{field}.y")


def angle(value: Any, field: str) -> float:
    """A finite angle of any size, wrapped to (-pi, pi]."""
    return wrap_angle(number(value, field))


def phase(value: Any, field: str) -> float:
    """A finite phase of any size, wrapped to [0, 2 pi) (exactly: fmod is exact for every finite float)."""
    wrapped = math.fmod(number(value, field), TWO_PI)
    if wrapped < 0.0:
        wrapped += TWO_PI
    return 0.0 if wrapped >= TWO_PI else wrapped


def rss_dbm(value: Any, field: str) -> float:
    return bounded(value, field, *RSS_DBM, "dBm")


def frequency_hz(value: Any, field: str) -> float:
    return bounded(value, field, *RF_FREQUENCY_HZ, "Hz")


def yaw(q: Any, field: str) -> float:
    """The yaw of a geometry_msgs Quaternion ``q`` that is a rotation: finite components, norm 1 within
    QUATERNION_NORM_TOLERANCE (an all-zero or a 1e308 quaternion gives some atan2, but no heading)."""
    components = [number(getattr(q, axis), f"{field}.{axis}") for axis in "xyzw"]
    norm = math.hypot(*components) if all(abs(c) <= 2.0 for c in components) else math.inf
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise BadInput(f"{field}: quaternion of norm {norm:.6g} is not a rotation")
    return quaternion_to_yaw(*components)


def frame(frame_id: str, expected: str | Collection[str], field: str = "header.frame_id") -> str:
    """``frame_id`` when it is the expected frame (or one of them), else BadInput naming both."""
    allowed = (expected,) if isinstance(expected, str) else tuple(expected)
    if frame_id not in allowed:
        raise BadInput(f"{field}: frame '{frame_id}', expected " + " or ".join(f"'{f}'" for f in allowed))
    return frame_id


def planar_pose(pose: Any, field: str) -> tuple[float, float, float]:
    """(x, y, yaw) of a geometry_msgs Pose, checked."""
    return (coordinate(pose.position.x, f"{field}.position.x"), coordinate(pose.position.y, f"{field}.position.y"),
            yaw(pose.orientation, f"{field}.orientation"))


def odometry_pose(msg: Any, frame_id: str = ODOM_FRAME, child_frame_id: str = BASE_FRAME) -> tuple[float, float, float]:
    """(x, y, yaw) of a nav_msgs Odometry in ``frame_id`` (``odom`` for /odom, ``map`` for ground truth) of the
    robot's ``child_frame_id``, checked."""
    frame(msg.header.frame_id, frame_id)
    frame(msg.child_frame_id, child_frame_id, "child_frame_id")
    return planar_pose(msg.pose.pose, "pose")


@dataclass(frozen=True)
class TagRead:
    """One read of a TagReadArray, checked: what the nodes steer and localize on. A measurement the reader did
    not report is NaN (the LLRP driver's convention: no phase or RSSI in the report, a channel outside its
    hop table); a node that needs it asks for it (``required``) and drops the read without it."""
    tag_id: str
    antenna: int            # 1-based port
    phase_rad: float        # [0, 2 pi): atan2(Q, I) (paper 001 eq. 1), or the reported phase when I = Q = 0
    rssi_dbm: float
    frequency_hz: float


READ_MEASUREMENTS = ("phase_rad", "rssi_dbm", "frequency_hz")


def _reported(value: Any, field: str, check: Callable[[Any, str], float]) -> float:
    """NaN (not reported) as it is; anything else through ``check`` (infinite or out of range: BadInput)."""
    return math.nan if isinstance(value, float) and math.isnan(value) else check(value, field)


def tag_read(read: Any, field: str = "reading", required: Collection[str] = READ_MEASUREMENTS) -> TagRead:
    """A rfidnav_msgs TagReading, checked: a tag id, a port from 1, I/Q finite (any scale: reader units) or both NaN,
    an RSS and a carrier frequency in their physical ranges; the phase wrapped. A measurement named in
    ``required`` must be reported; the others may be NaN (not reported)."""
    if not read.tag_id:
        raise BadInput(f"{field}.tag_id: empty")
    if read.antenna < 1:
        raise BadInput(f"{field}.antenna: port {read.antenna} (ports are 1-based)")
    reported = _reported(read.phase_rad, f"{field}.phase_rad", phase)
    if isinstance(read.i, float) and isinstance(read.q, float) and math.isnan(read.i) and math.isnan(read.q):
        measured_phase = reported
    else:
        i, q = number(read.i, f"{field}.i"), number(read.q, f"{field}.q")
        measured_phase = phase(math.atan2(q, i), f"{field}.i/q") if (i or q) else reported
    checked = TagRead(read.tag_id, int(read.antenna), measured_phase,
                      _reported(read.rssi_dbm, f"{field}.rssi_dbm", rss_dbm),
                      _reported(read.frequency_hz, f"{field}.frequency_hz", frequency_hz))
    missing = [name for name in required if math.isnan(getattr(checked, name))]
    if missing:
        raise BadInput(f"{field}.{missing[0]}: not reported (NaN), and this node needs it")
    return checked


def seconds_of(stamp: Any) -> float:
    """A builtin_interfaces/Time in seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def stamp_near(stamp_s: float, now_s: float, field: str = "header.stamp") -> float:
    """A message's stamp [s], refused (BadInput) when more than STAMP_TOLERANCE_S from the node's clock ``now_s``:
    a node that takes stamps as time (the round's own moment, not its arrival) must not take one from another era
    (one round stamped 2^31 s aborted a route: "no inventory rounds for 2147483635.7 s")."""
    if not abs(stamp_s - now_s) <= STAMP_TOLERANCE_S:
        raise BadInput(f"{field}: {stamp_s:.3f} s is {stamp_s - now_s:+.1f} s from this node's clock "
                       f"({now_s:.3f} s), more than {STAMP_TOLERANCE_S:g} s")
    return stamp_s


def round_reads(msg: Any, drops: Drops, now_s: float | None = None, ports: Collection[int] | None = None,
                where: str = "/rfid/reads", required: Collection[str] = ()) -> list[TagRead] | None:
    """The checked reads of a rfidnav_msgs TagReadArray (of ``ports`` only, when given), each read that fails
    :func:`tag_read` (with ``required``: the measurements this node uses) dropped and counted; None, the round
    dropped and counted, when it is not in READER_FRAME or, for a node that takes the round's stamp as time (it
    gives its clock, ``now_s``), when the stamp is far from that clock (:func:`stamp_near`)."""
    try:
        frame(msg.header.frame_id, READER_FRAME)
        if now_s is not None:
            stamp_near(seconds_of(msg.header.stamp), now_s)
    except BadInput as error:
        drops.drop(where, error)
        return None
    reads: list[TagRead] = []
    problems: list[BadInput] = []
    for index, reading in enumerate(msg.readings):
        if ports is not None and reading.antenna not in ports:
            continue
        try:
            reads.append(tag_read(reading, f"readings[{index}]", required))
        except BadInput as error:
            problems.append(error)
    if problems:
        drops.drop(where, problems[0] if len(problems) == 1 else f"{problems[0]} (and {len(problems) - 1} more)",
                   count=len(problems), unit="read")
    return reads


def wifi_rss(scan: Any) -> dict[str, float]:
    """A rfidnav_msgs WifiScan as BSSID -> RSS [dBm], each RSS in RSS_DBM, each BSSID non-empty and listed once
    (in any case: a scan lists an AP once, and which of two readings to trust no one can say); BadInput naming the
    first access point that is not."""
    rss: dict[str, float] = {}
    first: dict[str, int] = {}
    for index, access_point in enumerate(scan.access_points):
        where = f"access_points[{index}]"
        if not access_point.bssid:
            raise BadInput(f"{where}.bssid: empty")
        if (before := first.setdefault(access_point.bssid.lower(), index)) != index:
            raise BadInput(f"{where}.bssid: {access_point.bssid} listed twice (also access_points[{before}])")
        rss[access_point.bssid] = rss_dbm(access_point.rssi_dbm, f"{where}.rssi_dbm ({access_point.bssid})")
    return rss


def compass_heading(msg: Any) -> float:
    """The heading [rad] of a sensor_msgs/Imu compass reading, in its frame (compass or base_link), checked."""
    frame(msg.header.frame_id, COMPASS_FRAMES)
    return yaw(msg.orientation, "orientation")


def scan_rss(scan: Any) -> dict[str, float]:
    """:func:`wifi_rss` of a WifiScan from the robot's receiver, in base_link (what a navigator may locate)."""
    frame(scan.header.frame_id, WIFI_FRAME)
    return wifi_rss(scan)


@dataclass(frozen=True)
class Velocity:
    linear_mps: float
    angular_radps: float
    clamped: bool           # scaled down to the limits


def velocity(linear: Any, angular: Any, max_linear_mps: float, max_angular_radps: float) -> Velocity:
    """A velocity command (forward, yaw rate) within the robot's limits: finite, else BadInput; beyond a limit,
    both scaled by the one factor that brings it within (the same arc, more slowly)."""
    v, w = number(linear, "linear.x"), number(angular, "angular.z")
    # limit / |value|, not |value| / limit: that overflows for 1e308 m/s, this at most underflows towards 0.
    limits = ((v, max_linear_mps), (w, max_angular_radps))
    scale = min([1.0, *(limit / abs(value) for value, limit in limits if abs(value) > limit)])
    if scale == 1.0:
        return Velocity(v, w, False)
    # Clipped too: the product may round one ulp beyond the limit.
    linear_mps, angular_radps = (max(-limit, min(limit, value * scale)) for value, limit in limits)
    return Velocity(linear_mps, angular_radps, True)


class Drops:
    """What a node refused (or clamped), counted per input, with a warning at the first of each input and then
    at most every ``period_s`` with the count so far. ``warn`` takes the warning line (the node's logger)."""

    def __init__(self, warn: Callable[[str], None], period_s: float = WARN_PERIOD_S,
                 clock: Callable[[], float] = time.monotonic, resolve: Callable[[str], str] = str) -> None:
        """``resolve``: an input's name as the node resolves it (``odom`` under /r1 is /r1/odom), so that warnings
        and counts name the topic a user sees (rfidnav_common.ros.input_drops)."""
        self.warn = warn
        self.period_s = period_s
        self.clock = clock
        self.resolve = resolve
        self.counts: Counter[str] = Counter()
        self.clamps: Counter[str] = Counter()
        self._warned_at: dict[str, float] = {}

    def drop(self, where: str, problem: object, count: int = 1, unit: str = "message") -> None:
        """``count`` of ``unit`` (a message, a read of a round, a request) of input ``where`` (a topic, a service)
        dropped for ``problem``."""
        where = self.resolve(where)
        self.counts[where] += count
        self._say(where, f"{where}: dropped {f'a {unit}' if count == 1 else f'{count} {unit}s'}: {problem} "
                         f"({self.counts[where]} dropped so far)")

    def clamp(self, where: str, problem: object) -> None:
        where = self.resolve(where)
        self.clamps[where] += 1
        self._say(f"{where} (clamped)", f"{where}: clamped: {problem} ({self.clamps[where]} clamped so far)")

    def dropped(self, where: str | None = None) -> int:
        return self.counts[self.resolve(where)] if where is not None else sum(self.counts.values())

    def clamped(self, where: str | None = None) -> int:
        return self.clamps[self.resolve(where)] if where is not None else sum(self.clamps.values())

    def _say(self, key: str, line: str) -> None:
        now = self.clock()
        last = self._warned_at.get(key)
        if last is None or now - last >= self.period_s:
            self._warned_at[key] = now
            self.warn(line)
