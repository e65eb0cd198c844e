"""rclpy glue shared by every rfidnav node: the Jazzy main(), parameter declaration from dataclasses, QoS."""

from __future__ import annotations

import dataclasses
import faulthandler
import importlib
import signal
import sys
import threading
import typing
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from types import FrameType
from typing import Any

import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterTypeException, InvalidTopicNameException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from rfidnav_common.config import did_you_mean, parameters_from_mapping
from rfidnav_common.errors import ConfigError, RfidnavError
from rfidnav_common.geometry import quaternion_to_yaw
from rfidnav_common.inputs import WARN_PERIOD_S, Drops, seconds_of, stamp_near
from rfidnav_common.process_signals import STACK_DUMP_SIGNAL, STOP_SIGNALS

# Sensor streams: reliable, with room for a burst (a high RTF on a busy machine) so that the recorder
# and the controller see every message on localhost.
SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = SENSOR_QOS
# Maps and markers: late joiners (viewers, the recorder) get the last message.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)


def declare_parameters(node: Node, cls: type) -> Any:
    """Declare one ROS parameter per field of dataclass ``cls`` (default and description from the field),
    read them once and return a validated instance; a bad value is a ConfigError naming the node.

    An empty string-array default is declared by type (Jazzy cannot infer a type from ``[]``), a number list
    is dynamically typed (an empty ``[]`` arrives as a byte array), and float
    parameters accept integers (``-p rate:=2``), which Jazzy's static typing would reject with a traceback."""
    hints = typing.get_type_hints(cls)
    source = f"parameters of node '{node.get_fully_qualified_name()}'"
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        default = field.default if field.default is not dataclasses.MISSING else field.default_factory()
        doc = field.metadata.get("doc", "")
        try:
            if hints[field.name] == list[str]:
                value = node.declare_parameter(field.name, Parameter.Type.STRING_ARRAY,
                                               ParameterDescriptor(description=doc)).value
                values[field.name] = list(value) if value is not None else list(default)
            elif hints[field.name] in (list[int], list[float]):
                # Jazzy types an empty ``[]`` (default or override) as a byte array: declared with dynamic typing,
                # it is [].
                value = node.declare_parameter(field.name, default,
                                               ParameterDescriptor(description=doc, dynamic_typing=True)).value
                values[field.name] = [] if value is None or isinstance(value, (bytes, bytearray)) else list(value)
            else:
                dynamic = hints[field.name] is float
                values[field.name] = node.declare_parameter(
                    field.name, default, ParameterDescriptor(description=doc, dynamic_typing=dynamic)).value
        except InvalidParameterTypeException as error:
            raise ConfigError(source, field.name, f"wrong type: {error}") from None
    return parameters_from_mapping(cls, values, source)


def events_executor(context: Context | None = None) -> Executor:
    """rclpy's C++ EventsExecutor: about a third of SingleThreadedExecutor's CPU per callback, which is what
    lets five Python processes share two cores at RTF 5.

    Spin it only with bounded ``spin_once`` calls (see run_node) and never give it a coroutine that awaits a
    Future: in rclpy 7.1 an awaiting task is re-queued at once, so it -- and ``spin()`` or
    ``spin_until_future_complete()`` -- busy-loops a core (the action servers therefore run a goal's execute
    callback only once the outcome is known: rfidnav_common.goal_server). Pass SingleThreadedExecutor to
    run_node for such a node."""
    return EventsExecutor(context=context)


class _StopRequest:
    """The node process's stop: any of STOP_SIGNALS sets a flag that the spin loops check between bounded spins,
    so that the main thread itself ends the spin, destroys the nodes and shuts rclpy down, in that order. (rclpy's
    own handlers shut the context down from another thread, under a callback or the teardown: a publication or
    a destroy then fails at random and the process exits 1.) Later signals change nothing: the parent-death
    signal comes once per thread of a dying parent, and a node that will not stop is SIGKILLed by its parent."""

    def __init__(self) -> None:
        self.requested = False

    def __call__(self, _signum: int, _frame: FrameType | None) -> None:
        self.requested = True

    def install(self) -> None:
        self.requested = False
        if threading.current_thread() is threading.main_thread():   # a node run by a test's thread has none
            for signum in STOP_SIGNALS:
                signal.signal(signum, self)
            faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True)


