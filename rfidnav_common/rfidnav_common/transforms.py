"""tf over rclpy without tf2_ros (the PyPI wheels have none): /tf and /tf_static as tf2_ros publishes them.

``/tf_static`` is reliable and transient local, so a viewer or the recorder that joins later still gets every
static frame; each node publishes all of its static frames in one message (tf2 merges the publishers).

A node in a robot's namespace (``/r1``) publishes that robot's frames with its prefix (``r1/odom``,
``r1/base_link``: rfidnav_common.frames.frame_prefix); the map stays shared. Message headers keep the frame names
without the prefix: a robot's nodes check them as they would on a robot of their own.
"""

from __future__ import annotations

from collections.abc import Iterable

from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

from rfidnav_common.frames import ODOM_FRAME, Frame, frame_prefix, map_to_odom, prefixed

# tf2_ros's own profiles: TransformBroadcaster (depth 100, volatile) and StaticTransformBroadcaster (depth 1,
# transient local; its listeners keep 100).
TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


def transform_message(frame: Frame, stamp: Time) -> TransformStamped:
    transform = TransformStamped()
    transform.header.stamp = stamp
    transform.header.frame_id, transform.child_frame_id = frame.parent, frame.child
    t, r = transform.transform.translation, transform.transform.rotation
    t.x, t.y, t.z = (float(v) for v in frame.translation)
    r.x, r.y, r.z, r.w = (float(v) for v in frame.rotation)
    return transform


def tf_message(frames: Iterable[Frame], stamp: Time) -> TFMessage:
    return TFMessage(transforms=[transform_message(frame, stamp) for frame in frames])


def publish_static_frames(node: Node, frames: Iterable[Frame], prefix: str | None = None) -> None:
    """Latch ``frames`` on /tf_static for the node's lifetime (stamped now: static frames hold at every time), with
    ``prefix`` on the robot's frames (None: the node's namespace's)."""
    prefix = frame_prefix(node.get_namespace()) if prefix is None else prefix
    frames = [prefixed(frame, prefix) for frame in frames]
    if frames:
        publisher = node.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
        publisher.publish(tf_message(frames, node.get_clock().now().to_msg()))


class FrameBroadcaster:
    """Moving frames on /tf (odom -> base_link from a base, map -> odom from a localizer)."""

    def __init__(self, node: Node, prefix: str | None = None) -> None:
        """``prefix``: on the robot's frames; None: the node's namespace's (rfidnav_common.frames.frame_prefix)."""
        self.publisher = node.create_publisher(TFMessage, "/tf", TF_QOS)
        self.prefix = frame_prefix(node.get_namespace()) if prefix is None else prefix

    def send(self, frames: Iterable[Frame], stamp: Time) -> None:
        self.publisher.publish(tf_message((prefixed(frame, self.prefix) for frame in frames), stamp))

    def send_map_to_odom(self, map_frame: str, base_in_map: tuple[float, float, float],
                         base_in_odom: tuple[float, float, float], stamp: Time) -> None:
        """A localizer's estimate as map -> odom (REP 105), given where odometry put the base at that time."""
        self.send([Frame.planar(map_frame, ODOM_FRAME, map_to_odom(base_in_map, base_in_odom))], stamp)
