"""The house's structure, as the README's architecture section draws it: each package imports only packages below
it, the nodes' packages never the orchestration above them, and each package.xml names what its package imports
(and what its share of the tests imports) with rosdep keys that resolve; colcon test finds every test once."""

from __future__ import annotations

import ast
import functools
import importlib.metadata
import re
import sys
from pathlib import Path

import pytest
import yaml

from rfidnav_common.install import install_prefixes
from support.packages import (
    ROSDEP_FRAGMENT,
    TESTS,
    declared,
    environment,
    imported_modules,
    owner,
    packages,
    python_packages,
    rosdep_fragment,
    suite_modules,
    support_modules,
    used_packages,
)
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

# Bottom up; a package may import only packages on a lower level.
LEVELS: tuple[tuple[str, ...], ...] = (
    ("rfidnav_msgs",),
    ("rfidnav_common",),
    ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_drivers", "rfidnav_bag"),
    ("rfidnav_planning",),
    ("rfidnav_scenario",),
    ("rfidnav_bringup",),
    ("rfidnav_experiments",),
)
LEVEL = {package: level for level, packages in enumerate(LEVELS) for package in packages}
PYTHON_PACKAGES = [package for package in LEVEL if package != "rfidnav_msgs"]
NODE_PACKAGES = ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning", "rfidnav_drivers")


# rosdep keys of the Python libraries the packages and their tests import, by distribution. Those without "-pip" are
# rosdistro's (rosdep/python.yaml, checked at ros/rosdistro 000730dc); it has none for the "-pip" ones, which
# rosdep/rfidnav.yaml maps to pip.
PYTHON_KEYS = {
    "numpy": "python3-numpy", "scipy": "python3-scipy", "PyYAML": "python3-yaml", "networkx": "python3-networkx",
    "matplotlib": "python3-matplotlib", "psutil": "python3-psutil", "pyserial": "python3-serial",
    "ruamel.yaml": "python3-ruamel.yaml", "pytest": "python3-pytest", "hypothesis": "python3-hypothesis",
    "scikit-fuzzy": "python3-scikit-fuzzy-pip", "rosbags": "python3-rosbags-pip", "mcap": "python3-mcap-pip",
    "mcap-ros2-support": "python3-mcap-ros2-support-pip", "llrpkit": "python3-llrpkit-pip",
    # not confirmed in rosdistro here (no network to check): pip keys of our own, so they resolve anyway
    "foxglove-sdk": "python3-foxglove-sdk-pip", "rich": "python3-rich-pip", "websockets": "python3-websockets-pip",
    "distributed": "python3-distributed-pip",
}
TEST_TAGS_ALL = ("depend", "exec_depend", "test_depend")


def top_level_imports(trees: list[ast.AST]) -> set[str]:
    return {module.split(".")[0] for tree in trees for module in imported_modules(tree)}


@functools.cache
def package_imports(package: str) -> frozenset[str]:
    """The top-level names the modules of ``package`` import (anywhere in a module, lazy imports too)."""
    return frozenset(top_level_imports([ast.parse(path.read_text(), str(path))
                                        for path in (WORKSPACE / package / package).rglob("*.py")]))


@functools.cache
def imported_packages(package: str) -> frozenset[str]:
    """The other rfidnav packages the modules of ``package`` import."""
    return frozenset(name for name in package_imports(package) if name.startswith("rfidnav_")) - {package}


@functools.cache
def ros_packages() -> frozenset[str]:
    """The ROS packages on the ament index of the install prefixes (the ROS 2 wheels, a colcon install)."""
    return frozenset(path.name for prefix in install_prefixes()
                     for path in (prefix / "share" / "ament_index" / "resource_index" / "packages").glob("*")
                     if path.name not in packages())


def third_party(names: set[str] | frozenset[str]) -> tuple[set[str], set[str]]:
    """``names`` (top-level imports) as the ROS packages and the rosdep keys of the Python libraries they are; a
    library with no key in PYTHON_KEYS fails here, naming itself."""
    distributions = importlib.metadata.packages_distributions()
    ros, keys = set(), set()
    for name in names - set(sys.stdlib_module_names) - set(packages()):
        if name in ros_packages():
            ros.add(name)
            continue
        candidates = [distribution for distribution in distributions.get(name, []) if distribution in PYTHON_KEYS]
        assert candidates, f"'{name}' is imported but has no rosdep key: add its distribution to PYTHON_KEYS"
        keys.add(PYTHON_KEYS[candidates[0]])
    return ros, keys


@functools.cache
def owned_modules(package: str) -> tuple[Path, ...]:
    return tuple(path for path in suite_modules() if owner(path) == package)


