"""The building_floor scenario (paper 004): a topological map as the robot's map, node goals checked against it,
and the new nodes' parameter files validated before anything starts."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_scenario.scenario import load_scenario
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")


def test_the_scenario_carries_a_topological_map_and_a_node_goal() -> None:
    scenario = load_scenario("building_floor")
    assert scenario.route_map is None and scenario.topological_map.name == "building_fig5"
    assert scenario.mission.goal == {"goal_node": "g"} and scenario.mission.server == "mission_executor"
    assert scenario.metrics == ("topological",)


@pytest.mark.parametrize("goal, words", [
    ({"goal_node": "z"}, ("goal_node: 'z' is not a node of", "nodes: c, a, b")),
    ({"tag_ids": ["23"]}, ("tag_ids: the map", "is not a route map")),
])
def test_a_goal_the_map_cannot_have_is_one_error_naming_the_field(goal: dict, words: tuple[str, ...]) -> None:
    with pytest.raises(ConfigError) as raised:
        load_scenario("building_floor", goal=goal)
    assert raised.value.field == "mission.goal"
    assert all(word in str(raised.value) for word in words), str(raised.value)


def test_a_node_goal_on_a_route_map_is_refused() -> None:
    with pytest.raises(ConfigError, match="goal_node: the map .* is not a topological map"):
        load_scenario("hallway", goal={"goal_node": "g"})


def test_bad_wall_follower_parameters_are_named_before_anything_starts(tmp_path: Path) -> None:
    params = tmp_path / "wall_follower.yaml"
    params.write_text((WORKSPACE / "config/params/wall_follower.yaml").read_text().replace(
        "sonar_offsets_m: [0.175, 0.1945, 0.1945, 0.175, 0.175]", "sonar_offsets_m: [0.175, 0.1945]"))
    with pytest.raises(ConfigError, match="sonar_topics and sonar_offsets_m: one each for front"):
        load_scenario("building_floor", param_files={"wall_follower": params})
