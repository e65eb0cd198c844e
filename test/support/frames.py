"""The tf tree of a recorded run, read back from its bag: which frame hangs under which, and where, in time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from rfidnav_bag.bags import read_messages
from rfidnav_common.frames import compose
from rfidnav_common.geometry import quaternion_to_yaw


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _planar(transform) -> tuple[float, float, float]:
    t, r = transform.translation, transform.rotation
    return t.x, t.y, quaternion_to_yaw(r.x, r.y, r.z, r.w)


@dataclass
class FrameTree:
    parents: dict[str, str] = field(default_factory=dict)                 # child -> parent
    static: dict[str, object] = field(default_factory=dict)               # child -> its static transform
    moving: dict[str, list[tuple[int, tuple[float, float, float]]]] = field(default_factory=dict)  # child -> (t, pose)

    def root_of(self, frame: str) -> str:
        seen = [frame]
        while frame in self.parents:
            frame = self.parents[frame]
            assert frame not in seen, f"a loop in the tf tree: {seen + [frame]}"
            seen.append(frame)
        return frame

    def pose_at(self, child: str, time_ns: int) -> tuple[float, float, float]:
        """The planar pose of ``child`` in its parent at the last moving transform at or before ``time_ns``."""
        if child in self.static:
            return _planar(self.static[child])
        before = [pose for stamp, pose in self.moving[child] if stamp <= time_ns]
        assert before, f"no {child} transform at or before {time_ns} ns"
        return before[-1]

    def base_in_map(self, time_ns: int) -> tuple[float, float, float]:
        return compose(self.pose_at("odom", time_ns), self.pose_at("base_link", time_ns))


def frame_tree(run: Path) -> FrameTree:
    """Every transform on /tf_static and /tf of a run's bag, each child with one parent (checked)."""
    tree = FrameTree()
    for topic, _, message in read_messages(run / "bag", ["/tf_static", "/tf"]):
        for transform in message.transforms:
            child, parent = transform.child_frame_id, transform.header.frame_id
            assert tree.parents.setdefault(child, parent) == parent, f"{child} has two parents"
            if topic == "/tf_static":
                tree.static[child] = transform.transform
            else:
                tree.moving.setdefault(child, []).append((_stamp_ns(transform.header.stamp),
                                                          _planar(transform.transform)))
    return tree


def assert_same_pose(a: tuple[float, float, float], b: tuple[float, float, float], metres: float,
                     radians: float) -> None:
    assert math.dist(a[:2], b[:2]) <= metres, (a, b)
    assert abs(math.remainder(a[2] - b[2], 2 * math.pi)) <= radians, (a, b)


def assert_estimates_are_published_as_map_to_odom(run: Path, within_s: float = 0.05,
                                                  status_topic: str = "/localization/status") -> int:
    """Each map -> odom, composed with odom -> base_link at its stamp (the odometry the localizer used), is an
    estimate with a heading on ``status_topic`` (the localizer that drives) stamped then or up to ``within_s`` later
    (a localizer may publish on a step timer, after the odometry it rests on). Returns how many were checked."""
    tree = frame_tree(run)
    assert tree.parents["odom"] == "map" and tree.parents["base_link"] == "odom"
    estimates = [(_stamp_ns(m.header.stamp), (m.x, m.y, m.yaw_rad))
                 for _, _, m in read_messages(run / "bag", [status_topic])
                 if m.position_valid and m.orientation_valid]
    for stamp, map_to_odom in tree.moving["odom"]:
        base = compose(map_to_odom, tree.pose_at("base_link", stamp))
        candidates = [pose for t, pose in estimates if stamp <= t <= stamp + within_s * 1e9]
        assert any(math.dist(base[:2], pose[:2]) < 1e-3 and abs(math.remainder(base[2] - pose[2], 2 * math.pi))
                   < 1e-3 for pose in candidates), (stamp, base, candidates)
    return len(tree.moving["odom"])
