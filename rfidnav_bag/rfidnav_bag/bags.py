"""Reading rosbag2 (MCAP) directories written by the recorder, and the type knowledge both nodes share.

No rclpy here: bags are read without a running ROS graph (reports, metrics, ``./rfidnav bag info``). A finished
bag -- metadata.yaml, and an intact summary in every file that agrees with it -- is read with ``rosbags``, which
reads every file metadata.yaml lists (a split bag) in turn and decompresses zstd or lz4 chunks. Any other bag
(the recorder killed or out of disk before it could close it, a file cut short, metadata.yaml missing, stale or
malformed) is salvaged: each file is read from its start (:mod:`rfidnav_bag.salvage`), topics, counts and times
are rebuilt from its intact chunks, and ``BagInfo.notes`` says in one line per file what was lost. Every failure
to read a bag becomes one :class:`BagError` that names the path (and the topic when one is at fault); the
exceptions caught are the ones ``rosbags`` and ``mcap`` raise for bad input.

Types: :func:`typestore` is the ROS 2 Jazzy store of ``rosbags`` plus every rfidnav_msgs type, read from the
installed interface definitions (``share/rfidnav_msgs/{msg,action}``). Action topics carry types that exist in
no file (``X_FeedbackMessage``, ``X_SendGoal_Request``, ...): rosidl derives them from the .action, and so do we
here, with the same fields, so their RIHS01 hashes equal the ones rosidl computed.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import re
import struct
import sys
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.summary import Summary
from rosbags.interfaces import Connection, ConnectionExtRosbag2, MessageDefinition, MessageDefinitionFormat
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.rosbag2.metadata import parse_qos
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, TypesysError, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore
from ruamel.yaml import YAML, YAMLError

from rfidnav_bag.errors import BagError
from rfidnav_bag.salvage import FileScan, SalvagedChannel, salvaged_messages, scan_file
from rfidnav_common.errors import ConfigError

__all__ = [
    "Bag", "BagFile", "BagInfo", "OfferedQos", "RawMessage", "TopicInfo", "bag_info", "clock_stamp_ns",
    "format_bag_info", "is_bag_directory", "message_definition", "open_bag", "read_messages", "read_raw",
    "register_installed_type", "typestore",
]

INTERFACE_PACKAGE = "rfidnav_msgs"

# The message types rosidl generates for each action besides Goal/Result/Feedback (rosidl_adapter's
# action -> service/message expansion); written as .msg text so rosbags parses them like any message.
_ACTION_DERIVED = {
    "_SendGoal_Request": "unique_identifier_msgs/UUID goal_id\n{action}_Goal goal",
    "_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp",
    "_GetResult_Request": "unique_identifier_msgs/UUID goal_id",
    "_GetResult_Response": "int8 status\n{action}_Result result",
    "_FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n{action}_Feedback feedback",
}


# ----------------------------------------------------------------------------------------------- types

def _install_prefixes() -> list[Path]:
    """Where installed ROS packages live: AMENT_PREFIX_PATH as a sourced workspace sets it, then this venv."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes.append(Path(sys.prefix))
    return prefixes


def _package_share(package: str) -> Path | None:
    for prefix in _install_prefixes():
        share = prefix / "share" / package
        if share.is_dir():
            return share
    return None


# Parsed interface packages, one file per package and content (rosbags' IDL parser takes about a second for
# rfidnav_msgs: every recorder, report and replay would pay it): beside the venv's packages, as pip's caches are.
TYPES_CACHE = Path(sys.prefix) / "var" / "cache" / "rfidnav" / "types"


def _package_types(package: str, share: Path) -> dict:
    """Every message, service and action definition an installed interface package ships, parsed (once per
    content: the parse is cached in TYPES_CACHE under the hash of the package's definition files)."""
    sources = sorted(path for folder in ("msg", "srv", "action") for path in (share / folder).glob("*.*"))
    digest = hashlib.sha256()
    try:
        for source in sources:
            digest.update(f"{source.relative_to(share)}\0".encode() + source.read_bytes() + b"\0")
    except OSError as error:
        raise BagError(f"{error.filename}: cannot read this interface definition: {error.strerror}") from error
    cached = TYPES_CACHE / f"{package}-{digest.hexdigest()[:32]}.pickle"
    try:
        return pickle.loads(cached.read_bytes())
    except OSError:
        pass      # not parsed yet: parse it
    except (pickle.UnpicklingError, EOFError, ValueError, IndexError, AttributeError, ImportError):
        pass      # a torn or foreign file (what unpickling garbage raises): parse it and write it anew
    types = _parse_package_types(package, share)
    try:
        cached.parent.mkdir(parents=True, exist_ok=True)
        partial = cached.with_suffix(f".{os.getpid()}.part")
        partial.write_bytes(pickle.dumps(types))
        partial.replace(cached)
    except OSError:
        pass      # a read-only venv: parse each time
    return types


