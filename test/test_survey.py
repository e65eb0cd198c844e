"""./rfidnav survey --grid: the whole free floor wherever the map's origin lies (the walls' bounding box or a declared
extent), only where a surveyor walking from the scenario's start gets to (the rest warned of), refused in one line
for a world with neither walls nor extent, and possible before the radio map it writes exists."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_bringup import cli
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_scenario.scenario import load_scenario
from rfidnav_sim.world import load_world
from support.config_files import copy_config

pytestmark = pytest.mark.tier("unit")

HOME = ("scenarios/two_tier_home.yaml", "worlds/two_tier_home.yaml", "maps/two_tier_home.yaml",
        "params/robot_sim.yaml", "params/reader_hf_floor.yaml", "params/wifi_sim.yaml", "params/compass_sim.yaml",
        "params/location_server.yaml", "params/two_tier_navigator.yaml")     # no radio map: not surveyed yet
SPACING = "0.7"


def home_copy(tmp_path: Path, shift: tuple[float, float] = (0.0, 0.0), **world_keys) -> Path:
    """A private two_tier_home whose world, map, start and goal are moved by ``shift`` (the map's origin moved by
    minus it), with ``world_keys`` replacing world keys (None deletes one): its scenario file."""
    root = copy_config(tmp_path, HOME)
    dx, dy = shift

    def moved(xy: list[float]) -> list[float]:
        return [xy[0] + dx, xy[1] + dy]

    def rewrite(relative: str, change) -> None:
        data = yaml.safe_load((root / relative).read_text())
        change(data)
        (root / relative).write_text(yaml.safe_dump(data))

    def world(data: dict) -> None:
        data["walls"] = [moved(wall[:2]) + moved(wall[2:]) for wall in data["walls"]]
        for entry in (*data["tag_groups"], *data["access_points"]):
            entry["centre" if "centre" in entry else "position"] = moved(entry.get("centre", entry.get("position")))
        for key, value in world_keys.items():
            data.pop(key) if value is None else data.__setitem__(key, value)

    def robot_map(data: dict) -> None:
        for group in data["tag_groups"]:
            group["centre"] = moved(group["centre"])

    def scenario(data: dict) -> None:
        data["robot"]["x"], data["robot"]["y"] = moved([data["robot"]["x"], data["robot"]["y"]])
        target = data["mission"]["goal"]["target"]
        target["x"], target["y"] = moved([target["x"], target["y"]])

    rewrite("worlds/two_tier_home.yaml", world)
    rewrite("maps/two_tier_home.yaml", robot_map)
    rewrite("scenarios/two_tier_home.yaml", scenario)
    return root / "scenarios/two_tier_home.yaml"


def survey(scenario: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[tuple[float, float]], str]:
    """``./rfidnav survey SCENARIO --grid SPACING --out OUT`` in this process: exit code, fingerprint positions,
    stderr."""
    code = cli.main(["survey", str(scenario), "--grid", SPACING, "--out", str(out)])
    err = capsys.readouterr().err
    return code, [f.position for f in load_radio_map(out)] if out.exists() else [], err


def test_a_home_with_its_origin_at_its_centre_is_surveyed_as_fully_as_with_its_origin_at_a_corner(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    corner_code, corner, _ = survey(home_copy(tmp_path / "corner"), tmp_path / "corner.yaml", capsys)
    centre_code, centre, _ = survey(home_copy(tmp_path / "centre", (-6.0, -4.0)), tmp_path / "centre.yaml", capsys)
    assert corner_code == centre_code == 0
    # 17 x 11 points on a 0.7 m grid over 12 x 8 m, less those within 20 cm of a wall (the x = 6 and y = 5 walls)
    assert len(corner) > 150
    assert len(centre) == len(corner)
    assert np.allclose(np.array(centre), np.array(corner) - (6.0, 4.0), atol=1e-9)
    assert min(x for x, _ in centre) < -5.0 and min(y for _, y in centre) < -3.0     # the quarter x, y < 0 too


def test_grid_points_the_surveyor_cannot_walk_to_are_warned_of_in_one_line_and_not_surveyed(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    original = load_world(Path(cli.__file__).parents[2] / "config/worlds/two_tier_home.yaml")
    closet = [[9.8, 0.4, 11.6, 0.4], [11.6, 0.4, 11.6, 2.3], [11.6, 2.3, 9.8, 2.3], [9.8, 2.3, 9.8, 0.4]]
    scenario = home_copy(tmp_path, walls=[list(wall) for wall in original.walls] + closet)
    code, positions, err = survey(scenario, tmp_path / "radio.yaml", capsys)
    assert code == 0
    inside = [(x, y) for x in (10.15, 10.85) for y in (1.05, 1.75)]     # the 0.7 m grid's points in the closet
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1, err
    assert warnings[0].startswith("rfidnav survey: warning: 4 grid points clear of the walls cannot be reached "
                                  "from (1, 1)"), warnings[0]
    assert all(f"({x:g}, {y:g})" in warnings[0] for x, y in inside), warnings[0]
    assert not any(9.8 < x < 11.6 and 0.4 < y < 2.3 for x, y in positions)
    assert len(positions) > 150


def test_a_world_without_walls_or_extent_is_refused_in_one_line_naming_it_and_surveyed_over_a_declared_extent(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scenario = home_copy(tmp_path / "open", walls=None)
    code, positions, err = survey(scenario, tmp_path / "open.yaml", capsys)
    world = (scenario.parents[1] / "worlds/two_tier_home.yaml").resolve()
    assert code == 2 and not positions
    assert err.strip() == (f"rfidnav survey: {world}: walls: a grid survey covers the floor within the walls or the "
                           "extent: this world has neither (add extent: [x_min, y_min, x_max, y_max])")
    declared = home_copy(tmp_path / "declared", walls=None, extent=[-1.0, -1.0, 6.0, 4.0])
    code, positions, _ = survey(declared, tmp_path / "declared.yaml", capsys)
    assert code == 0 and len(positions) == 10 * 7                     # nothing in the way: every point of the grid
    assert min(positions) == pytest.approx((-0.65, -0.65)) and max(positions) == pytest.approx((5.65, 3.55))


def test_the_first_survey_runs_before_the_radio_map_it_writes_exists(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    scenario = home_copy(tmp_path)
    radio_map = scenario.parents[1] / "maps/two_tier_home_radio_map.yaml"
    assert "radio_map: two_tier_home_radio_map.yaml" in (scenario.parents[1] / "maps/two_tier_home.yaml").read_text()
    assert not radio_map.exists()
    with pytest.raises(Exception, match="radio_map: no such file"):    # a run still needs it
        load_scenario(str(scenario))
    code, positions, err = survey(scenario, radio_map, capsys)
    assert code == 0 and positions, err
    assert load_scenario(str(scenario)).route_map.radio_map_file == radio_map.resolve()
