"""Command-line value types shared by the verbs of every package (``./rfidnav``'s and the experiments'): argparse
``type`` functions that refuse a bad value in one line naming what they expected, and where runs are written."""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

WORKSPACE = Path(__file__).resolve().parents[2]
# Runs go to the source tree's bags/ (./rfidnav, a colcon --symlink-install), and from a colcon install, where
# WORKSPACE is the install's lib/pythonX.Y, to bags/ in the current folder.
RUNS_DIR = WORKSPACE / "bags" if (WORKSPACE / "rfidnav").is_file() else Path.cwd() / "bags"
Handler = Callable[[argparse.Namespace], int]


def key_value(text: str) -> tuple[str, str]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected ROLE=VALUE, got '{text}'")
    role, value = text.split("=", 1)
    return role, value


def checked_number(convert: Callable[[str], Any], unreadable: str, accepted: Callable[[Any], bool],
                   rejected: Callable[[str], str]) -> Callable[[str], Any]:
    """An argparse ``type``: ``convert`` the text ("expected UNREADABLE" if it cannot be), then keep the value if
    ``accepted``, else fail with ``rejected(text)``."""
    def parse(text: str) -> Any:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {unreadable}, got '{text}'") from None
        if not accepted(value):
            raise argparse.ArgumentTypeError(rejected(text))
        return value

    return parse


MAX_RTF = 1000.0        # a real-time factor beyond it: use max


def _rtf_number(text: str) -> float:
    """``max`` is infinite. The number "inf" is not another way to say it: made NaN here, it is refused as out of
    range (the help promises a number of at most MAX_RTF, or max)."""
    if text == "max":
        return math.inf
    value = float(text)
    return math.nan if math.isinf(value) else value


# --rtf: a number above 0 (at most MAX_RTF), or ``max`` (infinite: as fast as the stepped graph answers).
rtf_value = checked_number(_rtf_number, "a number or 'max'",
                           lambda rtf: rtf == math.inf or 0.0 < rtf <= MAX_RTF,
                           lambda text: f"expected a real-time factor above 0 and at most {MAX_RTF:g}, or max, "
                                        f"got {text}")

MAX_DOMAIN_ID = 101     # ROS 2 on Linux: higher ids run into the ephemeral port range

domain_id = checked_number(int, "a whole number", lambda value: 0 <= value <= MAX_DOMAIN_ID,
                           lambda text: f"must be 0-{MAX_DOMAIN_ID}, got {int(text)}")
# --max-bag-duration: seconds >= 0 (0: no split).
seconds_value = checked_number(float, "a number of seconds", lambda seconds: seconds >= 0.0,
                               lambda text: f"expected seconds >= 0 (0: no split), got {text}")


SEED_MAX = (1 << 63) - 1    # a ROS integer parameter (int64): every node's seed derives from the run's
seed_value = checked_number(int, "a whole number", lambda seed: 0 <= seed <= SEED_MAX,
                            lambda text: f"expected a seed 0-{SEED_MAX}, got {text}")


def count_value(most: int) -> Callable[[str], int]:
    """An argparse ``type`` for a count of runs, seeds, messages, ...: a whole number from 1 to ``most``."""
    return checked_number(int, "a whole number", lambda count: 1 <= count <= most,
                          lambda text: f"expected a whole number 1-{most}, got {text}")


def positive_number(what: str, most: float) -> Callable[[str], float]:
    """An argparse ``type`` for a finite number above 0 and at most ``most`` (seconds, a rate, a spacing)."""
    return checked_number(float, what, lambda value: math.isfinite(value) and 0.0 < value <= most,
                          lambda text: f"expected {what} above 0 and at most {most:g}, got {text}")


MAX_OPTION_S = 86400.0      # waits, timeouts, offsets into a bag: one day
MAX_RATE = 1000.0           # playback speed-ups
option_seconds = positive_number("a number of seconds", MAX_OPTION_S)
option_rate = positive_number("a rate", MAX_RATE)
start_seconds = checked_number(float, "a number of seconds", lambda value: 0.0 <= value <= MAX_OPTION_S,
                               lambda text: f"expected seconds from 0 to {MAX_OPTION_S:g}, got {text}")


def topic_name(text: str) -> str:
    """An argparse ``type`` for a topic name ROS accepts (rclpy's own check)."""
    from rfidnav_common.ros import topic_name_problem  # here, not at the top: it loads rclpy

    problem = topic_name_problem(text, "rfidnav")
    if problem is not None:
        raise argparse.ArgumentTypeError(f"'{text}' is not a valid ROS topic name: {problem}")
    return text


def output_folder(text: str) -> Path:
    """An argparse ``type`` for a folder to write into (created if missing): not a file, not under one, and one this
    user can create folders in (tried: /proc and /sys accept no folders, whatever the permissions say)."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a folder")
    existing = next(parent for parent in (path, *path.parents) if parent.exists())
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(f"{existing} is a file, not a folder")
    if (problem := unwritable(existing)) is not None:
        raise argparse.ArgumentTypeError(problem)
    return path


def unwritable(folder: Path) -> str | None:
    """Why this user cannot write in an existing folder (None if it can), found by trying: permission bits do not
    say it for root, nor for a read-only file system."""
    try:
        Path(tempfile.mkdtemp(dir=folder, prefix=".rfidnav-probe-")).rmdir()
    except OSError as error:
        return f"cannot write in {folder}: {error.strerror}"
    return None


def output_file(text: str) -> Path:
    """An argparse ``type`` for a file to write: not a folder, in an existing folder this user can write in."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder, not a file")
    folder = path.parent
    if not folder.is_dir():
        raise argparse.ArgumentTypeError(f"{folder} is not a folder" if folder.exists() else
                                         f"no folder {folder} (create it first)")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".rfidnav-probe-"):
            pass
    except OSError as error:
        raise argparse.ArgumentTypeError(f"cannot write in {folder}: {error.strerror}") from None
    if path.exists() and not os.access(path, os.W_OK):
        raise argparse.ArgumentTypeError(f"cannot write {text}: permission denied")
    return path


def port_number(text: str, lowest: int = 1) -> int:
    """A TCP port (``lowest`` 0: any free port, which the server then names)."""
    return checked_number(int, "a TCP port number", lambda port: lowest <= port <= 65535,
                          lambda text: f"expected a TCP port {lowest}-65535, got {int(text)}")(text)