def _parse_package_types(package: str, share: Path) -> dict:
    """Parse every message, service and action definition an installed interface package ships."""
    types: dict = {}
    source = share
    try:
        for source in sorted((share / "msg").glob("*.msg")):
            types.update(get_types_from_msg(source.read_text(encoding="utf-8"), f"{package}/msg/{source.stem}"))
        for source in sorted((share / "srv").glob("*.idl")):     # requests and responses (and service events)
            types.update(get_types_from_idl(_without_includes(source)))
        for source in sorted((share / "action").glob("*.idl")):
            types.update(get_types_from_idl(_without_includes(source)))
            action = f"{package}/action/{source.stem}"
            for suffix, text in _ACTION_DERIVED.items():
                types.update(get_types_from_msg(text.format(action=action), action + suffix))
    except (TypesysError, OSError, UnicodeDecodeError) as error:
        raise BagError(f"{source}: cannot parse this interface definition: {error}") from error
    return types


def _without_includes(source: Path) -> str:
    # rosbags' IDL parser takes no #include lines; the included types are in the typestore already.
    return re.sub(r"^#include .*$", "", source.read_text(encoding="utf-8"), flags=re.MULTILINE)


def _register(store: Typestore, types: dict, origin: str) -> None:
    try:
        store.register(types)
    except TypesysError as error:  # same name, different fields: two versions of one package
        raise BagError(f"{origin}: {error}") from error


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The ROS 2 Jazzy typestore plus the installed rfidnav_msgs types (cached, shared).

    Without rfidnav_msgs installed the plain Jazzy store is returned; bags still decode from the message
    definitions the recorder embeds in them (see :func:`read_messages`)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    share = _package_share(INTERFACE_PACKAGE)
    if share is not None:
        _register(store, _package_types(INTERFACE_PACKAGE, share), str(share))
    return store


def register_installed_type(msgtype: str) -> bool:
    """Make ``msgtype`` known to :func:`typestore` by loading its package's installed definitions.

    For types of third-party packages the recorder meets on the graph. Returns whether the type is known."""
    store = typestore()
    if msgtype in store.fielddefs:
        return True
    package = msgtype.split("/", 1)[0]
    share = _package_share(package)
    if share is None:
        return False
    types = {name: fields for name, fields in _package_types(package, share).items() if name not in store.fielddefs}
    _register(store, types, str(share))
    return msgtype in store.fielddefs


def _type_closure(store: Typestore, msgtype: str) -> list[str]:
    """msgtype and every type its fields use, depth first."""
    seen: list[str] = []
    pending = [msgtype]
    while pending:
        name = pending.pop()
        if name in seen:
            continue
        seen.append(name)
        for _, desc in store.fielddefs[name][1]:
            pending.extend(_nested_names(desc))
    return seen


def _nested_names(desc: tuple) -> list[str]:
    kind, arg = desc
    if kind == 2:  # Nodetype.NAME
        return [arg]
    if kind in (3, 4):  # Nodetype.ARRAY / SEQUENCE: ((kind, arg), length)
        return _nested_names(arg[0])
    return []


def _in_msg_namespace(name: str) -> str:
    package, namespace, leaf = name.split("/")
    return name if namespace == "msg" else f"{package}/msg/{leaf}"


def _short_name(name: str) -> str:
    package, _, leaf = name.split("/")
    return f"{package}/{leaf}"


def _rename_desc(desc: tuple) -> tuple:
    kind, arg = desc
    if kind == 2:
        return (kind, _in_msg_namespace(arg))
    if kind in (3, 4):
        return (kind, (_rename_desc(arg[0]), arg[1]))
    return desc


_FIELD = re.compile(r"^(?P<type>[A-Za-z][\w/]*)(?P<rest>(\[[^\]]*\])? .*)$")


