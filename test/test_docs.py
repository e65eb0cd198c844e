"""The README and docs/ stand on their own in a user's clone: every relative link resolves inside the repository
and nothing points at files outside it."""

from __future__ import annotations

import re
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
