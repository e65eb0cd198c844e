"""The tasks file of an experiment: one JSON line per finished task, written as its result arrives, so that an
interrupted reproduction resumes where it stopped (``--resume``) and the figures are computed from exactly what the
file holds.

The first line is a header: the experiment, its arguments and the fingerprint of the code and configuration that
produced the results (:func:`code_fingerprint`); a resume with any of them changed is refused, as its rows would
mix two experiments. Every further line is one task: its batch (the experiment's stage, e.g. "reproduce
partitions: navigations"), its key (the batch and a digest of the job), the job and its result, both in
:func:`encode`'s tagged JSON. A line cut short by the interruption is dropped on resume and its task run again.

The codec keeps what the experiments' results hold: dataclasses (by import path), tuples, dicts with any keys,
numpy arrays and scalars, and floats to the last bit (JSON's shortest round-trip repr; NaN and infinities as
Python's json writes them).
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import importlib.util
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from rfidnav_common.errors import ConfigError

FORMAT = 1
# The packages whose code makes an experiment's results (their *.py files) and the configuration they read.
RESULT_PACKAGES = ("rfidnav_common", "rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning",
                   "rfidnav_scenario", "rfidnav_bringup", "rfidnav_experiments")


def encode(value: Any) -> Any:
    """``value`` as JSON-ready data that :func:`decode` turns back into an equal value of the same types."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, (np.integer, np.floating)):
        return value
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return {"__numpy__": type(value).__name__, "value": value.item()}
    if isinstance(value, np.ndarray):
        return {"__ndarray__": value.tolist(), "dtype": value.dtype.str, "shape": list(value.shape)}
    if isinstance(value, tuple):
        return {"__tuple__": [encode(item) for item in value]}
    if isinstance(value, list):
        return [encode(item) for item in value]
    if isinstance(value, (set, frozenset)):
        return {"__set__": sorted((encode(item) for item in value), key=repr), "frozen": isinstance(value, frozenset)}
    if isinstance(value, dict):
        if all(isinstance(key, str) and not key.startswith("__") for key in value):
            return {key: encode(item) for key, item in value.items()}
        return {"__dict__": [[encode(key), encode(item)] for key, item in value.items()]}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        kind = type(value)
        return {"__dataclass__": f"{kind.__module__}:{kind.__qualname__}",
                **{field.name: encode(getattr(value, field.name)) for field in dataclasses.fields(value)}}
    raise TypeError(f"a task result cannot hold a {type(value).__qualname__} ({value!r:.60})")


def decode(data: Any) -> Any:
    """The value :func:`encode` was given."""
    if isinstance(data, list):
        return [decode(item) for item in data]
    if not isinstance(data, dict):
        return data
    if "__tuple__" in data:
        return tuple(decode(item) for item in data["__tuple__"])
    if "__ndarray__" in data:
        return np.array(data["__ndarray__"], dtype=np.dtype(data["dtype"])).reshape(data["shape"])
    if "__numpy__" in data:
        return getattr(np, data["__numpy__"])(data["value"])
    if "__set__" in data:
        items = (decode(item) for item in data["__set__"])
        return frozenset(items) if data["frozen"] else set(items)
    if "__dict__" in data:
        return {decode(key): decode(item) for key, item in data["__dict__"]}
    if "__dataclass__" in data:
        module, _, name = data["__dataclass__"].partition(":")
        kind: Any = importlib.import_module(module)
        for part in name.split("."):
            kind = getattr(kind, part)
        return kind(**{key: decode(item) for key, item in data.items() if key != "__dataclass__"})
    return {key: decode(item) for key, item in data.items()}


def canonical(value: Any) -> str:
    """One text per value (sorted keys, no spaces): what a task's identity is a digest of."""
    return json.dumps(encode(value), sort_keys=True, separators=(",", ":"), allow_nan=True)


def task_key(batch: str, job: Any) -> str:
    """The task's identity: its batch and a digest of its job, the same on every machine and every run."""
    slug = "-".join("".join(c if c.isalnum() else " " for c in batch).split())
    return f"{slug}-{hashlib.sha256(canonical(job).encode()).hexdigest()[:20]}"