def _restore_namespaces(text: str, msgtype: str, moved: set[str]) -> str:
    """Put the action (or service) types that were rendered as ``pkg/Leaf`` back where they live.

    Each ``MSG:`` line gets the full name (``MSG: pkg/action/X_Feedback``, the form rosbag2 writes), and a field
    of such a type is written relative (``X_Feedback feedback``) when its owner lives in the same package and
    namespace -- always the case for rosidl's action-derived types. Both readers resolve a relative name in
    the owner's namespace (rosbags: ``pkg/action/X_Feedback``, so the RIHS01 hash checks out; mcap_ros2: in the
    owner's package). A full three-part name in a field would do for rosbags, but mcap_ros2 0.6 rejects it."""
    by_short = {_short_name(name): name for name in moved}
    blocks = text.split(f"{'=' * 80}\n")
    restored = []
    for index, block in enumerate(blocks):
        lines = block.split("\n")
        owner = msgtype
        if index:  # "MSG: pkg/Leaf" opens every block after the first
            owner = by_short.get(lines[0].removeprefix("MSG: "), lines[0].removeprefix("MSG: "))
            lines[0] = f"MSG: {owner}"
        owner_space = owner.rsplit("/", 1)[0]
        for number, line in enumerate(lines[1:] if index else lines, start=1 if index else 0):
            match = _FIELD.match(line)
            if match is None or match["type"] not in by_short:
                continue
            full = by_short[match["type"]]
            package_space, leaf = full.rsplit("/", 1)
            lines[number] = f"{leaf if package_space == owner_space else full}{match['rest']}"
        restored.append("\n".join(lines))
    return f"{'=' * 80}\n".join(restored)


@functools.cache
def message_definition(msgtype: str) -> tuple[str, str]:
    """(ros2msg definition text with its dependencies, RIHS01 hash) of a type known to :func:`typestore`.

    This is what MCAP schema records carry so Foxglove, ``mcap_ros2`` and rosbags decode without rfidnav
    installed. rosbags renders nested type names as ``pkg/Type``, which it can only do for ``pkg/msg/Type``;
    action types (``pkg/action/X_Feedback``) are therefore rendered from a scratch store where they are filed
    under ``msg`` and then put back in their namespace (:func:`_restore_namespaces`), so that a reader that
    parses the text and hashes it (rosbags' AnyReader) gets the RIHS01 hash rosidl computed, which is the one
    returned here (computed on the real names)."""
    store = typestore()
    if msgtype not in store.fielddefs:
        raise BagError(f"message type {msgtype} is unknown (not in ROS 2 Jazzy, not installed)")
    rihs01 = store.hash_rihs01(msgtype)
    closure = _type_closure(store, msgtype)
    moved = {name for name in closure if name.split("/")[1] != "msg"}
    if not moved:
        return store.generate_msgdef(msgtype, ros_version=2)[0], rihs01
    scratch = get_typestore(Stores.ROS2_JAZZY)
    renamed = {
        _in_msg_namespace(name): (store.fielddefs[name][0],
                                  [(field, _rename_desc(desc)) for field, desc in store.fielddefs[name][1]])
        for name in closure if name not in scratch.fielddefs
    }
    scratch.register(renamed)
    text = scratch.generate_msgdef(_in_msg_namespace(msgtype), ros_version=2)[0]
    return _restore_namespaces(text, msgtype, moved), rihs01


# ----------------------------------------------------------------------------------------------- info

@dataclass(frozen=True)
class OfferedQos:
    """The QoS one recorded publisher offered (rosbag2 metadata names, lower case)."""

    reliability: str  # reliable | best_effort | ...
    durability: str  # transient_local | volatile | ...
    history: str  # keep_last | keep_all | ...
    depth: int

    def __str__(self) -> str:
        # DDS discovery carries neither history nor depth, so recorded offers say "unknown": leave it out.
        history = "" if self.history == "unknown" else f" {self.history}({self.depth})"
        return f"{self.reliability} {self.durability}{history}"


@dataclass(frozen=True)
class TopicInfo:
    name: str
    msgtype: str
    count: int
    qos: str | None  # one line summarising the distinct offered profiles; None when the bag recorded none
    offered_qos: tuple[OfferedQos, ...] = ()

    @property
    def latched(self) -> bool:
        """Every publisher kept its last messages for late joiners (maps, markers, action status)."""
        return bool(self.offered_qos) and all(q.durability == "transient_local" for q in self.offered_qos)

    @property
    def reliable(self) -> bool:
        return all(q.reliability == "reliable" for q in self.offered_qos)


