"""rclpy glue shared by every rfidnav node: the Jazzy main(), parameter declaration from dataclasses, QoS."""

from __future__ import annotations

import dataclasses
import sys
import typing
from typing import Any, Callable

import rclpy
from builtin_interfaces.msg import Time
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rfidnav_common.config import parameters_from_mapping
from rfidnav_common.errors import RfidnavError

# Sensor streams: reliable so the recorder and the controller see every inventory round on localhost.
SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = SENSOR_QOS
# Maps and markers: late joiners (viewers, the recorder) get the last message.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)


def declare_parameters(node: Node, cls: type) -> Any:
    """Declare one ROS parameter per field of dataclass ``cls`` (default and description from the field),
    read them once and return a validated instance. A bad value raises a ConfigError naming the node."""
    hints = typing.get_type_hints(cls)
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        default = field.default if field.default is not dataclasses.MISSING else field.default_factory()
        descriptor = ParameterDescriptor(description=field.metadata.get("doc", ""))
        if isinstance(default, list) and not default:  # ROS cannot infer an array type from []
            descriptor.type = (ParameterType.PARAMETER_STRING_ARRAY if hints[field.name] == list[str]
                               else ParameterType.PARAMETER_DOUBLE_ARRAY)
            values[field.name] = node.declare_parameter(field.name, descriptor=descriptor).value or []
        else:
            values[field.name] = node.declare_parameter(field.name, default, descriptor).value
    for name, value in values.items():
        if hints[name] is float and isinstance(value, int) and not isinstance(value, bool):
            values[name] = float(value)
        elif hints[name] == list[float]:
            values[name] = [float(v) for v in value]
        elif hints[name] == list[str]:
            values[name] = list(value)
    return parameters_from_mapping(cls, values, f"parameters of node '{node.get_fully_qualified_name()}'")


def run_node(make_node: Callable[[], Node], args: list[str] | None = None) -> int:
    """Jazzy main(): init, spin until Ctrl-C or shutdown, always destroy and shut down.

    A configuration problem found while constructing the node is printed as one line and exits 2."""
    rclpy.init(args=args)
    node = None
    try:
        node = make_node()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RfidnavError as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        return 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def time_msg(seconds: float) -> Time:
    """builtin_interfaces/Time for a non-negative time in seconds."""
    nanoseconds = round(seconds * 1e9)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def seconds_of(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9
