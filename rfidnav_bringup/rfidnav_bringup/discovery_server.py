"""A Fast DDS Discovery Server, for a graph split between computers whose network carries no multicast (Wi-Fi, a
VPN, a lab's managed switch): ``./rfidnav discovery-server --listen ADDRESS:PORT`` on one computer, and each part
of the run given ``--discovery-server ADDRESS:PORT`` (README, "One run on two computers").

The server is the ros-fastrtps wheel's ``fast-discovery-server``. The wheel leaves the libraries it links against
where the dynamic linker does not look (the venv's ``lib`` and the wheel's ``ros_fastrtps.libs``), so it is started
with those folders on ``LD_LIBRARY_PATH``. Pure: no rclpy.
"""

from __future__ import annotations

import ipaddress
import os
import sys
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

from rfidnav_bringup.errors import LaunchError

SERVER_DISTRIBUTION = "ros-fastrtps"
SERVER_EXECUTABLE = "fast-discovery-server"
DEFAULT_PORT = 11811                       # Fast DDS's own default for a discovery server
# A client's view of the graph: a plain client of a discovery server learns only the endpoints it matches, so the
# orchestrator and the recorder, which read the whole graph (every topic, every node), would not see it.
SUPER_CLIENT = {"ROS_SUPER_CLIENT": "TRUE"}


def server_address(text: str) -> tuple[str, int]:
    """``ADDRESS[:PORT]`` (an IPv4 address; PORT 1-65535, default DEFAULT_PORT), or ValueError saying why."""
    address, _, port_text = text.partition(":")
    try:
        ipaddress.IPv4Address(address)
    except ipaddress.AddressValueError:
        raise ValueError(f"expected an IPv4 address, optionally with :PORT, got '{text}'") from None
    port = int(port_text) if port_text.isdigit() else (DEFAULT_PORT if not port_text else 0)
    if not 1 <= port <= 65535:
        raise ValueError(f"expected a port 1-65535 after the address, got '{port_text}'")
    return address, port


def client_environment(address: str, port: int) -> dict[str, str]:
    """What a process of a part sets to find the graph through the server at ``address``:``port``."""
    return {"ROS_DISCOVERY_SERVER": f"{address}:{port}", **SUPER_CLIENT}


def server_command(address: str, port: int, server_id: int = 0) -> tuple[list[str], dict[str, str]]:
    """The command line of the wheel's discovery server listening on ``address``:``port``, and its environment."""
    try:
        wheel = distribution(SERVER_DISTRIBUTION)
    except PackageNotFoundError:
        raise LaunchError(f"the {SERVER_DISTRIBUTION} wheel is not installed (./rfidnav setup installs it)") from None
    executable = next((Path(str(wheel.locate_file(file))).resolve() for file in wheel.files or ()
                       if file.name == SERVER_EXECUTABLE), None)
    if executable is None or not executable.is_file():
        raise LaunchError(f"{SERVER_DISTRIBUTION} {wheel.version} has no {SERVER_EXECUTABLE}")
    libraries = [Path(sys.prefix) / "lib", Path(str(wheel.locate_file("ros_fastrtps.libs"))).resolve()]
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        [str(folder) for folder in libraries] + ([env["LD_LIBRARY_PATH"]] if env.get("LD_LIBRARY_PATH") else []))
    return [str(executable), "-i", str(server_id), "-l", address, "-p", str(port)], env