_STOP = _StopRequest()


def stop_requested() -> bool:
    """Whether the node process was asked to stop (SIGINT, SIGTERM or SIGHUP): the condition of every spin loop."""
    return _STOP.requested


def spin_until_shutdown(executor: Executor, node: Node, until: Callable[[], bool] = lambda: False) -> int:
    """Spin until a stop signal or shutdown (or ``until()`` holds); 0."""
    while rclpy.ok(context=node.context) and not stop_requested() and not until():
        # Bounded waits: Python signal handlers run only when control returns from the executor.
        executor.spin_once(timeout_sec=0.1)
    return 0


def run_node(make_node: Callable[[], Node], args: list[str] | None = None,
             make_executor: Callable[[], Executor] = events_executor,
             spin: Callable[[Executor, Node], int] = spin_until_shutdown) -> int:
    """Jazzy main() of every rfidnav node: init, ``spin`` (until SIGINT, SIGTERM, SIGHUP or shutdown by default;
    its value is the exit code), always destroy the node and shut down.

    A configuration problem found while constructing the node is printed as one line and exits 2."""
    return run_nodes([make_node], args, make_executor, spin)


def run_nodes(make_nodes: Sequence[Callable[[], Node]], args: list[str] | None = None,
              make_executor: Callable[[], Executor] = events_executor,
              spin: Callable[[Executor, Node], int] = spin_until_shutdown) -> int:
    """run_node for several nodes in one process and on one executor (rfidnav_bringup.container); ``spin`` is
    given the first."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    _STOP.install()
    nodes: list[Node] = []
    executor = make_executor()
    code = 0
    try:
        for make_node in make_nodes:
            nodes.append(make_node())
            executor.add_node(nodes[-1])
        code = spin(executor, nodes[0])
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RfidnavError as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        return 2
    finally:
        # The executor lets go of the nodes' entities (it holds their handles and their DDS listeners' callbacks)
        # before the nodes destroy them, as rclpy.spin() removes its node before the caller destroys it.
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


@contextmanager
def standalone_node(name: str, domain_id: int | None = None) -> Iterator[tuple[Node, SingleThreadedExecutor]]:
    """A node on its own context and executor, for a command that listens to a graph it is not part of (echo,
    a calibration); the domain is ROS_DOMAIN_ID's unless ``domain_id`` is given. All three end with the block.

    rclpy's signal handlers are left out: Ctrl-C (and the command line's SIGTERM and SIGHUP) end the command as
    Python exceptions, between two bounded spins, instead of shutting the context down under the executor."""
    context = Context()
    rclpy.init(context=context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
    node = Node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()


def odometry_pose(msg: Odometry) -> tuple[float, float, float]:
    """(x, y, yaw) of an Odometry message's pose (a planar robot); NaN is passed through for the caller."""
    pose = msg.pose.pose
    q = pose.orientation
    return pose.position.x, pose.position.y, quaternion_to_yaw(q.x, q.y, q.z, q.w)


def twist(linear: float, angular: float) -> Twist:
    """A planar velocity command: forward [m/s] and yaw rate [rad/s]."""
    command = Twist()
    command.linear.x, command.angular.z = float(linear), float(angular)
    return command


def time_msg(seconds: float) -> Time:
    """builtin_interfaces/Time for a non-negative time in seconds."""
    nanoseconds = round(seconds * 1e9)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def sim_clock_seconds(node: Node) -> float | None:
    """The node's simulated time now [s] (the stepped clock's, or /clock's), or None on wall time and before the
    first clock message (nothing to check a stamp against yet). Stamps are checked against simulated time only:
    there a stamp from another era stops a run, while on a real robot the drivers' clocks are the operator's to
    keep in step (a robot whose reader's clock is off would otherwise go blind on a check of ours)."""
    clock = node.get_clock()
    if not getattr(clock, "ros_time_is_active", False):
        return None
    return (clock.now().nanoseconds * 1e-9) or None     # 0: no /clock heard yet


