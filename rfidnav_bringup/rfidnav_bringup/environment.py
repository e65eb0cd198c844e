"""Set up the workspace's Python environment: ``./rfidnav setup``, run implicitly by every verb.

Standard library only: it runs with the system Python 3.11 before ``.venv`` exists. Each step is
skipped when the hash of its inputs matches the stamp it left last time, so with nothing changed the
whole set-up takes well under a second; a changed interface file rebuilds rfidnav_msgs, a changed
requirements file reinstalls the pins, a changed package manifest reinstalls the packages.

Steps: (1) create ``.venv``; (2) install ``requirements.txt`` under ``constraints.txt`` (ROS 2 Jazzy
wheels from PyPI and everything else, transitive pins included); (3) build and install the
``rfidnav_msgs`` interface package with CMake into the venv; (4) install the ament_python packages
in editable mode; (5) list them in the venv's ament resource index and link their share files (package.xml,
and rfidnav_scenario's ``config``) from the sources, as ``colcon build --symlink-install`` does, so that code
finds its configuration the same way in this workspace and in a colcon install.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

PYTHON_PACKAGES = ("rfidnav_common", "rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning",
                   "rfidnav_drivers", "rfidnav_bag", "rfidnav_scenario", "rfidnav_bringup",
                   "rfidnav_experiments")   # bottom up
INTERFACE_PACKAGE = "rfidnav_msgs"
# Standard interface packages the Jazzy wheels on PyPI lack, vendored (with the standard definitions) and built
# only where nothing provides them: tf2_msgs for /tf and /tf_static.
VENDORED_INTERFACES = (("tf2_msgs", "rfidnav_msgs/vendor/tf2_msgs"),)


class SetupStepFailed(Exception):
    """A set-up step failed; the message says which and what to do."""


def venv_paths(workspace: Path) -> tuple[Path, Path]:
    venv = workspace / ".venv"
    return venv, venv / "bin" / "python"


def build_environment(venv: Path) -> dict[str, str]:
    """The environment the ROS 2 wheels and CMake need to find what is installed in the venv."""
    env = dict(os.environ)
    env["VIRTUAL_ENV"] = str(venv)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    for var in ("CMAKE_PREFIX_PATH", "AMENT_PREFIX_PATH"):
        env[var] = str(venv)
    return env


def digest(paths: list[Path]) -> str:
    sha = hashlib.sha256()
    for path in sorted(paths):
        sha.update(str(path).encode())
        sha.update(path.read_bytes())
    return sha.hexdigest()


def files_under(root: Path, skip_dirs: tuple[str, ...] = ("__pycache__", "build")) -> list[Path]:
    return [
        p for p in root.rglob("*")
        if p.is_file() and not any(part in skip_dirs or part.endswith(".egg-info") for part in p.parts)
    ]


class Stamps:
    """Remembers the input hash of each step that succeeded."""

    def __init__(self, venv: Path) -> None:
        self.directory = venv / ".rfidnav-stamps"

    def matches(self, step: str, value: str) -> bool:
        path = self.directory / step
        return path.is_file() and path.read_text() == value

    def has(self, step: str) -> bool:
        return (self.directory / step).is_file()

    def record(self, step: str, value: str) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        (self.directory / step).write_text(value)


def run_step(step: str, command: list[str], env: dict[str, str], log: Path, advice: str,
             cwd: Path | None = None) -> None:
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("a") as handle:
        handle.write(f"\n$ {' '.join(command)}\n")
        handle.flush()
        result = subprocess.run(command, env=env, cwd=cwd, stdout=handle, stderr=subprocess.STDOUT, check=False)
    if result.returncode != 0:
        tail = "\n".join(log.read_text(errors="replace").splitlines()[-15:])
        raise SetupStepFailed(f"set-up step '{step}' failed (exit {result.returncode}); {advice}\n"
                              f"last lines of {log}:\n{tail}")


def ensure_venv(workspace: Path, say) -> None:
    venv, python = venv_paths(workspace)
    if python.exists():
        return
    if sys.version_info[:2] != (3, 11):
        raise SetupStepFailed(f"set-up step 'venv' needs Python 3.11, this is {sys.version.split()[0]}; "
                              "run with python3.11 or set RFIDNAV_PYTHON")
    say("creating .venv (Python 3.11)")
    run_step("venv", [sys.executable, "-m", "venv", str(venv)], dict(os.environ), workspace / "build" / "setup.log",
             "check that the python3.11 venv module is installed (Debian: python3.11-venv)")


def ensure_requirements(workspace: Path, stamps: Stamps, env: dict[str, str], say) -> None:
    _, python = venv_paths(workspace)
    inputs = [workspace / "requirements.txt", workspace / "constraints.txt"]
    value = digest(inputs)
    if stamps.matches("requirements", value):
        return
    say("installing pinned requirements (ROS 2 Jazzy wheels, numpy, scipy, scikit-fuzzy, rosbags, mcap, ...)")
    log = workspace / "build" / "setup.log"
    advice = "check that PyPI is reachable and requirements.txt/constraints.txt pin versions that exist"
    run_step("requirements", [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                              "-r", str(inputs[0]), "-c", str(inputs[1])], env, log, advice)
    stamps.record("requirements", value)


def ensure_interfaces(workspace: Path, stamps: Stamps, env: dict[str, str], say) -> None:
    """Step (3): the vendored standard interfaces the wheels lack, then rfidnav_msgs."""
    venv, python = venv_paths(workspace)
    for name, source in VENDORED_INTERFACES:
        stamp = f"interfaces-{name}"
        if not stamps.has(stamp) and installed(python, env, name):
            continue                                   # the wheels (or a system) provide it: theirs is used
        build_interface_package(workspace, stamps, env, say, name, workspace / source, stamp)
    build_interface_package(workspace, stamps, env, say, INTERFACE_PACKAGE, workspace / INTERFACE_PACKAGE,
                            "interfaces")


def installed(python: Path, env: dict[str, str], package: str) -> bool:
    return subprocess.run([str(python), "-c", f"import {package}.msg"], env=env, capture_output=True,
                          check=False).returncode == 0


def build_interface_package(workspace: Path, stamps: Stamps, env: dict[str, str], say, name: str, source: Path,
                            stamp: str) -> None:
    """Configure, build and install one ament_cmake interface package into the venv, unless its files (and
    rfidnav_msgs/cmake, which every one includes) are unchanged since the last build."""
    venv, python = venv_paths(workspace)
    value = digest(list({*files_under(source), *files_under(workspace / INTERFACE_PACKAGE / "cmake")}))
    if stamps.matches(stamp, value):
        return
    say(f"building {name} with CMake (1-4 min)")
    build = workspace / "build" / name
    build.mkdir(parents=True, exist_ok=True)
    log = workspace / "build" / f"{name}.log"
    log.write_text("")
    advice = ("check that gcc/g++ and CMake are installed and that the .msg/.action files parse; "
              f"the full log is {log}")
    run_step(f"interfaces: {name}: cmake configure",
             ["cmake", str(source), f"-DCMAKE_INSTALL_PREFIX={venv}", f"-DPython3_EXECUTABLE={python}",
              "-DCMAKE_BUILD_TYPE=Release", "-DBUILD_TESTING=OFF"], env, log, advice, cwd=build)
    run_step(f"interfaces: {name}: build", ["cmake", "--build", ".", "--parallel", str(os.cpu_count() or 2)],
             env, log, advice, cwd=build)
    run_step(f"interfaces: {name}: install", ["cmake", "--install", "."], env, log, advice, cwd=build)
    stamps.record(stamp, value)


def ensure_packages(workspace: Path, stamps: Stamps, env: dict[str, str], say) -> None:
    _, python = venv_paths(workspace)
    manifests = [workspace / pkg / name for pkg in PYTHON_PACKAGES for name in ("setup.py", "setup.cfg", "package.xml")]
    value = digest([m for m in manifests if m.exists()])
    if stamps.matches("packages", value):
        return
    say("installing the rfidnav Python packages (editable)")
    command = [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps",
               "--no-build-isolation"]
    for pkg in PYTHON_PACKAGES:
        command += ["-e", str(workspace / pkg)]
    run_step("packages", command, env, workspace / "build" / "setup.log",
             "check each package's setup.py and package.xml")
    stamps.record("packages", value)


SHARED_FILES = {"rfidnav_scenario": ("config",)}    # beyond package.xml: what a package installs to share/


def link_shares(workspace: Path) -> None:
    """The ament index entries and share links of step (5); cheap, so redone on every set-up."""
    venv, _ = venv_paths(workspace)
    index = venv / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True, exist_ok=True)
    for pkg in PYTHON_PACKAGES:
        (index / pkg).touch()
        share = venv / "share" / pkg
        share.mkdir(parents=True, exist_ok=True)
        for name, source in [("package.xml", workspace / pkg / "package.xml"),
                             *((name, workspace / name) for name in SHARED_FILES.get(pkg, ()))]:
            link = share / name
            if link.is_symlink() and link.resolve() == source.resolve():
                continue
            if link.is_symlink() or link.is_file():
                link.unlink()
            link.symlink_to(source)


def set_up(workspace: Path, quiet: bool = False) -> None:
    def say(text: str) -> None:
        if not quiet:
            print(f"rfidnav setup: {text}", file=sys.stderr, flush=True)

    ensure_venv(workspace, say)
    venv, _ = venv_paths(workspace)
    env = build_environment(venv)
    stamps = Stamps(venv)
    ensure_requirements(workspace, stamps, env, say)
    ensure_interfaces(workspace, stamps, env, say)
    ensure_packages(workspace, stamps, env, say)
    link_shares(workspace)


SETUP_HELP = ("create or refresh .venv, install the pinned requirements, build the interface packages with CMake and "
              "install the rfidnav packages; each step is skipped while its inputs are unchanged")


def setup_parser() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(prog="rfidnav setup", description=SETUP_HELP,
                                   epilog="Every other verb runs the set-up first, so it is needed only to "
                                          "prepare a machine ahead of time.")


def main(argv: list[str] | None = None) -> int:
    """``environment.py WORKSPACE [VERB ARGS...]``: the set-up, before any verb. The verb's own arguments are the
    command line's, not this script's; ``setup`` has only ``--help`` (which prints and sets nothing up)."""
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print("usage: environment.py WORKSPACE [VERB [ARGS...]]", file=sys.stderr)
        return 2
    workspace, command_line = Path(argv[0]).resolve(), argv[1:]
    setting_up = command_line[:1] == ["setup"]
    if setting_up:
        setup_parser().parse_args(command_line[1:])   # --help exits 0 here; anything else is an error (exit 2)
    try:
        set_up(workspace)
    except SetupStepFailed as error:
        print(f"rfidnav: {error}", file=sys.stderr)
        return 1
    if setting_up:
        print(f"rfidnav setup: ready ({workspace / '.venv'}, Python {sysconfig.get_python_version()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