@dataclass(frozen=True)
class BagFile:
    """One storage file of a bag, as metadata.yaml lists it (or as read, for a bag that was not finalised), with
    what its MCAP chunk records say."""

    path: Path
    message_count: int
    start_ns: int
    duration_s: float
    size_bytes: int
    compression: str  # of its chunks: none | zstd | lz4 (several: joined by ", "); "-" for non-MCAP storage,
    # "unknown" for a file of which no chunk could be read


@dataclass(frozen=True)
class BagInfo:
    path: Path
    storage: str  # storage plugin of the files: mcap | sqlite3
    start_ns: int  # first message's timestamp (0 for an empty bag)
    end_ns: int  # last message's timestamp
    duration_s: float
    message_count: int
    topics: tuple[TopicInfo, ...]
    files: tuple[BagFile, ...] = ()
    ros_distro: str | None = None
    notes: tuple[str, ...] = ()  # what was lost or rebuilt, one line each: empty for a finalised, intact bag

    @property
    def compression(self) -> str:
        """The chunk compression of the files ("none" when no file is compressed)."""
        return ", ".join(dict.fromkeys(f.compression for f in self.files)) or "none"

    def selected(self, names: Iterable[str], where: str, field: str) -> tuple[TopicInfo, ...]:
        """The recorded topics named (all of them for none), refused as a ConfigError at ``where``/``field`` if one
        is not in the bag: checked by the replay verb before it leases a domain, and by the player itself."""
        recorded = {topic.name: topic for topic in self.topics}
        names = list(names)
        missing = [name for name in names if name not in recorded]
        if missing:
            raise ConfigError(where, field, f"{', '.join(missing)} not in bag {self.path} "
                                            f"(it has {', '.join(recorded) or 'no topics'})")
        return tuple(recorded[name] for name in names) if names else self.topics

    def topic(self, name: str) -> TopicInfo:
        for info in self.topics:
            if info.name == name:
                return info
        raise KeyError(name)


def is_bag_directory(path: Path) -> bool:
    """A folder that holds a rosbag2 bag, finished or not: metadata.yaml, or MCAP files without it."""
    return path.is_dir() and ((path / "metadata.yaml").is_file() or any(path.glob("*.mcap")))


def _checked_bag_path(path: str | Path) -> Path:
    bag = Path(path)
    if not bag.exists():
        raise BagError(f"{bag}: no such bag (path does not exist)")
    if not bag.is_dir():
        raise BagError(f"{bag}: not a rosbag2 directory (expected a directory with metadata.yaml and .mcap files)")
    if not is_bag_directory(bag):
        raise BagError(f"{bag}: not a rosbag2 directory (no metadata.yaml, no .mcap file)")
    return bag


def _offered(connection: Connection) -> tuple[OfferedQos, ...]:
    profiles = getattr(connection.ext, "offered_qos_profiles", None) or []
    return tuple(OfferedQos(q.reliability.name.lower(), q.durability.name.lower(), q.history.name.lower(), q.depth)
                 for q in profiles)


def _topics(connections: Iterable[Connection]) -> tuple[TopicInfo, ...]:
    """One TopicInfo per topic name (a topic recorded with two types counts both)."""
    by_name: dict[str, list[Connection]] = {}
    for connection in connections:
        by_name.setdefault(connection.topic, []).append(connection)
    topics = []
    for name, group in sorted(by_name.items()):
        offered: tuple[OfferedQos, ...] = ()
        for connection in group:
            offered += _offered(connection)
        distinct = list(dict.fromkeys(str(q) for q in offered))
        msgtypes = {c.msgtype for c in group}
        topics.append(TopicInfo(name=name, msgtype=msgtypes.pop() if len(msgtypes) == 1 else "(several types)",
                                count=sum(c.msgcount for c in group),
                                qos="; ".join(distinct) if distinct else None, offered_qos=offered))
    return tuple(topics)


def _yaml_problem(error: YAMLError) -> str:
    problem, mark = getattr(error, "problem", None), getattr(error, "problem_mark", None)
    if problem and mark is not None:
        return f"{problem} at line {mark.line + 1}"
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def _load_information(bag: Path) -> tuple[dict | None, str | None]:
    """metadata.yaml's rosbag2_bagfile_information, or None and why it cannot be used."""
    path = bag / "metadata.yaml"
    if not path.is_file():
        return None, "no metadata.yaml"
    try:
        document = YAML(typ="safe").load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as error:
        return None, f"metadata.yaml cannot be read ({error})"
    except YAMLError as error:
        return None, f"metadata.yaml is not valid YAML ({_yaml_problem(error)})"
    information = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(information, dict) or not isinstance(information.get("relative_file_paths"), list):
        return None, "metadata.yaml holds no rosbag2_bagfile_information with relative_file_paths"
    return information, None


