"""The workspace's ament packages as their manifests declare them, what a module imports, and the package each test
module belongs to under ``colcon test``.

``colcon test`` runs pytest in each package's folder, where ``test`` links to the workspace's test/; conftest.py
collects there only the modules :func:`owner` gives that package, so every test runs once across the packages and in
an environment that holds what it uses. A test module uses the rfidnav packages it imports, those its support
modules import, those it names in a string (``-m rfidnav_bringup.cli``, ``resolve_executable("rfidnav_sim", ...)``)
and those behind the conftest fixtures it takes (``domain`` leases a DDS domain with rfidnav_bringup). It belongs to
the lowest package whose colcon environment (itself and its exec dependencies, recursively) holds all of them.
"""

from __future__ import annotations

import ast
import functools
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import yaml

WORKSPACE = Path(__file__).resolve().parents[2]
TESTS = WORKSPACE / "test"
SUPPORT = "support"
RUNTIME_TAGS = ("depend", "exec_depend")
ROSDEP_FRAGMENT = WORKSPACE / "rosdep" / "rfidnav.yaml"


class OwnershipError(Exception):
    """A test module no package, or more than one lowest package, can run."""


@functools.cache
def packages() -> tuple[str, ...]:
    """The workspace's ament packages: the folders at its root holding a package.xml."""
    return tuple(sorted(path.parent.name for path in WORKSPACE.glob("*/package.xml")))


@functools.cache
def python_packages() -> tuple[str, ...]:
    """The ament_python packages: those ``colcon test`` runs pytest for."""
    return tuple(package for package in packages()
                 if ElementTree.parse(WORKSPACE / package / "package.xml").findtext("export/build_type")
                 == "ament_python")


@functools.cache
def declared(package: str, tags: tuple[str, ...] = RUNTIME_TAGS) -> frozenset[str]:
    """The dependencies ``package``'s package.xml declares under ``tags``."""
    manifest = ElementTree.parse(WORKSPACE / package / "package.xml").getroot()
    return frozenset((element.text or "").strip() for element in manifest if element.tag in tags)


@functools.cache
def environment(package: str) -> frozenset[str]:
    """The rfidnav packages a colcon install of ``package`` puts on its paths: itself and its exec dependencies
    among the workspace's packages, recursively."""
    found = {package}
    pending = [package]
    while pending:
        for dependency in declared(pending.pop()) & set(packages()):
            if dependency not in found:
                found.add(dependency)
                pending.append(dependency)
    return frozenset(found)


def _docstrings(tree: ast.Module) -> set[int]:
    nodes = [tree, *(node for node in ast.walk(tree)
                     if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef))]
    return {id(node.body[0].value) for node in nodes
            if node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}


def imported_modules(tree: ast.AST) -> set[str]:
    """Every absolute module name ``tree`` imports, at the top or lazily inside a function."""
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
    return found


@functools.cache
def _parsed(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


def support_modules(tree: ast.AST) -> list[Path]:
    """The support modules (test/support/NAME.py) ``tree`` imports, recursively."""
    found: list[Path] = []
    pending = [tree]
    while pending:
        for module in sorted(imported_modules(pending.pop())):
            parts = module.split(".")
            candidate = TESTS.joinpath(*parts).with_suffix(".py")
            if parts[0] == SUPPORT and len(parts) > 1 and candidate.is_file() and candidate not in found:
                found.append(candidate)
                pending.append(_parsed(candidate))
    return found


def _named_packages(tree: ast.Module) -> set[str]:
    """The rfidnav packages ``tree`` imports or names in a string that is not a docstring."""
    names = {module.split(".")[0] for module in imported_modules(tree)}
    skip = _docstrings(tree)
    pattern = re.compile(r"\b(" + "|".join(packages()) + r")\b")
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            names |= set(pattern.findall(node.value))
    return names & set(packages())


def _uses(tree: ast.Module) -> set[str]:
    """The rfidnav packages ``tree`` and the support modules it imports name."""
    uses = _named_packages(tree)
    for support in support_modules(tree):
        uses |= _named_packages(_parsed(support))
    return uses


def _arguments(function: ast.FunctionDef | ast.AsyncFunctionDef) -> set[str]:
    return {arg.arg for arg in (*function.args.posonlyargs, *function.args.args, *function.args.kwonlyargs)}


def _is_fixture(decorator: ast.expr) -> bool:
    target = decorator.func if isinstance(decorator, ast.Call) else decorator
    return isinstance(target, ast.Attribute) and target.attr == "fixture"


@functools.cache
def conftest_fixtures() -> dict[str, frozenset[str]]:
    """The rfidnav packages behind each fixture of test/conftest.py: those its body uses and those of the conftest
    fixtures it takes as arguments."""
    functions = {node.name: node for node in _parsed(TESTS / "conftest.py").body
                 if isinstance(node, ast.FunctionDef) and any(map(_is_fixture, node.decorator_list))}

    def closure(name: str, seen: frozenset[str]) -> frozenset[str]:
        uses = _uses(ast.Module(body=functions[name].body, type_ignores=[]))
        for argument in _arguments(functions[name]) & set(functions) - seen:
            uses |= closure(argument, seen | {name})
        return frozenset(uses)

    return {name: closure(name, frozenset()) for name in functions}


@functools.cache
def used_packages(path: Path) -> frozenset[str]:
    """The rfidnav packages the test module ``path`` uses (see the module's docstring)."""
    tree = _parsed(path)
    uses = _uses(tree)
    fixtures = conftest_fixtures()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for name in _arguments(node) & set(fixtures):
                uses |= fixtures[name]
    return frozenset(uses)


@functools.cache
def owner(path: Path) -> str:
    """The package whose ``colcon test`` runs the test module ``path``: the lowest one whose environment holds every
    rfidnav package the module uses."""
    uses = used_packages(path)
    candidates = {package for package in python_packages() if uses <= environment(package)}
    lowest = {package for package in candidates if not any(other != package and other in environment(package)
                                                           for other in candidates)}
    if len(lowest) != 1:
        problem = f"held alike by {', '.join(sorted(lowest))}" if lowest else "no package holds all of them"
        raise OwnershipError(f"{path.name}: uses {', '.join(sorted(uses)) or 'no rfidnav package'}; {problem}")
    return lowest.pop()


def suite_modules() -> list[Path]:
    """The workspace's test modules (test/test_*.py)."""
    return sorted(TESTS.glob("test_*.py"))


def rosdep_fragment() -> dict[str, list[str]]:
    """rosdep/rfidnav.yaml: each key's pip packages, which must be the same on every OS it lists."""
    result = {}
    for key, platforms in yaml.safe_load(ROSDEP_FRAGMENT.read_text()).items():
        installs = {tuple(rule["pip"]["packages"]) for rule in platforms.values()}
        assert len(installs) == 1, (key, installs)
        result[key] = list(installs.pop())
    return result
