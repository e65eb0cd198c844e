"""A robot map's surveyed ceiling_tags, floor_tags and wall_tags (rfidnav_common.robot_map): read as declared, and
every bad entry one ConfigError naming the file and the field; the shipped surveys agree with their worlds."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import load_route_map

pytestmark = pytest.mark.tier("unit")

GOOD = """
name: surveyed
extent: [0.0, 0.0, 10.0, 4.0]
ceiling_tags:
  C1: [1.0, 2.0, 3.0]
floor_tags:
  F1: [1.0, 2.5]
wall_tags:
  - {id: 8, position: [3.0, 4.0], normal: [0.0, -2.0]}
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def test_surveyed_ceiling_floor_and_wall_tags_are_read_with_numeric_ids_as_strings_and_normals_made_unit(
        tmp_path: Path) -> None:
    route_map = load_route_map(write(tmp_path, GOOD))
    assert route_map.ceiling_tags == {"C1": (1.0, 2.0, 3.0)} and route_map.floor_tags == {"F1": (1.0, 2.5)}
    (tag,) = route_map.wall_tags
    assert (tag.tag_id, tag.position, tag.normal) == ("8", (3.0, 4.0), (0.0, -1.0))


@pytest.mark.parametrize(("old", "new", "field", "words"), [
    ("C1: [1.0, 2.0, 3.0]", "C1: [1.0, 2.0]", "ceiling_tags.C1", "expected 3 numbers"),
    ("C1: [1.0, 2.0, 3.0]", "C1: [1.0, .nan, 3.0]", "ceiling_tags.C1[1]", "finite"),
    ("F1: [1.0, 2.5]", "F1: [1.0, 2.5, 0.0]", "floor_tags.F1", "expected 2 numbers"),
    ("F1: [1.0, 2.5]", "3: [1.0, 2.5]", "floor_tags.3", "tag ids must be strings"),
    ("normal: [0.0, -2.0]", "normal: [0.0, 0.0]", "wall_tags[0].normal", "must not be zero"),
    ("{id: 8, position: [3.0, 4.0], normal: [0.0, -2.0]}",
     "{id: 8, position: [3.0, 4.0], normal: [0.0, -2.0]}\n  - {id: '8', position: [5.0, 4.0], normal: [0.0, -1.0]}",
     "wall_tags[1].id", "duplicate tag id '8'"),
    ("position: [3.0, 4.0]", "position: [3.0, 4.0], height: 1.0", "wall_tags[0]", "height"),
])
def test_a_bad_surveyed_tag_is_one_error_naming_the_file_and_the_field(tmp_path: Path, old: str, new: str,
                                                                       field: str, words: str) -> None:
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(ConfigError) as raised:
        load_route_map(path)
    assert str(path) in str(raised.value) and field in str(raised.value) and words in str(raised.value)


@pytest.mark.parametrize(("scenario", "role"), [("hallway", None), ("building_ring", "rfid_localizer")])
def test_each_shipped_tag_survey_places_every_tag_where_its_world_has_it(scenario: str, role: str | None) -> None:
    from rfidnav_common.robot_map import bounding_box
    from rfidnav_scenario.scenario import load_scenario

    loaded = load_scenario(scenario)
    survey_file = loaded.map_file if role is None else loaded.nodes[role].map_file
    assert survey_file is not None
    survey, world = load_route_map(survey_file), loaded.world
    assert survey.ceiling_tags == {tag.tag_id: tag.position for tag in world.tags if tag.kind == "ceiling"}
    assert survey.floor_tags == {tag.tag_id: tag.position[:2] for tag in world.tags if tag.kind == "floor"}
    assert {(t.tag_id, t.position, t.normal) for t in survey.wall_tags} == {
        (t.tag_id, t.position, t.normal) for t in world.wall_tags}
    assert survey.extent == bounding_box(world.walls)