def _file_order(path: Path) -> tuple[str, int]:
    """bag_2.mcap before bag_10.mcap, as rosbag2 numbers them."""
    stem, _, number = path.stem.rpartition("_")
    return (stem, int(number)) if number.isdigit() else (path.stem, -1)


def _listed_files(bag: Path, information: dict) -> list[Path]:
    return [bag / Path(str(relative)).name for relative in information["relative_file_paths"]]


def _summary(path: Path) -> Summary | None:
    """The MCAP summary of ``path`` if its footer and summary are intact, else None."""
    try:
        with path.open("rb") as stream:
            return make_reader(stream).get_summary()
    except (McapError, OSError, struct.error, ValueError):
        return None


def _compression(names: Iterable[str]) -> str:
    return ", ".join(sorted({name or "none" for name in names})) or "none"


class Bag:
    """An open bag (:func:`open_bag`): what it holds (``info``, ``connections``) and its messages.

    Complete bags -- metadata.yaml and every file's MCAP summary agree -- are read with rosbags; any other is
    salvaged (:class:`_SalvagedBag`) and ``info.notes`` says what was lost or rebuilt."""

    path: Path
    info: BagInfo
    connections: list[Connection]

    def messages(self, connections: list[Connection], start_ns: int | None = None) -> Iterator[
            tuple[Connection, int, bytes]]:
        """(connection, timestamp, CDR) of ``connections`` (not empty) in time order, from ``start_ns`` on."""
        raise NotImplementedError

    def close(self) -> None:
        """Let go of the files."""

    def __enter__(self) -> Bag:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()


class _CompleteBag(Bag):
    """A finished bag, read with rosbags' Reader."""

    def __init__(self, bag: Path, information: dict, summaries: list[Summary | None]) -> None:
        self.path = bag
        try:
            self.reader = Reader(bag)
            self.reader.open()
        except (ReaderError, OSError, struct.error, UnicodeDecodeError) as error:
            # ReaderError: rosbags' own checks (magic, footer, record sizes, metadata keys); struct.error and
            # UnicodeDecodeError: a corrupt record that passed those checks but cannot be unpacked.
            raise BagError(f"{bag}: unreadable bag (truncated or corrupt?): {error}") from error
        self.connections = list(self.reader.connections)
        count = self.reader.message_count
        # rosbags reports end_time one past the last message (a half-open range); we report the message itself.
        start_ns = self.reader.start_time if count else 0
        end_ns = self.reader.end_time - 1 if count else 0
        storage = str(information["storage_identifier"])
        entries = {Path(str(entry["path"])).name: entry for entry in information.get("files") or []}
        files = []
        for path, summary in zip(_listed_files(bag, information), summaries, strict=True):
            entry = entries.get(path.name, {})
            files.append(BagFile(
                path=path, message_count=int(entry.get("message_count", 0)),
                start_ns=int(entry.get("starting_time", {}).get("nanoseconds_since_epoch", 0)),
                duration_s=int(entry.get("duration", {}).get("nanoseconds", 0)) / 1e9,
                size_bytes=path.stat().st_size,
                compression=_compression(i.compression for i in summary.chunk_indexes) if summary else "-"))
        self.info = BagInfo(path=bag, storage=storage, start_ns=start_ns, end_ns=end_ns,
                            duration_s=(end_ns - start_ns) / 1e9, message_count=count,
                            topics=_topics(self.connections), files=tuple(files),
                            ros_distro=information.get("ros_distro"))

    def messages(self, connections: list[Connection], start_ns: int | None = None) -> Iterator[
            tuple[Connection, int, bytes]]:
        try:
            yield from self.reader.messages(connections, start=start_ns)
        except (ReaderError, struct.error, UnicodeDecodeError) as error:
            raise BagError(f"{self.path}: corrupt message data (truncated or damaged chunk?): {error}") from error

    def close(self) -> None:
        self.reader.close()


