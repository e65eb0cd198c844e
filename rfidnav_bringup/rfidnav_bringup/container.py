"""A node container: several rfidnav nodes in one OS process, on one executor (the ROS 2 composition idea).

``python -m rfidnav_bringup.container --node PKG:EXECUTABLE[@/NAMESPACE] [--node ...] --ros-args --params-file F ...``

The scenario groups roles with ``process: NAME`` (rfidnav_scenario.scenario); the orchestrator starts each group
as one container. Every node is the class its executable runs, constructed in one rclpy context, so the
messages between them stay in the process (Fast DDS delivers within a participant without the network or a
wake-up of another process). The parameter files are global arguments of the context and each is keyed by its
node's name (its fully qualified name in a namespace), so each node reads its own section, as in a component
container. A node given with ``@/NAMESPACE`` runs in that namespace (a robot's, of a scenario with several: its
simulated sensors beside the one simulator of the world).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import inspect
import sys
from collections.abc import Callable

from rclpy.node import Node

from rfidnav_bringup.errors import LaunchError
from rfidnav_common.errors import UnknownExecutableError
from rfidnav_common.install import console_script
from rfidnav_common.ros import run_nodes


def node_class(package: str, executable: str) -> type[Node]:
    """The Node subclass that ``package``'s console script ``executable`` runs: the one defined in the module
    its entry point names. Unknown ones are an UnknownExecutableError."""
    module = importlib.import_module(console_script(package, executable).value.split(":")[0])
    classes = [cls for _, cls in inspect.getmembers(module, inspect.isclass)
               if issubclass(cls, Node) and cls.__module__ == module.__name__]
    if len(classes) != 1:
        raise LaunchError(f"container: {package}:{executable} defines {len(classes)} node classes, not one")
    return classes[0]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    split = argv.index("--ros-args") if "--ros-args" in argv else len(argv)
    parser = argparse.ArgumentParser(prog="rfidnav_bringup.container", description=__doc__.splitlines()[0])
    parser.add_argument("--node", action="append", required=True, metavar="PKG:EXECUTABLE[@/NAMESPACE]",
                        help="a node to run in this process (repeat), in NAMESPACE if given")
    args = parser.parse_args(argv[:split])
    try:
        makers = [node_maker(entry) for entry in args.node]
    except (LaunchError, UnknownExecutableError, TypeError) as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        return 2
    return run_nodes(makers, [sys.argv[0], *argv[split:]])


def node_maker(entry: str) -> Callable[[], Node]:
    """What makes the node of a ``--node`` entry: its class, with its namespace if the entry gives one."""
    executable, _, namespace = entry.partition("@")
    cls = node_class(*executable.split(":", 1))
    return functools.partial(cls, namespace=namespace) if namespace else cls


if __name__ == "__main__":
    raise SystemExit(main())
