"""reproduce two_tier: the navigations as engine tasks: Fig. 11's direct and indirect moving, Fig. 12's routes
leg by leg, each home's scenario with straight and planned legs; and tier one's error at random points of a radio
map."""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.two_tier.conditions import (
    FIG11_SPACINGS_M,
    GRID_SCANS_PER_POINT,
    GRID_SPACING_M,
    HOMES,
    LEGS,
    LONG_ROUTE,
    MAP_FILE,
    ROUTES,
    TEST_POINTS,
    WORLD_FILE,
)
from rfidnav_experiments.runners.two_tier import (
    LOCATE_SETTINGS,
    SETTINGS,
    Site,
    floor_extent,
    grid_radio_map,
    run_two_tier,
    survey_grid,
)
from rfidnav_localization.fingerprint import RadioMap
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_planning.wall_paths import WallMap
from rfidnav_scenario.scenario import Scenario, load_scenario
from rfidnav_sim.world import load_world


@functools.cache
def grid_site(seed: int) -> Site:
    """The flat with the grid survey's radio map, built once per process (the pool's workers too)."""
    world = load_world(WORLD_FILE)
    grid = survey_grid(world, GRID_SPACING_M, ROUTES["route 1"][0][:2])
    return Site.of(world, grid_radio_map(world, grid.points, rng_for(seed, "grid survey"), GRID_SCANS_PER_POINT))


@dataclass(frozen=True)
class Leg:
    """One navigation to a turning point of Fig. 12."""
    route: str
    run: int
    point: str
    fingerprint_m: float                  # tier one alone at the turning point
    fix_m: float | None                   # ours: the last tag fix on arriving (None: the leg failed)
    tag_position_m: float | None          # the same poll taken the paper's way
    all_fixes_m: tuple[float, ...]        # every tag fix of the leg, ours
    all_tag_positions_m: tuple[float, ...]
    wall_crossings: int                   # of the leg's true track (a leg that crossed a wall did not arrive)


@functools.cache
def floor_plan() -> WallMap:
    """The flat's walls and extent as the robot's map gives them (its legs are planned round the walls)."""
    return WallMap.of(load_route_map(MAP_FILE))


def fig12_route(job: tuple[str, int, int]) -> list[Leg]:
    """One run of a route, leg by leg (one navigation per turning point, as in the paper)."""
    name, run, seed = job
    site = grid_site(seed)
    landmarks = {group.group_id: group for group in load_route_map(MAP_FILE).tag_groups}
    start, points = ROUTES[name]
    rng = rng_for(seed, f"fig12:{name}:{run}")
    pose = start
    legs = []
    for point in points:
        centre = landmarks[point].centre
        scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*centre, rng)}
        fingerprint = math.dist(site.radio_map.locate(scan, LOCATE_SETTINGS).position, centre)
        result = run_two_tier(site, pose, centre, SETTINGS, rng, derive_seed(seed, f"fig12:{name}:{run}:{point}"),
                              floor=floor_plan())
        arrived = result.success and bool(result.fix_errors_m)
        legs.append(Leg(name, run, point, fingerprint, result.fix_errors_m[-1] if arrived else None,
                        result.tag_position_errors_m[-1] if arrived else None, result.fix_errors_m,
                        result.tag_position_errors_m, result.wall_crossings))
        heading = math.atan2(centre[1] - pose[1], centre[0] - pose[0])
        pose = (result.final_position[0], result.final_position[1], heading)
    return legs


def fig12(runs: int, seed: int) -> list[Leg]:
    results = run_tasks(fig12_route, [(name, run, seed) for name in ROUTES for run in range(runs)],
                       "reproduce two_tier: Fig. 12")
    return sorted((leg for legs in results for leg in legs), key=lambda leg: (leg.route, leg.run))


def fig11_run(job: tuple[str, int, int]) -> tuple[str, int, float | None, int]:
    """Direct or indirect moving along LONG_ROUTE: the final position error [m], None if the run failed, and its
    wall crossings. Both kinds of run ``run`` draw the same compass, WiFi and reader streams."""
    kind, run, seed = job
    start, target = LONG_ROUTE
    settings = dataclasses.replace(SETTINGS, landmark_spacing_m=FIG11_SPACINGS_M[kind], calibration_distance_m=1000.0)
    result = run_two_tier(grid_site(seed), start, target, settings, rng_for(seed, f"fig11:{run}"),
                          derive_seed(seed, f"fig11:{run}:reader"), floor=floor_plan())
    return kind, run, result.final_error_m if result.success else None, result.wall_crossings


def fig11(runs: int, seed: int) -> tuple[dict[str, dict[int, float | None]], int]:
    """Per kind of moving, each run's final error (None: it failed); and the runs' wall crossings in all."""
    results = run_tasks(fig11_run, [(kind, run, seed) for run in range(runs) for kind in FIG11_SPACINGS_M],
                       "reproduce two_tier: Fig. 11")
    errors: dict[str, dict[int, float | None]] = {kind: {} for kind in FIG11_SPACINGS_M}
    for kind, run, error, _ in sorted(results, key=lambda result: result[1]):
        errors[kind][run] = error
    return errors, sum(result[3] for result in results)


@dataclass(frozen=True)
class Home:
    scenario: Scenario
    floor: WallMap                        # its map's walls and extent
    site: Site                            # its world with the radio map its map names (the location server's)


@functools.cache
def home(name: str) -> Home:
    scenario = load_scenario(name)
    robot_map = scenario.route_map
    if robot_map is None or robot_map.radio_map_file is None:
        raise ConfigError(str(scenario.map_file), "radio_map", "a two-tier home's map names its radio map")
    site = Site.of(scenario.world, RadioMap(load_radio_map(robot_map.radio_map_file)))
    return Home(scenario, WallMap.of(robot_map), site)


@dataclass(frozen=True)
class HomeRun:
    home: str
    legs: str                             # a key of LEGS
    run: int
    success: bool
    final_error_m: float
    path_length_m: float
    bumps: int
    wall_crossings: int


def home_run(job: tuple[str, str, int, int]) -> HomeRun:
    """One navigation of a home's scenario, from its start to its goal within its timeout; both kinds of legs of
    run ``run`` draw the same compass, WiFi and reader streams."""
    name, legs, run, seed = job
    place = home(name)
    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    result = run_two_tier(place.site, (x, y, math.radians(yaw_deg)), (target["x"], target["y"]), SETTINGS,
                          rng_for(seed, f"homes:{name}:{run}"), derive_seed(seed, f"homes:{name}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s,
                          floor=place.floor if legs == "planned" else WallMap())
    return HomeRun(name, legs, run, result.success, result.final_error_m, result.path_length_m, result.bumps,
                   result.wall_crossings)


def homes(runs: int, seed: int) -> list[HomeRun]:
    results = run_tasks(home_run, [(name, legs, run, seed) for name in HOMES for legs in LEGS for run in range(runs)],
                       "reproduce two_tier: homes")
    return sorted(results, key=lambda result: (HOMES.index(result.home), list(LEGS).index(result.legs), result.run))


def tier_one_errors(site: Site, radio_map: RadioMap, seed: int) -> list[float]:
    rng = rng_for(seed, "test points")
    x_min, y_min, x_max, y_max = floor_extent(site.world)
    errors = []
    for _ in range(TEST_POINTS):
        point = (float(rng.uniform(x_min + 0.2, x_max - 0.2)), float(rng.uniform(y_min + 0.2, y_max - 0.2)))
        scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*point, rng)}
        errors.append(math.dist(radio_map.locate(scan, LOCATE_SETTINGS).position, point))
    return errors