def _complete_bag(bag: Path, information: dict) -> tuple[_CompleteBag | None, str | None]:
    """The bag read with rosbags if metadata.yaml and the files' summaries agree, else (None, what is wrong with
    metadata.yaml, if it is metadata.yaml that is unusable)."""
    if information.get("storage_identifier") != "mcap":  # sqlite3: rosbags' to read, nothing to salvage
        return _CompleteBag(bag, information, [None] * len(information["relative_file_paths"])), None
    listed = _listed_files(bag, information)
    if not listed or set(listed) != set(bag.glob("*.mcap")):
        return None, None
    summaries = [_summary(path) for path in listed]
    counted = [s.statistics.message_count for s in summaries if s is not None and s.statistics is not None]
    if len(counted) != len(listed) or sum(counted) != information.get("message_count"):
        return None, None   # a file without summary, or metadata.yaml of a checkpoint: salvage
    try:
        return _CompleteBag(bag, information, list(summaries)), None
    except BagError as error:  # intact files, but metadata.yaml that rosbags refuses (keys missing, ...)
        return None, f"metadata.yaml is not usable ({error.__cause__ or error})"


_DEFINITION_FORMATS = {"ros2msg": MessageDefinitionFormat.MSG, "ros2idl": MessageDefinitionFormat.IDL,
                       "omgidl": MessageDefinitionFormat.IDL}


def _channel_qos(channel: SalvagedChannel) -> list:
    try:
        return parse_qos(channel.metadata.get("offered_qos_profiles", ""))
    except (ReaderError, KeyError, TypeError, AttributeError):
        return []


def _file_note(scan: FileScan) -> str | None:
    """One line on what reading ``scan``'s file lost, or None for a complete file."""
    name = scan.path.name
    skipped = f"; {scan.damaged_chunks} damaged chunk(s) skipped" if scan.damaged_chunks else ""
    if scan.complete:
        return f"{name}: read {scan.message_count:,} messages{skipped}" if skipped else None
    if not scan.message_count and not scan.channels:
        return f"{name} is unreadable: {scan.problem}"
    if scan.data_complete:
        return (f"{name} has no intact summary ({scan.problem}): all its {scan.message_count:,} messages were read, "
                f"the summary rebuilt{skipped}")
    if not scan.cut:
        tail = f"{scan.problem}: the {scan.lost_bytes:,} bytes from there on are lost"
    elif scan.lost_bytes:
        tail = f"the last, incomplete chunk ({scan.lost_bytes:,} bytes) is lost"
    else:
        tail = "the file ends after a whole chunk: later messages were never written to it"
    return (f"{name} has no summary (the recorder stopped without closing it, or the file was cut): read "
            f"{scan.message_count:,} messages up to {scan.end_ns / 1e9:.1f} s; {tail}{skipped}")


