"""The node registry: what a scenario needs to know of a node executable, registered by the package that ships it.

A package registers each node executable under the ``rfidnav.nodes`` entry-point group of its setup.py, the entry's
name the executable's and its value a :class:`NodeRegistration`::

    entry_points={"rfidnav.nodes": ["rfid_reader_sim = rfidnav_sim.parameters:RFID_READER_SIM"]}

The scenario reads it to validate the node's parameter files before start-up, to make the node a participant of the
stepped clock (``stepped``) and to check the mission against the action it serves. The cross-node checks ask the
parameters for what they declare through the protocols below, so a new node takes part in a check by implementing
one. See docs/extending.md.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import metadata
from typing import Protocol, runtime_checkable

from rfidnav_common.errors import UnknownExecutableError

NODE_GROUP = "rfidnav.nodes"


@dataclass(frozen=True)
class NodeRegistration:
    node_name: str                        # its default ROS node name: the key of its parameter files
    parameters: type                      # its parameters dataclass (rfidnav_common.config's ``param`` fields)
    stepped: bool                         # derives rfidnav_common.stepped_node.SteppedNode: answers the stepped clock
    serves: tuple[tuple[str, str], ...] = ()   # (action name, action type) of each action server it runs


@functools.cache
def registered_node(package: str, executable: str) -> NodeRegistration | None:
    """The registration of ``package``'s ``executable``; None for a package that is not installed or registers no
    such node (a hardware driver of another suite, a user's node). A registration that is not a
    :class:`NodeRegistration` is an :class:`UnknownExecutableError` naming the entry point."""
    try:
        entry_points = metadata.distribution(package).entry_points
    except metadata.PackageNotFoundError:
        return None
    entries = [entry for entry in entry_points if entry.group == NODE_GROUP and entry.name == executable]
    if not entries:
        return None
    registration = entries[0].load()
    if not isinstance(registration, NodeRegistration):
        raise UnknownExecutableError("executable", f"{package}'s {NODE_GROUP} entry point '{executable}' "
                                     f"({entries[0].value}) is a {type(registration).__name__}, not a NodeRegistration")
    return registration


def registered_nodes() -> dict[tuple[str, str], NodeRegistration]:
    """Every registered node of every installed package: (package, executable) -> its registration."""
    entries = metadata.entry_points(group=NODE_GROUP)
    return {(package, entry.name): registration for entry in entries
            for package in [entry.dist.name if entry.dist is not None else ""]
            for registration in [registered_node(package, entry.name)] if registration is not None}


@runtime_checkable
class PublishesAntennaPorts(Protocol):
    """A reader: the antenna ports whose reads reach /rfid/reads."""

    def published_antenna_ports(self) -> tuple[str, tuple[int, ...]]:
        """The parameter naming the ports, and the ports (empty: every port the reader has)."""
        ...


@runtime_checkable
class ReadsAntennaPorts(Protocol):
    """A node that takes reads of given antenna ports: a reader of the scenario must publish each."""

    def antenna_ports_read(self) -> dict[str, int]:
        """The ports, by the parameter that names each."""
        ...


@runtime_checkable
class LimitsSpeed(Protocol):
    """A base: no node may command it faster than it drives."""

    def speed_limit(self) -> tuple[str, float]:
        """The parameter bounding the forward speed [m/s], and its value."""
        ...


@runtime_checkable
class CommandsSpeeds(Protocol):
    """A node that commands forward speeds: the base must be able to drive them."""

    def commanded_speeds(self) -> dict[str, float]:
        """The speeds [m/s], by parameter."""
        ...
