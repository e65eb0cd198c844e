"""The house's structure, as the README's architecture section draws it: each package imports only packages below
it, the nodes' packages never the orchestration above them, and each package.xml names what its package imports."""

from __future__ import annotations

import ast
import functools
import re
import xml.etree.ElementTree as ElementTree

import pytest

from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

# Bottom up; a package may import only packages on a lower level.
LEVELS: tuple[tuple[str, ...], ...] = (
    ("rfidnav_msgs",),
    ("rfidnav_common",),
    ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_drivers", "rfidnav_bag"),
    ("rfidnav_planning",),
    ("rfidnav_bringup",),
    ("rfidnav_experiments",),
)
LEVEL = {package: level for level, packages in enumerate(LEVELS) for package in packages}
PYTHON_PACKAGES = [package for package in LEVEL if package != "rfidnav_msgs"]
NODE_PACKAGES = ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning", "rfidnav_drivers")


@functools.cache
def imported_packages(package: str) -> frozenset[str]:
    """The other rfidnav packages the modules of ``package`` import (anywhere in a module, lazy imports too)."""
    found: set[str] = set()
    for path in (WORKSPACE / package / package).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            found |= {name.split(".")[0] for name in names if name.startswith("rfidnav_")}
    return frozenset(found - {package})


def readme_graph() -> dict[str, set[str]]:
    """The block between the architecture markers of README.md: ``package -> a, b`` per line."""
    text = (WORKSPACE / "README.md").read_text()
    block = re.search(r"<!-- import graph -->\n```\n(.*?)```", text, re.S)
    assert block, "README.md has no import graph block"
    graph = {}
    for line in block.group(1).splitlines():
        package, _, imports = line.partition("->")
        graph[package.strip()] = {name.strip() for name in imports.split(",") if name.strip() not in ("", "-")}
    return graph


def test_no_package_imports_one_on_its_level_or_above() -> None:
    upward = {(package, other) for package in PYTHON_PACKAGES for other in imported_packages(package)
              if LEVEL[other] >= LEVEL[package]}
    assert not upward


def test_the_nodes_packages_never_import_the_bags_the_orchestration_or_the_experiments() -> None:
    for package in NODE_PACKAGES:
        assert not imported_packages(package) & {"rfidnav_bag", "rfidnav_bringup", "rfidnav_experiments"}, package


def test_the_readme_draws_the_import_graph_the_code_has() -> None:
    assert readme_graph() == {package: imported_packages(package) for package in PYTHON_PACKAGES}


def test_each_package_xml_depends_on_the_rfidnav_packages_it_imports() -> None:
    for package in PYTHON_PACKAGES:
        manifest = ElementTree.parse(WORKSPACE / package / "package.xml").getroot()
        declared = {element.text for element in manifest if element.tag in ("depend", "exec_depend")}
        assert imported_packages(package) <= declared, (package, imported_packages(package) - declared)