class _SalvagedBag(Bag):
    """A bag that was not finalised or is damaged: its files read from their start (:mod:`rfidnav_bag.salvage`),
    topics, counts and times rebuilt from the records read. The messages of each file are sorted by time in
    memory (the files follow each other in time), one file at a time."""

    def __init__(self, bag: Path, information: dict | None, metadata_problem: str | None) -> None:
        self.path = bag
        notes = [f"{metadata_problem}: topics and counts rebuilt from the MCAP files"] if metadata_problem else []
        listed = _listed_files(bag, information) if information is not None else []
        notes += [f"{path.name} (listed in metadata.yaml) is missing: its messages are lost"
                  for path in listed if not path.is_file()]
        self.files = [p for p in listed if p.is_file()]
        self.files += sorted(set(bag.glob("*.mcap")) - set(self.files), key=_file_order)
        scans = []
        for path in self.files:
            try:
                scans.append(scan_file(path))
            except OSError as error:
                raise BagError(f"{path}: cannot read: {error}") from error
        notes += [note for note in map(_file_note, scans) if note]
        if not any(scan.message_count or scan.complete for scan in scans):
            raise BagError(f"{bag}: no message readable: {'; '.join(notes) or 'no .mcap file'}")
        first: dict[tuple[str, str], SalvagedChannel] = {}  # (topic, type) -> its channel in the first file
        counts: Counter[tuple[str, str]] = Counter()
        for scan in scans:
            for channel_id, channel in scan.channels.items():
                key = (channel.topic, channel.schema_name)
                first.setdefault(key, channel)
                counts[key] += scan.counts[channel_id]
        self.connections = [
            Connection(id=index, topic=channel.topic, msgtype=channel.schema_name,
                       msgdef=MessageDefinition(
                           _DEFINITION_FORMATS.get(channel.schema_encoding, MessageDefinitionFormat.NONE),
                           channel.schema_data.decode("utf-8", errors="replace")),
                       digest=channel.metadata.get("topic_type_hash", ""), msgcount=counts[key],
                       ext=ConnectionExtRosbag2(serialization_format=channel.message_encoding,
                                                offered_qos_profiles=_channel_qos(channel)),
                       owner=None)
            for index, (key, channel) in enumerate(first.items(), start=1)]
        self.by_key = {(c.topic, c.msgtype): c for c in self.connections}
        read = [scan for scan in scans if scan.message_count]
        start_ns = min((scan.start_ns for scan in read), default=0)
        end_ns = max((scan.end_ns for scan in read), default=0)
        distro = information.get("ros_distro") if information is not None else None
        recorded = next((scan.rosbag2_metadata for scan in scans if scan.rosbag2_metadata), None)
        if distro is None and recorded is not None:
            try:
                distro = (YAML(typ="safe").load(recorded) or {}).get("ros_distro")
            except (YAMLError, AttributeError):
                distro = None
        self.info = BagInfo(
            path=bag, storage="mcap", start_ns=start_ns, end_ns=end_ns, duration_s=(end_ns - start_ns) / 1e9,
            message_count=sum(scan.message_count for scan in scans), topics=_topics(self.connections),
            files=tuple(BagFile(path=scan.path, message_count=scan.message_count, start_ns=scan.start_ns,
                                duration_s=(scan.end_ns - scan.start_ns) / 1e9, size_bytes=scan.size_bytes,
                                compression=_compression(scan.compressions) if scan.compressions else "unknown")
                        for scan in scans),
            ros_distro=distro, notes=tuple(notes))

    def messages(self, connections: list[Connection], start_ns: int | None = None) -> Iterator[
            tuple[Connection, int, bytes]]:
        wanted = {(c.topic, c.msgtype) for c in connections}
        for path in self.files:
            found = []
            try:
                for channel, message in salvaged_messages(path):
                    key = (channel.topic, channel.schema_name)
                    if key in wanted and (start_ns is None or message.log_time >= start_ns):
                        found.append((message.log_time, self.by_key[key], message.data))
            except OSError as error:
                raise BagError(f"{path}: cannot read: {error}") from error
            found.sort(key=lambda item: item[0])  # stable: messages of one time keep their order in the file
            for timestamp, connection, data in found:
                yield connection, timestamp, data


def open_bag(path: str | Path, salvage: bool = False) -> Bag:
    """Open a rosbag2 directory, finished or not (a BagError naming the path if nothing in it can be read).
    ``salvage``: read every file from its start even if the bag looks finished, so that a damaged chunk is
    skipped (and counted in the notes) instead of ending the read with a BagError. Use as a context manager."""
    bag = _checked_bag_path(path)
    information, metadata_problem = _load_information(bag)
    if information is not None and not (salvage and information.get("storage_identifier") == "mcap"):
        complete, metadata_problem = _complete_bag(bag, information)
        if complete is not None:
            return complete
    return _SalvagedBag(bag, information, metadata_problem)


def bag_info(path: str | Path) -> BagInfo:
    """Topics, types, counts, QoS and time span of a rosbag2 directory, and for a bag that was not finalised or
    is damaged what was lost (``notes``); BagError if nothing in it can be read."""
    with open_bag(path) as bag:
        return bag.info


def _seconds(nanoseconds: int) -> str:
    """Exact decimal seconds (a float would round the nanoseconds of an epoch timestamp)."""
    return f"{nanoseconds // 1_000_000_000}.{nanoseconds % 1_000_000_000:09d}"


def format_bag_info(info: BagInfo) -> str:
    """A table for people, in the spirit of ``ros2 bag info``."""
    lines = [
        f"Bag:              {info.path}",
        f"Storage:          {info.storage} ({info.ros_distro or 'ROS distribution not recorded'})",
        f"Compression:      {info.compression}",
        f"Duration:         {info.duration_s:.3f} s",
        f"Start:            {_seconds(info.start_ns)} s",
        f"End:              {_seconds(info.end_ns)} s",
        f"Messages:         {info.message_count}",
        f"Topics:           {len(info.topics)}",
        f"Files:            {len(info.files)}",
    ]
    for file in info.files:
        lines.append(f"  {file.path.name}: {file.message_count} messages, {file.duration_s:.3f} s from "
                     f"{_seconds(file.start_ns)} s, {file.size_bytes} bytes, {file.compression}")
    if info.topics:
        name_width = max(len("topic"), *(len(t.name) for t in info.topics))
        type_width = max(len("type"), *(len(t.msgtype) for t in info.topics))
        count_width = max(len("count"), *(len(str(t.count)) for t in info.topics))
        lines.append("")
        lines.append(f"{'topic':<{name_width}}  {'type':<{type_width}}  {'count':>{count_width}}  qos")
        lines.append(f"{'-' * name_width}  {'-' * type_width}  {'-' * count_width}  ---")
        for topic in info.topics:
            lines.append(f"{topic.name:<{name_width}}  {topic.msgtype:<{type_width}}  "
                         f"{topic.count:>{count_width}}  {topic.qos or '-'}")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------- messages

