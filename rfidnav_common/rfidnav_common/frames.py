"""The robot's coordinate frames (REP 105: map -> odom -> base_link -> sensors), as plain data.

Sensor nodes describe where they are mounted from their own parameters (:class:`Frame`), the base and the
simulator where base_link is in odom, a localizer where odom is in the map (:func:`map_to_odom`); the adapter
``rfidnav_common.transforms`` turns them into tf2_msgs/TFMessage on /tf and /tf_static.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from rfidnav_common.geometry import wrap_angle

BASE_FRAME = "base_link"
ODOM_FRAME = "odom"
MAP_FRAME = "map"
# The frames the consuming nodes expect of the robot's sensors (rfidnav_common.inputs drops the rest). A reader's
# /rfid/reads and a WiFi scan are in base_link: the antennas' frames hang from it on /tf_static, and nothing links
# another reader frame to the robot. The compass is at the base's centre, in base_link or its own frame; each
# rangefinder NAME of /sonar/NAME in SONAR_FRAME_PREFIX + NAME (sonar_sim's frames, in base_link).
READER_FRAME = BASE_FRAME
WIFI_FRAME = BASE_FRAME
COMPASS_FRAMES = ("compass", BASE_FRAME)
SONAR_FRAME_PREFIX = "sonar_"

# Frames every robot of a world shares: one map. A robot's own frames (odom, base_link, its sensors') carry its
# namespace as a prefix on /tf (Nav2's multi-robot convention: r1/odom -> r1/base_link), so that several robots'
# trees hang from the one map without clashing.
SHARED_FRAMES = (MAP_FRAME,)

Quaternion = tuple[float, float, float, float]       # x, y, z, w


def rpy_to_quaternion(roll: float, pitch: float, yaw: float) -> Quaternion:
    """(x, y, z, w) of the fixed-axis rotation roll about x, then pitch about y, then yaw about z (REP 103)."""
    cr, sr = math.cos(roll / 2.0), math.sin(roll / 2.0)
    cp, sp = math.cos(pitch / 2.0), math.sin(pitch / 2.0)
    cy, sy = math.cos(yaw / 2.0), math.sin(yaw / 2.0)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


@dataclass(frozen=True)
class Frame:
    """Where ``child`` is in ``parent``: a translation [m] and a rotation."""
    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: Quaternion = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if not self.parent or not self.child or self.parent == self.child:
            raise ValueError(f"frame {self.parent!r} -> {self.child!r}: needs two different non-empty names")
        values = (*self.translation, *self.rotation)
        if len(self.translation) != 3 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"frame {self.parent} -> {self.child}: not finite: {values}")

    @classmethod
    def mounted(cls, parent: str, child: str, position: tuple[float, float, float], roll: float = 0.0,
                pitch: float = 0.0, yaw: float = 0.0) -> Frame:
        """A sensor mounted at ``position`` in ``parent``, turned by roll, pitch and yaw [rad]."""
        return cls(parent, child, position, rpy_to_quaternion(roll, pitch, yaw))

    @classmethod
    def planar(cls, parent: str, child: str, pose: tuple[float, float, float]) -> Frame:
        """A frame at (x, y, yaw) in the plane of ``parent``."""
        x, y, yaw = pose
        return cls.mounted(parent, child, (x, y, 0.0), yaw=yaw)


# The turn from the reader frame's x axis to each antenna facing (a sensor frame's x is its boresight): a pitch of
# -90 deg points x up, at the ceiling tags; left and right face the walls.
FACINGS = ("up", "down", "left", "right")
BORESIGHT_TURNS = {"up": {"pitch": -math.pi / 2.0}, "down": {"pitch": math.pi / 2.0},
                   "left": {"yaw": math.pi / 2.0}, "right": {"yaw": -math.pi / 2.0}}


def antenna_frames(reader_frame: str, prefix: str, ports: Sequence[int], positions: Sequence[float],
                   facings: Sequence[str]) -> list[Frame]:
    """Each antenna port's frame (``prefix`` + port) in the reader's, at its x, y, z (``positions`` concatenated),
    its x axis along the boresight: what the simulated reader and the LLRP driver both publish."""
    if len(positions) != 3 * len(ports) or len(facings) != len(ports):
        raise ValueError(f"antennas {list(ports)}: need 3 position values and a facing per port, got "
                         f"{len(positions)} and {len(facings)}")
    return [Frame.mounted(reader_frame, f"{prefix}{port}", (float(positions[3 * i]), float(positions[3 * i + 1]),
                                                             float(positions[3 * i + 2])), **BORESIGHT_TURNS[facing])
            for i, (port, facing) in enumerate(zip(ports, facings))]


def compose(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    """Planar pose ``b`` (given in frame ``a``) in ``a``'s parent frame."""
    ax, ay, ayaw = a
    bx, by, byaw = b
    c, s = math.cos(ayaw), math.sin(ayaw)
    return ax + c * bx - s * by, ay + s * bx + c * by, wrap_angle(ayaw + byaw)


def inverse(pose: tuple[float, float, float]) -> tuple[float, float, float]:
    """The planar pose of a frame's parent in that frame."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    return -c * x - s * y, s * x - c * y, wrap_angle(-yaw)


def map_to_odom(base_in_map: tuple[float, float, float],
                base_in_odom: tuple[float, float, float]) -> tuple[float, float, float]:
    """odom in the map, from where a localizer puts base_link in the map and where odometry puts it in odom at
    the same time (REP 105: the localizer publishes map -> odom, so that odom -> base_link stays continuous)."""
    return compose(base_in_map, inverse(base_in_odom))


def frame_prefix(namespace: str) -> str:
    """The tf prefix of a robot's frames from its ROS namespace: ``/r1`` -> ``r1/``, the root namespace none."""
    stripped = namespace.strip("/")
    return f"{stripped}/" if stripped else ""


def prefixed(frame: Frame, prefix: str) -> Frame:
    """``frame`` with ``prefix`` on each of its names but the shared ones (the map)."""
    if not prefix:
        return frame
    parent = frame.parent if frame.parent in SHARED_FRAMES else prefix + frame.parent
    child = frame.child if frame.child in SHARED_FRAMES else prefix + frame.child
    return Frame(parent, child, frame.translation, frame.rotation)