def stamp_seconds(node: Node, stamp: Time, field: str = "header.stamp") -> float:
    """A message's stamp [s], checked against the node's simulated time (rfidnav_common.inputs.stamp_near:
    BadInput if far); as it is on wall time."""
    now_s = sim_clock_seconds(node)
    return seconds_of(stamp) if now_s is None else stamp_near(seconds_of(stamp), now_s, field)


def message_class(type_name: str) -> type | None:
    """The generated Python class of ``pkg/kind/Name`` (kind msg, srv or action), or None when it is not
    installed (rosidl_runtime_py is not among the PyPI wheels).

    Action-derived types (``X_FeedbackMessage``) are not exported by ``pkg.action``; they live in the private
    module of their action (``pkg.action._x``), which each exported class names as its ``__module__``."""
    parts = type_name.split("/")
    if len(parts) != 3:
        return None
    package, kind, name = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
    except ImportError:
        return None
    found = getattr(module, name, None)
    if found is None:
        for exported in vars(module).values():
            private = sys.modules.get(getattr(exported, "__module__", ""))
            found = getattr(private, name, None) if private is not None else None
            if found is not None:
                break
    return found if isinstance(found, type) else None


def interface_class(type_name: str) -> type:
    """message_class for a configured type (``pkg/Name`` means ``pkg/msg/Name``); an unknown type is a
    ConfigError naming it."""
    parts = type_name.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or parts[1] not in ("msg", "srv", "action"):
        raise ConfigError(type_name, "", "expected an interface type like pkg/msg/Name or pkg/action/Name")
    found = message_class("/".join(parts))
    if found is None:
        raise ConfigError(type_name, "", "unknown interface type (is its package built and installed?)")
    return found


def topic_name_problem(name: str, node_name: str) -> str | None:
    """Why ``name`` is no valid topic (or action, service) name for node ``node_name``, in rclpy's words ("topic
    name must not contain repeated '/'"); None when it is one."""
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name

    try:
        validate_full_topic_name(expand_topic_name(name, node_name, "/"))
    except InvalidTopicNameException as error:          # "Invalid topic name: PROBLEM:\n  'NAME'\n    ^"
        return str(error).splitlines()[0].removeprefix("Invalid topic name: ").rstrip(":")
    except ValueError as error:                          # "topic name 'NAME' is invalid: PROBLEM, at FILE:LINE"
        return str(error).partition("is invalid: ")[2].rpartition(", at ")[0] or str(error)
    return None


def fill_message(message: Any, values: dict[str, Any], where: str) -> Any:
    """Set ``message``'s fields from a plain mapping (nested mappings fill nested messages, built with their
    fields' types and ranges checked, as ``message`` was if it was built with ``check_fields=True``)."""
    fields = message.get_fields_and_field_types()
    for name, value in values.items():
        if name not in fields:
            raise ConfigError(where, name, f"no such field in {type(message).__name__} "
                              f"({did_you_mean(str(name), fields)}fields: {', '.join(fields)})")
        current = getattr(message, name)
        try:
            if isinstance(value, dict) and hasattr(current, "get_fields_and_field_types"):
                setattr(message, name, fill_message(type(current)(check_fields=True), value, f"{where}.{name}"))
            else:
                setattr(message, name, float(value) if isinstance(current, float) and isinstance(value, int)
                        else value)
        except (TypeError, ValueError, AssertionError) as error:
            raise ConfigError(where, name, f"cannot hold {value!r}: {error}") from None
    return message


def input_drops(node: Node, period_s: float = WARN_PERIOD_S) -> Drops:
    """The node's drop-and-count of bad inputs, naming each topic or service as the node resolves it (``odom`` in a
    robot's namespace is /r1/odom; what is no ROS name, a goal, a read of a round, stays as it is)."""
    def resolve(where: str) -> str:
        try:
            return node.resolve_topic_name(where)
        except InvalidTopicNameException:
            return where

    return Drops(node.get_logger().warning, period_s, resolve=resolve)