def clock_stamp_ns(data: bytes) -> int | None:
    """The time a rosgraph_msgs/Clock message carries, from its CDR bytes (None if too short to hold one).

    CDR: a 4-byte encapsulation header (its second byte 1 for little endian), then builtin_interfaces/Time
    (int32 sec, uint32 nanosec)."""
    if len(data) < 12:
        return None
    sec, nanosec = struct.unpack_from("<iI" if data[1] == 1 else ">iI", data, 4)
    return sec * 1_000_000_000 + nanosec


class RawMessage(NamedTuple):
    """One recorded message as stored: CDR bytes, ready to republish."""

    topic: str
    msgtype: str
    timestamp_ns: int
    data: bytes


def _selected(connections: list[Connection], topics: Iterable[str] | None) -> list[Connection]:
    """The connections of ``topics``; a topic the bag lacks simply has no messages (a run where nothing was
    ever published on it records no connection). Callers that need a topic check ``bag_info`` first."""
    if topics is None:
        return connections
    wanted = set(topics)
    return [c for c in connections if c.topic in wanted]


def read_raw(path: str | Path, topics: Iterable[str] | None = None, *,
             start_ns: int | None = None) -> Iterator[RawMessage]:
    """Yield the recorded messages (all, or those of ``topics``; absent topics yield nothing) as raw CDR in
    time order; of a bag that was not finalised, those of its intact chunks (see ``bag_info``'s notes).

    ``start_ns`` skips messages stamped before it (absolute bag time). Lazy: errors, including a missing bag,
    surface as BagError on the first ``next()``."""
    with open_bag(path) as bag:
        connections = _selected(bag.connections, topics)
        if not connections:  # rosbags reads every connection when given none
            return
        for connection, timestamp, data in bag.messages(connections, start_ns):
            yield RawMessage(connection.topic, connection.msgtype, timestamp, bytes(data))


def _store_for(bag: Path, connections: list[Connection]) -> Typestore:
    """The shared typestore if it knows every type; else one extended with the bag's embedded definitions
    (a bag from another robot's packages), so the shared store never takes in a stranger's definitions."""
    store = typestore()
    unknown = [c for c in connections if c.msgtype not in store.fielddefs]
    if not unknown:
        return store
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register({name: store_fields for name, store_fields in typestore().fielddefs.items()
                    if name not in store.fielddefs})
    for connection in unknown:
        if connection.msgtype in store.fielddefs:
            continue
        definition = connection.msgdef
        if definition.format != MessageDefinitionFormat.MSG or not definition.data.strip():
            raise BagError(f"{bag}: topic {connection.topic}: message type {connection.msgtype} is unknown and "
                           "the bag carries no definition for it")
        try:
            store.register(get_types_from_msg(definition.data, connection.msgtype))
        except TypesysError as error:
            raise BagError(f"{bag}: topic {connection.topic}: cannot use the bag's definition of "
                           f"{connection.msgtype}: {error}") from error
    return store


def read_messages(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, object]]:
    """Yield (topic, timestamp_ns, message) in time order, messages deserialised as rosbags dataclasses.

    Lazy like :func:`read_raw`. A message that does not deserialise raises BagError naming the topic."""
    with open_bag(path) as bag:
        connections = _selected(bag.connections, topics)
        if not connections:
            return
        store = _store_for(bag.path, connections)
        for connection, timestamp, data in bag.messages(connections):
            try:
                message = store.deserialize_cdr(data, connection.msgtype)
            except SerdeError as error:
                raise BagError(f"{bag.path}: topic {connection.topic}: message at {timestamp} ns does not "
                               f"deserialise as {connection.msgtype}: {error}") from error
            yield connection.topic, timestamp, message
