"""Installed packages as ``ros2 run`` finds them: the install prefixes, a package's share folder (REP 122's ament
index), and the command of a package's executable, in a colcon install or the workspace's editable one."""

from __future__ import annotations

import os
import sys
from importlib import metadata
from pathlib import Path

from rfidnav_common.errors import UnknownExecutableError


def install_prefixes() -> list[Path]:
    """Where installed packages are looked up, as ``ros2 run`` does: each AMENT_PREFIX_PATH entry (a colcon
    install), then this Python's prefix (the workspace's .venv)."""
    return [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [Path(sys.prefix)]


def package_share(package: str) -> Path:
    """``<prefix>/share/<package>`` of the first prefix whose ament resource index (REP 122) lists the package:
    a colcon install, or the workspace's .venv where ``./rfidnav setup`` links the sources' share files.
    An unknown package is an :class:`UnknownExecutableError` naming the prefixes searched."""
    prefixes = install_prefixes()
    for prefix in prefixes:
        if (prefix / "share" / "ament_index" / "resource_index" / "packages" / package).is_file():
            return prefix / "share" / package
    raise UnknownExecutableError("package", f"package '{package}' is in no ament index (searched "
                                 f"{', '.join(map(str, prefixes))}); run ./rfidnav setup")


def resolve_executable(package: str, executable: str) -> list[str]:
    """The command for a node executable: ``<prefix>/lib/<package>/<executable>`` on any install prefix
    (a colcon install), else the package's console_scripts entry point (an editable install).
    An unknown package or executable is an :class:`UnknownExecutableError`."""
    for prefix in install_prefixes():
        candidate = prefix / "lib" / package / executable
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return [str(candidate)]
    entry_point = console_script(package, executable)
    script = Path(sys.prefix) / "bin" / executable
    if script.is_file():
        return [str(script)]
    module, function = entry_point.value.split(":")
    return [sys.executable, "-c", f"import sys; from {module} import {function}; sys.exit({function}())"]


def console_script(package: str, executable: str) -> metadata.EntryPoint:
    """The console_scripts entry point ``executable`` of installed package ``package``; an unknown package or
    executable is an :class:`UnknownExecutableError`."""
    try:
        distribution = metadata.distribution(package)
    except metadata.PackageNotFoundError:
        raise UnknownExecutableError("package",
                                     f"unknown package '{package}' (not installed in {sys.prefix})") from None
    scripts = {ep.name: ep for ep in distribution.entry_points if ep.group == "console_scripts"}
    if executable not in scripts:
        raise UnknownExecutableError("executable", f"package '{package}' has no executable '{executable}' "
                                     f"(it has: {', '.join(sorted(scripts)) or 'none'})")
    return scripts[executable]
