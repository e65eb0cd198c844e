"""The README and docs/ stand on their own in a user's clone: every relative link resolves inside the repository
and nothing points at files outside it."""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

import pytest

pytestmark = pytest.mark.tier("unit")

WORKSPACE = Path(__file__).resolve().parents[1]
PAGES = [WORKSPACE / "README.md", *sorted((WORKSPACE / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_every_relative_link_of_a_page_resolves_inside_the_repository(page: Path) -> None:
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+://", target):
            continue
        resolved = (page.parent / target).resolve()
        assert resolved.exists(), f"{page.name}: {target} does not exist"
        assert resolved.is_relative_to(WORKSPACE), f"{page.name}: {target} is outside the repository"


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_a_page_names_no_file_outside_the_repository(page: Path) -> None:
    text = page.read_text()
    assert "../shared" not in text and "DESIGN.md" not in text


def test_the_readme_links_a_page_for_each_paper() -> None:
    readme = (WORKSPACE / "README.md").read_text()
    for paper in ("000", "001", "003", "004"):
        assert f"(docs/paper-{paper}.md)" in readme


ANCHORED_LINK = re.compile(r"\]\(([^)\s]*)#([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6} (.+)$", re.MULTILINE)


def heading_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation but '-' and '_' dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors_of(page: Path) -> set[str]:
    return {heading_anchor(heading) for heading in HEADING.findall(page.read_text())}


def test_a_heading_anchor_is_spelled_as_github_spells_it() -> None:
    assert heading_anchor("Reach, and the search for a tag the robot cannot hear") == \
        "reach-and-the-search-for-a-tag-the-robot-cannot-hear"
    assert heading_anchor("Node graph (scenario `partition_field`)") == "node-graph-scenario-partition_field"


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_every_link_into_a_section_names_a_heading_of_its_page(page: Path) -> None:
    for target, anchor in ANCHORED_LINK.findall(page.read_text()):
        if re.match(r"[a-z]+://", target):
            continue
        linked = (page.parent / target).resolve() if target else page
        assert anchor in anchors_of(linked), f"{page.name}: {target}#{anchor} names no heading of {linked.name}"


README_COMMAND = re.compile(r"^\./rfidnav ([^#\n`]+)", re.MULTILINE)
INLINE_COMMAND = re.compile(r"`\./rfidnav ([^`]+)`")
PLACEHOLDER = re.compile(r"\b[A-Z][A-Z_]+\b|[\[\]|]|\.\.\.")


def readme_commands() -> list[str]:
    readme = (WORKSPACE / "README.md").read_text()
    blocks = "\n".join(re.findall(r"```\n(.*?)```", readme, re.DOTALL))
    return [command.strip() for command in README_COMMAND.findall(blocks) + INLINE_COMMAND.findall(readme)]


def test_the_readme_shows_commands() -> None:
    assert len(readme_commands()) >= 5, readme_commands()


@pytest.mark.parametrize("command", readme_commands())
def test_each_command_the_readme_shows_is_one_the_cli_takes(command: str) -> None:
    """Its verb and sub-verb exist; a command without placeholders parses with the CLI's own parser, and a run
    names a shipped scenario."""
    from rfidnav_bringup.cli import parser
    top, _handlers = parser()
    words = shlex.split(command)
    verbs = next(action for action in top._actions if isinstance(action, argparse._SubParsersAction))
    assert words[0] in verbs.choices or words[0].startswith("-"), f"README: ./rfidnav {command}: no verb {words[0]}"
    if PLACEHOLDER.search(command):
        return
    try:
        arguments = top.parse_args(words)
    except SystemExit as exit_:
        if exit_.code == 0 and "--help" in words:
            return
        raise AssertionError(f"README: ./rfidnav {command} does not parse (exit {exit_.code})") from None
    if arguments.verb == "run":
        assert (WORKSPACE / "config" / "scenarios" / f"{arguments.scenario}.yaml").is_file(), command
