"""Paper 003's navigator and the home's walls (issue 18): legs planned round the robot map's walls, spiral searches
kept inside its extent, targets outside it refused, and wheels stalled at an unexpected wall noticed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.tag_groups import TagGroup
from rfidnav_experiments.reproduce.two_tier import DEVELOPMENT_SEED, home_run
from rfidnav_experiments.runners.two_tier import SETTINGS, Site, run_two_tier
from rfidnav_localization.dead_reckoning import TIER_TAG, Fix
from rfidnav_localization.fingerprint import RadioMap
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_planning.two_tier_navigation import (
    BACKING_OFF,
    LOCATE,
    SEARCHING,
    TAG_MAP,
    MapTag,
    TwoTierNavigator,
    TwoTierSettings,
)
from rfidnav_planning.wall_paths import WallMap, WallPlanner, segment_distances
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from rfidnav_sim.kinematics import unicycle_step
from rfidnav_sim.world import load_world

pytestmark = pytest.mark.tier("unit")

HOME_MAP = CONFIG_DIR / "maps" / "two_tier_home.yaml"
HOME = WallMap.of(load_route_map(HOME_MAP))
CORRIDOR_MAP = CONFIG_DIR / "maps" / "two_tier_corridor.yaml"
CLEARANCE_M = 0.3


def crosses_a_wall(points: list[tuple[float, float]], walls: np.ndarray, clearance_m: float) -> bool:
    return any(np.any(segment_distances(np.array(a), np.array(b), walls) < clearance_m - 1e-9)
               for a, b in zip(points, points[1:]))


def test_the_home_map_carries_the_worlds_walls_and_its_extent() -> None:
    world = load_world(CONFIG_DIR / "worlds" / "two_tier_home.yaml")
    assert sorted(HOME.walls) == sorted(world.walls)
    assert HOME.extent == (0.0, 0.0, 12.0, 8.0)


def test_the_corridor_flat_of_ours_has_its_origin_at_its_centre_and_its_map_carries_the_worlds_walls() -> None:
    world = load_world(CONFIG_DIR / "worlds" / "two_tier_corridor.yaml")
    corridor = load_route_map(CORRIDOR_MAP)
    assert sorted(corridor.walls) == sorted(world.walls)
    assert corridor.extent == (-8.0, -3.5, 8.0, 3.5)
    assert {group.group_id: group.centre for group in corridor.tag_groups} == \
        {group.group_id: group.centre for group in world.tag_groups}


def test_a_leg_down_the_corridor_flat_keeps_to_its_corridor_and_goes_through_both_doors() -> None:
    # From the south-west room S1 to the north-east room N3: out of S1's door (x -3.5..-2.5 in y = -0.6), along the
    # 1.2 m corridor and into N3's door (x 5.5..6.5 in y = 0.6), 30 cm from every wall and jamb.
    planner = WallPlanner(WallMap.of(load_route_map(CORRIDOR_MAP)), CLEARANCE_M)
    start, goal = (-5.5, -2.2), (6.8, 2.5)
    waypoints = planner.path(start, goal)
    assert waypoints is not None and waypoints[-1] == goal
    points = [start, *waypoints]
    assert not crosses_a_wall(points, planner.walls, CLEARANCE_M)

    def crossing_x(wall_y: float) -> float:
        (a, b), = [(a, b) for a, b in zip(points, points[1:]) if (a[1] - wall_y) * (b[1] - wall_y) < 0.0]
        return a[0] + (b[0] - a[0]) * (wall_y - a[1]) / (b[1] - a[1])

    assert -3.5 + CLEARANCE_M - 1e-6 <= crossing_x(-0.6) <= -2.5 - CLEARANCE_M + 1e-6
    assert 5.5 + CLEARANCE_M - 1e-6 <= crossing_x(0.6) <= 6.5 - CLEARANCE_M + 1e-6
    assert all(-0.6 + CLEARANCE_M - 1e-6 <= y <= 0.6 - CLEARANCE_M + 1e-6 for x, y in waypoints if -2.0 < x < 5.0)


def test_a_target_outside_the_corridor_flats_extent_is_refused_when_the_scenario_loads_naming_the_goal() -> None:
    west = {"target": {"x": -9.0, "y": 0.0, "z": 0.0}, "tolerance_m": 0.0}
    with pytest.raises(ConfigError) as refused:
        load_scenario("two_tier_corridor", goal=west)
    assert refused.value.field == "mission.goal"
    assert "target (-9.0, 0.0) is outside the map's extent [-8.0, -3.5, 8.0, 3.5]" in refused.value.problem
    inside = {"target": {"x": -7.5, "y": -3.0, "z": 0.0}, "tolerance_m": 0.0}
    assert load_scenario("two_tier_corridor", goal=inside).mission.goal == inside


def test_a_map_without_a_declared_extent_takes_its_walls_bounding_box(tmp_path) -> None:
    path = tmp_path / "map.yaml"
    path.write_text("name: m\ntag_groups: [{id: G, shape: cross, centre: [0.0, 0.0]}]\n"
                    "walls: [[-3.0, -2.0, 3.0, -2.0], [3.0, -2.0, 3.0, 4.0]]\n")
    assert load_route_map(path).extent == (-3.0, -2.0, 3.0, 4.0)


def test_a_leg_from_the_west_rooms_to_the_east_goes_through_the_door_and_keeps_its_clearance() -> None:
    planner = WallPlanner(HOME, CLEARANCE_M)
    start, goal = (3.0, 1.5), (9.0, 3.6)
    assert not planner.segment_clear(start, goal)                 # straight through the x = 6 wall
    waypoints = planner.path(start, goal)
    assert waypoints is not None and waypoints[-1] == goal
    points = [start, *waypoints]
    assert not crosses_a_wall(points, planner.walls, CLEARANCE_M)
    at_the_wall = [(a, b) for a, b in zip(points, points[1:]) if (a[0] - 6.0) * (b[0] - 6.0) <= 0.0]
    (a, b), = at_the_wall
    y = a[1] + (b[1] - a[1]) * (6.0 - a[0]) / (b[0] - a[0])
    assert 3.0 + CLEARANCE_M - 1e-6 <= y <= 4.2 - CLEARANCE_M + 1e-6      # in the door, clear of both jambs
    assert math.dist(start, goal) < planner.length(start, goal) < 1.2 * math.dist(start, goal)


def test_a_room_whose_door_is_walled_up_has_no_way_in() -> None:
    closed = WallMap(HOME.walls + ((6.0, 3.0, 6.0, 4.2),), HOME.extent)
    assert WallPlanner(closed, CLEARANCE_M).path((3.0, 1.5), (9.0, 3.6)) is None


def test_a_robot_that_believes_it_is_against_a_wall_can_still_leave_it() -> None:
    planner = WallPlanner(HOME, CLEARANCE_M)
    waypoints = planner.path((5.9, 1.0), (3.0, 1.5))           # 10 cm from the x = 6 wall
    assert waypoints == [(3.0, 1.5)]
    assert planner.path((12.05, 1.0), (9.0, 1.5)) is not None   # dead reckoning 5 cm outside the flat


def test_a_target_outside_the_maps_extent_is_refused_by_the_core() -> None:
    navigator = TwoTierNavigator(SETTINGS, HOME)
    assert "outside the map's extent" in navigator.refusal((16.0, 4.0))
    assert navigator.refusal((10.8, 6.8)) is None
    with pytest.raises(ValueError, match="outside the map's extent"):
        navigator.start((16.0, 4.0))
    assert TwoTierNavigator(SETTINGS).refusal((16.0, 4.0)) is None   # no floor plan: nothing to refuse against


def group_tags(group: TagGroup) -> list[MapTag]:
    return [MapTag(tag_id, position, group.group_id, group.shape) for tag_id, position in group.tags()]


def drive(navigator: TwoTierNavigator, decision, pose, odom, steps: int, step_s: float = 0.05):
    """Step the core with exact odometry and compass; every decision with the true pose it was taken at."""
    trace = []
    for _ in range(steps):
        if decision.finished or decision.request is not None:
            break
        linear, angular = decision.command
        dx, dy, dyaw = unicycle_step(pose[2], linear, angular, step_s)
        pose = (pose[0] + dx, pose[1] + dy, pose[2] + dyaw)
        dx, dy, dyaw = unicycle_step(odom[2], linear, angular, step_s)
        odom = (odom[0] + dx, odom[1] + dy, odom[2] + dyaw)
        decision = navigator.step(odom, pose[2], [])
        trace.append((decision, pose))
    return decision, pose, odom, trace


def test_a_spiral_search_ends_before_it_leaves_the_maps_extent() -> None:
    # A landmark 1 m from two edges of an empty 12 x 8 m extent, a start fix so vague (30 cm) that the spiral would
    # reach out 1 m: it ends, unfound, when the estimate comes within 20 cm of an edge, and tier one is asked.
    settings = TwoTierSettings(go_to=SETTINGS.go_to)
    navigator = TwoTierNavigator(settings, WallMap((), (0.0, 0.0, 12.0, 8.0)))
    decision = navigator.start((1.0, 1.0), Fix((2.0, 2.0), 0.3, TIER_TAG, "dock"))
    assert decision.request is not None and decision.request.kind == TAG_MAP
    group = TagGroup("G", "cross", (1.0, 1.0), 0.3, 0.0, 0.05)
    navigator.on_tag_map(group_tags(group))      # no tag will be read: the landmark is not where the robot looks
    pose = odom = (2.0, 2.0, 0.0)
    navigator.step(odom, pose[2], [])
    decision = navigator.drive()
    decision, pose, odom, trace = drive(navigator, decision, pose, odom, 20_000)
    assert any(step.phase == SEARCHING for step, _ in trace)
    assert decision.request is not None and decision.request.kind == LOCATE
    assert navigator.progress.cut_searches == 1 and navigator.progress.failed_searches == 1
    assert min(min(x, y) for _, (x, y, _) in trace) >= settings.search_wall_clearance_m - 0.02


def test_wheels_stalled_at_a_wall_back_the_robot_off_and_ask_tier_one_then_give_up_after_the_last_stall() -> None:
    settings = TwoTierSettings(go_to=SETTINGS.go_to, max_stalls=2)
    navigator = TwoTierNavigator(settings)
    navigator.start((5.0, 0.0), Fix((0.0, 0.0), 0.02, TIER_TAG, "dock"))
    navigator.on_tag_map(group_tags(TagGroup("G", "cross", (5.0, 0.0), 0.3, 0.0, 0.05)))
    odom = (0.0, 0.0, 0.0)
    navigator.step(odom, 0.0, [])
    decision = navigator.drive()
    assert decision.command[0] > 0.0
    for _ in range(settings.stall_steps):                   # commanded forward, the odometry stands: a stall
        decision = navigator.step(odom, 0.0, [])
    assert decision.phase == BACKING_OFF and decision.command[0] < 0.0
    backed = 0.0
    while decision.request is None:
        backed += -decision.command[0] * 0.05
        odom = (odom[0] + decision.command[0] * 0.05, 0.0, 0.0)
        decision = navigator.step(odom, 0.0, [])
    assert decision.request.kind == LOCATE and backed == pytest.approx(settings.back_off_m, abs=0.01)
    decision = navigator.on_located((0.0, 0.0), 1.0)        # tier one: back where it started
    for _ in range(settings.stall_steps + 20):
        if decision.finished:
            break
        decision = navigator.step(odom, 0.0, [])
    assert decision.finished and not decision.success
    assert "stalled at a wall 2 times" in decision.message


def shipped_site(name: str) -> Site:
    """The world of ``name`` with the radio map its robot map names (as the location server starts)."""
    robot_map = load_route_map(CONFIG_DIR / "maps" / f"{name}.yaml")
    world = load_world(CONFIG_DIR / "worlds" / f"{name}.yaml")
    return Site.of(world, RadioMap(load_radio_map(robot_map.radio_map_file)))


@pytest.mark.tier("slow")
def test_legs_planned_round_the_homes_walls_arrive_more_often_than_straight_ones_on_the_same_streams() -> None:
    # Route 1 of Fig. 12 (T1 -> T2 -> T3 -> T4 -> T5 from the south-west corner), four runs, both ways on the same
    # seeds. A leg that stalls backs off either way; the floor plan keeps the legs out of the walls.
    landmarks = {group.group_id: group.centre for group in load_route_map(HOME_MAP).tag_groups}
    site = shipped_site("two_tier_home")
    arrived = {}
    for name, floor in (("straight", WallMap()), ("planned", HOME)):
        arrived[name] = 0
        for run in range(4):
            rng, pose = np.random.default_rng(100 + run), (1.0, 1.0, 0.3)
            for index, point in enumerate(("T1", "T2", "T3", "T4", "T5")):
                result = run_two_tier(site, pose, landmarks[point], SETTINGS, rng, 1000 * run + index, floor=floor,
                                      max_time_s=600.0)
                arrived[name] += result.success
                pose = (*result.final_position, 0.0)
    assert arrived["planned"] >= 17, arrived             # of 20 legs
    assert arrived["planned"] >= arrived["straight"]



@pytest.mark.tier("slow")
@pytest.mark.parametrize("home", ["two_tier_home", "two_tier_flat", "two_tier_corridor"])
def test_each_homes_scenario_run_in_process_with_planned_legs_arrives_crosses_no_wall_and_some_runs_bump_none(
        home: str) -> None:
    # The scenario's start, goal and shipped radio map in-process (reproduce two_tier's homes), eight runs on the
    # development seed; the walls stop the base. A WiFi fix metres off can still put a spiral against a wall (a
    # bump, backed off from; a run whose tier one keeps it there gives up, 1 in 5 on two_tier_home and
    # two_tier_flat at the evaluation seed); a crossing is never allowed.
    runs = [home_run((home, "planned", run, DEVELOPMENT_SEED)) for run in range(8)]
    assert sum(run.success and run.final_error_m < 0.1 for run in runs) >= 5, runs
    assert all(run.wall_crossings == 0 for run in runs), runs
    assert any(run.bumps == 0 for run in runs), runs
