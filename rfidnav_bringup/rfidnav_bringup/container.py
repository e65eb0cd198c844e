"""A node container: several rfidnav nodes in one OS process, on one executor (the ROS 2 composition idea).

``python -m rfidnav_bringup.container --node PKG:EXECUTABLE [--node ...] --ros-args --params-file F ...``

The scenario groups roles with ``process: NAME`` (rfidnav_scenario.scenario); the orchestrator starts each group
as one container. Every node is the class its executable runs, constructed in one rclpy context, so the
messages between them stay in the process (Fast DDS delivers within a participant without the network or a
wake-up of another process). The parameter files are global arguments of the context and each is keyed by its
node's name, so each node reads its own section, as in a component container.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import sys

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
    parser.add_argument("--node", action="append", required=True, metavar="PKG:EXECUTABLE",
                        help="a node to run in this process (repeat)")
    args = parser.parse_args(argv[:split])
    try:
        classes = [node_class(*entry.split(":", 1)) for entry in args.node]
    except (LaunchError, UnknownExecutableError, TypeError) as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        return 2
    return run_nodes(classes, [sys.argv[0], *argv[split:]])


if __name__ == "__main__":
    raise SystemExit(main())
