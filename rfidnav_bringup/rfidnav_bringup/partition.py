"""One DDS partition per orchestrator process, so that nothing outside a run can talk to it.

A ROS domain keeps apart only the graphs that know our domain locks. A node left running by a killed run, another
checkout's graph or a user's own nodes can share the domain, and then it could take the run's goal or publish into
its bag. Fast DDS matches a writer with a reader only when they share a partition, and rmw_fastrtps makes every
writer and reader of a participant (topics, services, actions, and the ROS graph's own ``ros_discovery_info``) with
the default publisher and subscriber profiles of the XML file that ``FASTRTPS_DEFAULT_PROFILES_FILE`` names. So a
run whose every process loads a profile naming a partition of its own, unguessable, hears only its own processes:
a foreign node in its domain is neither heard nor even listed among the graph's nodes (its endpoints show, with no
node name, in the endpoint lists only).

Fast DDS reads that file once per process, at its first participant: the partition is joined before anything of
ROS starts in the process (:func:`join_process_partition`), and every later run of the process (bench rtf's, a
sweep's) stays in it. A caller that sets the variable to a profile naming a partition already (a test session, a
driver on the robot's computer that must join the run) keeps it; a profile without one (a shorter lease, a network
setting) is kept and the partition added to a copy.
"""

from __future__ import annotations

import atexit
import os
import secrets
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

from rfidnav_bringup.errors import LaunchError

PROFILES_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"
NAMESPACE = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
ENDPOINT_KINDS = ("publisher", "subscriber")   # the profiles rmw_fastrtps makes its writers and readers with
# The node name rmw gives an endpoint whose node it has not heard of: a node outside the partition for good, or one
# inside it for the moment its endpoints are known and its name is not yet.
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"
JOIN_ADVICE = (f"an rfidnav run's graph is in a DDS partition of its own: join it with the {PROFILES_VARIABLE} "
               "that its 'graph on' line gives")


@dataclass(frozen=True)
class RunPartition:
    name: str
    profiles_file: Path     # what a process outside the run sets FASTRTPS_DEFAULT_PROFILES_FILE to, to join it
    chosen_by_caller: bool  # named by the caller (a profile naming one, or --partition): others may share it


def tag(name: str) -> str:
    return f"{{{NAMESPACE}}}{name}"


def default_profile(root: ElementTree.Element, kind: str) -> ElementTree.Element | None:
    return next((profile for profile in root.iter(tag(kind)) if profile.get("is_default_profile") == "true"), None)


def partition_in(root: ElementTree.Element) -> str | None:
    """The first partition name of the default publisher profile, if there is one."""
    profile = default_profile(root, "publisher")
    path = "/".join(tag(part) for part in ("qos", "partition", "names", "name"))
    name = None if profile is None else profile.findtext(path)
    return (name or "").strip() or None


def parse_profiles(path: Path) -> ElementTree.Element:
    try:
        root = ElementTree.fromstring(path.read_text())
    except (OSError, UnicodeDecodeError) as error:
        raise LaunchError(f"{PROFILES_VARIABLE}={path}: cannot read it: {error}") from None
    except ElementTree.ParseError as error:
        raise LaunchError(f"{PROFILES_VARIABLE}={path}: not Fast DDS profiles XML: {error}") from None
    if root.tag != tag("dds") and root.tag != tag("profiles"):
        raise LaunchError(f"{PROFILES_VARIABLE}={path}: expected a <dds> or <profiles> root in the namespace "
                          f"{NAMESPACE}, got <{root.tag}>")
    return root


def with_partition(root: ElementTree.Element, partition: str) -> ElementTree.Element:
    """``root`` (Fast DDS profiles) with ``partition`` in its default publisher and subscriber profiles, made when
    it has none."""
    profiles = root if root.tag == tag("profiles") else root.find(tag("profiles"))
    if profiles is None:
        profiles = ElementTree.SubElement(root, tag("profiles"))
    for kind in ENDPOINT_KINDS:
        profile = default_profile(profiles, kind)
        if profile is None:
            profile = ElementTree.SubElement(profiles, tag(kind), profile_name=f"rfidnav_run_{kind}",
                                             is_default_profile="true")
        qos = profile.find(tag("qos"))
        if qos is None:
            qos = ElementTree.SubElement(profile, tag("qos"))
        for old in qos.findall(tag("partition")):
            qos.remove(old)
        names = ElementTree.SubElement(ElementTree.SubElement(qos, tag("partition")), tag("names"))
        ElementTree.SubElement(names, tag("name")).text = partition
    return root


_joined: RunPartition | None = None


def join_process_partition(folder: Path, named: str | None = None) -> RunPartition:
    """This process's partition: the caller's (the variable names a profile with one), or a new one whose profile
    is written to ``folder`` (private: the name is what keeps others out) and removed when the process ends. It
    sets the variable in os.environ, which the run's node processes inherit; call it before the process's first
    DDS participant, which reads the file. ``named``: the new one's name (a split run's two parts give the same,
    --partition), else an unguessable one; a caller's profile that names another is refused."""
    global _joined
    if _joined is not None:
        return _joined
    given = os.environ.get(PROFILES_VARIABLE, "").strip()
    root = parse_profiles(Path(given)) if given else ElementTree.Element(tag("dds"))
    chosen = partition_in(root)
    if chosen is not None and named is not None and chosen != named:
        raise LaunchError(f"--partition {named}: {PROFILES_VARIABLE}={given} names the partition '{chosen}'; give "
                          "one of the two")
    if chosen is not None:
        _joined = RunPartition(chosen, Path(given), chosen_by_caller=True)
        return _joined
    name = named or f"rfidnav-{secrets.token_hex(8)}"
    path = folder / f"dds-{name}.xml"
    ElementTree.register_namespace("", NAMESPACE)
    try:
        ElementTree.ElementTree(with_partition(root, name)).write(path, encoding="UTF-8", xml_declaration=True)
    except OSError as error:
        raise LaunchError(f"cannot write the run's DDS profile {path}: {error.strerror}") from None
    atexit.register(path.unlink, missing_ok=True)
    os.environ[PROFILES_VARIABLE] = str(path)
    _joined = RunPartition(name, path, chosen_by_caller=named is not None)
    return _joined