def package_folder(package: str) -> Path:
    """The folder of ``package``'s own ``__init__.py``. Not the package's ``__path__``: run from the source tree's
    root (``python -m``, pytest) the name first finds the outer folder of the same name, a namespace package that
    the editable install's finder then completes."""
    spec = importlib.util.find_spec(f"{package}.__init__")
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError(f"{package} is not installed")
    return Path(spec.origin).parent


def code_fingerprint() -> str:
    """A digest of every Python file of the packages that make the results and of the configuration they read
    (worlds, maps, parameter files): equal on two machines only if both run the same experiments."""
    from rfidnav_scenario.scenario import CONFIG_DIR

    digest = hashlib.sha256()
    roots = [(package, package_folder(package)) for package in RESULT_PACKAGES]
    roots.append(("config", CONFIG_DIR))
    for name, root in roots:
        for path in sorted(path for path in root.rglob("*") if path.is_file() and path.suffix in (".py", ".yaml")
                           and "__pycache__" not in path.parts):
            digest.update(f"{name}/{path.relative_to(root).as_posix()}\0".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:24]


@dataclass(frozen=True)
class Header:
    experiment: str
    arguments: dict[str, Any]
    code: str

    def line(self) -> str:
        return json.dumps({"rfidnav_tasks": FORMAT, "experiment": self.experiment, "arguments": self.arguments,
                           "code": self.code}, sort_keys=True)

    def differences(self, other: Header) -> list[str]:
        return [f"{name}: {getattr(other, name)!r} in the file, {getattr(self, name)!r} now"
                for name in ("experiment", "arguments", "code") if getattr(self, name) != getattr(other, name)]


class TaskRows:
    """The open tasks file: the results it held on resume (by batch and key) and the lines appended since."""

    def __init__(self, path: Path, header: Header, resume: bool) -> None:
        self.path = path
        self.finished: dict[tuple[str, str], Any] = {}
        self.dropped_line = False
        path.parent.mkdir(parents=True, exist_ok=True)
        if resume and path.exists():
            self._read(header)
            self.stream: IO[str] = path.open("a", encoding="utf-8")
        else:
            self.stream = path.open("w", encoding="utf-8")
            self.stream.write(header.line() + "\n")
            self.stream.flush()

    def _read(self, header: Header) -> None:
        lines = self.path.read_text(encoding="utf-8").split("\n")
        try:
            first = json.loads(lines[0])
            held = Header(first["experiment"], first["arguments"], first["code"])
        except (json.JSONDecodeError, KeyError, TypeError) as error:
            raise ConfigError(str(self.path), "line 1", f"not an rfidnav tasks file header ({error}); "
                                                        "run without --resume to start afresh") from None
        if first.get("rfidnav_tasks") != FORMAT:
            raise ConfigError(str(self.path), "line 1", f"tasks file format {first.get('rfidnav_tasks')!r}, "
                                                        f"this rfidnav writes {FORMAT}")
        differences = header.differences(held)
        if differences:
            raise ConfigError(str(self.path), "line 1", "cannot resume another experiment's tasks: "
                              + "; ".join(differences) + " (run without --resume to start afresh)")
        body = lines[1:]
        for number, text in enumerate(body, start=2):
            if not text.strip():
                continue
            try:
                row = json.loads(text)
                self.finished[(row["batch"], row["task"])] = decode(row["result"])
            except (json.JSONDecodeError, KeyError, TypeError):
                if number != len(lines):      # only the last line, with no newline after it, can be cut short
                    raise ConfigError(str(self.path), f"line {number}", "not a task row") from None
                self.dropped_line = True
        if self.dropped_line:
            # Rewrite without the cut line, so the rows appended next start on a line of their own.
            self.path.write_text("\n".join(lines[:-1]) + "\n", encoding="utf-8")

    def finished_in(self, batch: str) -> Iterator[tuple[str, Any]]:
        return ((key, result) for (row_batch, key), result in self.finished.items() if row_batch == batch)

    def append(self, batch: str, key: str, job: Any, result_data: Any) -> None:
        self.stream.write(json.dumps({"batch": batch, "task": key, "job": encode(job), "result": result_data})
                          + "\n")
        self.stream.flush()

    def close(self) -> None:
        self.stream.close()