def share_imports(package: str) -> set[str]:
    """What ``package``'s share of the tests imports: its modules, their support modules and conftest.py, but for
    the test folder's own modules."""
    trees: list[ast.AST] = [ast.parse((TESTS / "conftest.py").read_text())]
    for path in owned_modules(package):
        trees += [ast.parse(module.read_text()) for module in [path, *support_modules(ast.parse(path.read_text()))]]
    local = {"support", "conftest", *(path.stem for path in suite_modules())}
    return top_level_imports(trees) - local


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


def test_the_experiments_use_nothing_of_the_orchestration_but_its_public_run_api() -> None:
    trees = [ast.parse(path.read_text(), str(path))
             for path in (WORKSPACE / "rfidnav_experiments" / "rfidnav_experiments").rglob("*.py")]
    used = {module for tree in trees for module in imported_modules(tree) if module.split(".")[0] == "rfidnav_bringup"}
    assert used == {"rfidnav_bringup.api"}


def test_the_readme_draws_the_import_graph_the_code_has() -> None:
    assert readme_graph() == {package: imported_packages(package) for package in PYTHON_PACKAGES}


def test_each_package_xml_depends_on_the_rfidnav_packages_it_imports() -> None:
    for package in PYTHON_PACKAGES:
        missing = imported_packages(package) - declared(package)
        assert not missing, (package, missing)


def test_each_package_xml_depends_on_the_ros_packages_its_package_imports() -> None:
    missing = {package: ros - declared(package) for package in PYTHON_PACKAGES
               for ros in [third_party(package_imports(package))[0]] if ros - declared(package)}
    assert not missing


def test_each_package_xml_names_exactly_the_python_libraries_its_package_imports_by_their_rosdep_keys() -> None:
    known = set(PYTHON_KEYS.values())
    wrong = {package: {"missing": keys - declared(package), "not imported": (declared(package) & known) - keys}
             for package in PYTHON_PACKAGES for keys in [third_party(package_imports(package))[1]]
             if keys != declared(package) & known}
    assert not wrong


def test_each_package_xml_declares_what_its_share_of_the_tests_imports() -> None:
    missing = {package: needed - declared(package, TEST_TAGS_ALL) for package in python_packages()
               for needed in [set.union(*third_party(share_imports(package)))]
               if needed - declared(package, TEST_TAGS_ALL)}
    assert not missing


def test_every_dependency_a_package_xml_declares_resolves_with_rosdep() -> None:
    """A workspace package, a released ROS package (on the wheels' ament index), a key of rosdistro's or one of
    rosdep/rfidnav.yaml."""
    resolvable = set(packages()) | ros_packages() | set(PYTHON_KEYS.values()) | set(rosdep_fragment())
    tags = ("depend", "build_depend", "buildtool_depend", "exec_depend", "test_depend")
    unresolved = {(package, key) for package in packages() for key in declared(package, tags) - resolvable}
    assert not unresolved


def test_the_rosdep_fragment_maps_each_pip_key_to_the_library_requirements_txt_pins() -> None:
    pinned = {line.split("==")[0].strip().lower() for line in (WORKSPACE / "requirements.txt").read_text().splitlines()
              if "==" in line and not line.startswith("#")}
    own = {key: distribution for distribution, key in PYTHON_KEYS.items() if key.endswith("-pip")}
    assert rosdep_fragment() == {key: [distribution] for key, distribution in own.items()}
    assert {distribution.lower() for distribution in own.values()} <= pinned


def test_the_rosdep_fragment_is_valid_rosdep_yaml_for_debian_fedora_and_ubuntu() -> None:
    for key, platforms in yaml.safe_load(ROSDEP_FRAGMENT.read_text()).items():
        assert set(platforms) == {"debian", "fedora", "ubuntu"}, key
        assert all(set(rule) == {"pip"} and set(rule["pip"]) == {"packages"} for rule in platforms.values()), key


def test_every_test_module_belongs_to_one_python_package_whose_colcon_environment_holds_what_it_uses() -> None:
    for path in suite_modules():
        package = owner(path)
        assert package in python_packages() and used_packages(path) <= environment(package), path.name
    assert {owner(path) for path in suite_modules()} >= {"rfidnav_common", "rfidnav_bringup", "rfidnav_experiments"}


def test_each_python_package_links_its_test_folder_to_the_suite_and_asks_colcon_for_pytest() -> None:
    """colcon test runs pytest in the package's folder only if setup.py names pytest as a test dependency (else
    setup.py test: nothing); pytest finds the suite through the ``test`` link, conftest.py the package's share."""
    for package in python_packages():
        link = WORKSPACE / package / "test"
        assert link.is_symlink() and link.resolve() == TESTS, package
        setup = ast.parse((WORKSPACE / package / "setup.py").read_text())
        extras = [keyword.value for node in ast.walk(setup) if isinstance(node, ast.Call)
                  for keyword in node.keywords if keyword.arg == "extras_require"]
        assert extras and "pytest" in ast.literal_eval(extras[0]).get("test", []), package
