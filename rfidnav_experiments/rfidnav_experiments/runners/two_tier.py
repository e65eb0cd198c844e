"""In-process two-tier navigation (paper 003): the navigator core of the DDS node driving an idealised robot through a
simulated flat, for the paper's statistics.

The robot is a unicycle stepped at the navigator's control rate with the commanded velocities (no motor dynamics),
as round as robot_sim's base: a step into one of the flat's walls is not made (and not counted by the odometry), as
robot_sim stalls its base there; ``TwoTierRun.bumps`` counts those steps. The navigator is the two_tier_navigator
node's, with its shipped parameters (config/params/two_tier_navigator.yaml). What it sees is simulated as the nodes
simulate it: wheel odometry whose distance is off by ``odometry_scale_error`` (paper 003: about 1 m per 20 m with a
load), the e-compass of compass_sim.yaml, the HF floor reader of reader_hf_floor.yaml (the rfid_reader_sim node's
reader: polled every 500-600 ms, some polls failing; a poll falls on the first step at or after its time) and the
location server (the WiFi model's scan at the true position matched against a radio map). Only the simulation knows
the true pose.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_bringup.scenario import CONFIG_DIR
from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import RouteMap
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_common.tag_groups import HF_READ_RANGE_M
from rfidnav_experiments.runners.shipped import file_parameters, shipped_parameters
from rfidnav_localization.dead_reckoning import TIER_TAG, Fix
from rfidnav_localization.errors import LocateError
from rfidnav_localization.fingerprint import Fingerprint, LocateSettings, RadioMap
from rfidnav_planning.parameters import TwoTierNavigatorParameters
from rfidnav_planning.two_tier_navigation import LOCATE, MapTag, Request, TwoTierNavigator, TwoTierSettings
from rfidnav_planning.wall_paths import WallMap
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.kinematics import moves_into_wall, unicycle_step
from rfidnav_sim.parameters import CompassParameters, ReaderParameters, RobotSimParameters, WifiSimParameters
from rfidnav_sim.wifi_model import WifiModel
from rfidnav_sim.world import World

NAVIGATOR = shipped_parameters(TwoTierNavigatorParameters, "two_tier_navigator")    # the node's, as shipped
SETTINGS = NAVIGATOR.settings()
STEP_S = 1.0 / NAVIGATOR.control_rate_hz    # control and simulation step
SURVEY_FRESH_M = 2.0               # survey only within this odometry distance of a tag fix (sd ~ 10 cm)
ODOMETRY_SCALE_ERROR = 0.05        # odometry distance 5 % long: paper 003 sec. 4.1, 1 m of error per 20 m
COMPASS = shipped_parameters(CompassParameters, "compass_sim").model()   # the compass_sim node's
FOOTPRINT_RADIUS_M = shipped_parameters(RobotSimParameters, "robot_sim", world_file="-").footprint_radius_m
FLOOR_READER_FILE = CONFIG_DIR / "params" / "reader_hf_floor.yaml"       # two_tier_home's rfid_reader role
FLOOR_READER = file_parameters(ReaderParameters, FLOOR_READER_FILE, "rfid_reader_sim", world_file="unused")


@dataclass(frozen=True)
class Site:
    """A world as the experiments use it: its WiFi and the location server's two maps (its floor tags are read
    by the floor reader, from the world)."""
    world: World
    wifi: WifiModel
    tag_map: tuple[MapTag, ...]           # what the server serves (every tag of every group)
    radio_map: RadioMap

    @classmethod
    def of(cls, world: World, radio_map: RadioMap) -> Site:
        tags = [MapTag(tag_id, position, group.group_id, group.shape)
                for group in world.tag_groups for tag_id, position in group.tags()]
        return cls(world, wifi_model(world), tuple(tags), radio_map)

    def tags_near(self, centre: tuple[float, float], radius_m: float) -> list[MapTag]:
        return [tag for tag in self.tag_map if math.dist(tag.position, centre) <= radius_m]


def wifi_model(world: World) -> WifiModel:
    """The world's WiFi heard by the receiver of config/params/wifi_sim.yaml (its noise and sensitivity), as the
    wifi_sim node hears it."""
    receiver = shipped_parameters(WifiSimParameters, "wifi_sim", world_file="unused")
    settings = dataclasses.replace(world.wifi, scan_noise_sd_db=receiver.scan_noise_sd_db,
                                   sensitivity_dbm=receiver.sensitivity_dbm)
    return WifiModel(world.access_points, world.wall_segments(), settings, world.wifi_seed)


MAX_GRID_POINTS = 100_000     # a grid survey's points at most (~0.5 ms each)


def grid_points(world: World, spacing_m: float) -> float:
    """How many points a survey on a ``spacing_m`` grid visits (a float: it may be far beyond any integer loop)."""
    width, height = floor_extent(world)
    return max(0.0, math.ceil(width / spacing_m - 0.5)) * max(0.0, math.ceil(height / spacing_m - 0.5))


def grid_radio_map(world: World, spacing_m: float, rng: np.random.Generator, scans_per_point: int = 3) -> RadioMap:
    """A site survey on a regular grid at known positions (the usual manual way): each fingerprint is the mean
    of a few scans, as surveyors average."""
    wifi = wifi_model(world)
    xs = np.arange(spacing_m / 2.0, floor_extent(world)[0], spacing_m)
    ys = np.arange(spacing_m / 2.0, floor_extent(world)[1], spacing_m)
    fingerprints = []
    for x in xs:
        for y in ys:
            scans = [wifi.scan(float(x), float(y), rng) for _ in range(scans_per_point)]
            heard: dict[str, list[float]] = {}
            for scan in scans:
                for reading in scan:
                    heard.setdefault(reading.bssid, []).append(reading.rssi_dbm)
            if heard:
                fingerprints.append(Fingerprint((float(x), float(y)), {b: float(np.mean(v)) for b, v in heard.items()},
                                                "grid"))
    return RadioMap(fingerprints)


def floor_extent(world: World) -> tuple[float, float]:
    """(width, height) of a floor whose walls start at the origin: its walls' largest x and y."""
    walls = world.wall_segments()
    return float(max(walls[:, 0].max(), walls[:, 2].max())), float(max(walls[:, 1].max(), walls[:, 3].max()))


@dataclass(frozen=True)
class TwoTierRun:
    success: bool
    message: str
    final_position: tuple[float, float]    # true
    target: tuple[float, float]
    path_length_m: float
    fix_errors_m: tuple[float, ...]        # true distance from each tier-two fix's position (at the fix)
    tag_position_errors_m: tuple[float, ...]   # the same fixes taken at the tags read (their centroid): the paper's
    tier_one_errors_m: tuple[float, ...]   # true distance from each tier-one answer
    searches: int
    search_length_m: float
    visited: tuple[str, ...]
    duration_s: float
    survey: tuple[tuple[tuple[float, float], dict[str, float]], ...] = ()   # (estimated position, scan)
    bumps: int = 0                         # steps refused because they drove into a wall

    @property
    def final_error_m(self) -> float:
        return math.dist(self.final_position, self.target)


def run_two_tier(site: Site, start: tuple[float, float, float], target: tuple[float, float],
                 settings: TwoTierSettings, rng: np.random.Generator, reader_seed: int,
                 odometry_scale_error: float = ODOMETRY_SCALE_ERROR, compass: CompassModel = COMPASS,
                 locate: LocateSettings = LocateSettings(), max_time_s: float = 1800.0,
                 survey_spacing_m: float | None = None, known_start: Fix | None = None,
                 floor: WallMap = WallMap()) -> TwoTierRun:
    """One navigation from ``start`` (true pose) to ``target``, the compass and WiFi drawn from ``rng``, the floor
    reader's streams seeded from ``reader_seed`` (as the rfid_reader_sim node seeds them from its seed). With
    ``survey_spacing_m`` the robot also surveys (paper 003's automatic radio map construction): a scan every that
    many metres while its position is fresh from a tag fix (within SURVEY_FRESH_M), recorded at the position it
    believes (never the true one) and added to the site's radio map at once, as the add_fingerprint service
    does. ``floor``: the walls and extent of the robot's map, which its legs are planned round."""
    x, y, yaw = start
    reader = FLOOR_READER.simulated_reader(site.world, reader_seed)
    floor_port = NAVIGATOR.floor_antenna
    positions = {tag.tag_id: tag.position for tag in site.tag_map}
    survey: list[tuple[tuple[float, float], dict[str, float]]] = []
    surveyed_at_m = -math.inf
    odom = (0.0, 0.0, 0.0)
    navigator = TwoTierNavigator(settings, floor)
    decision = navigator.start(target, known_start)
    fix_errors: list[float] = []
    tag_position_errors: list[float] = []
    tier_one_errors: list[float] = []
    fixes_seen = len(navigator.progress.fixes)      # a known start is no fix of the reader's
    time_s = path_m = 0.0
    walls, bumps = site.world.wall_segments(), 0
    while not decision.finished and time_s < max_time_s:
        if decision.request is not None:
            decision = answer(site, navigator, decision.request, (x, y), rng, locate, tier_one_errors)
            continue
        linear, angular = decision.command
        dx, dy, dyaw = unicycle_step(yaw, linear, angular, STEP_S)
        if len(walls) and moves_into_wall(walls, (x, y), (x + dx, y + dy), FOOTPRINT_RADIUS_M):
            bumps += 1
            linear = dx = dy = 0.0                      # stalled against the wall: it only turns
        x, y, yaw = x + dx, y + dy, yaw + dyaw
        # Odometry: the same motion with the distance off by the scale error.
        dx, dy, dyaw = unicycle_step(odom[2], linear * (1.0 + odometry_scale_error), angular, STEP_S)
        odom = (odom[0] + dx, odom[1] + dy, odom[2] + dyaw)
        path_m += abs(linear) * STEP_S
        time_s += STEP_S
        round_reads = reader.round_at(x, y, yaw, time_s) or []
        reads = [read.tag_id for read in round_reads if read.antenna == floor_port]
        decision = navigator.step(odom, compass.measure(yaw, rng), reads)
        fixes = navigator.progress.fixes
        for fix in fixes[fixes_seen:]:
            if fix.tag_id:
                fix_errors.append(math.dist(fix.position, (x, y)))
                read_at = np.mean([positions[tag_id] for tag_id in reads if tag_id in positions], axis=0)
                tag_position_errors.append(math.dist(read_at, (x, y)))
        fixes_seen = len(fixes)
        estimate = navigator.estimate()
        if (survey_spacing_m is not None and estimate.last_fix is not None and estimate.last_fix.tag_id
                and estimate.distance_since_fix_m <= SURVEY_FRESH_M
                and navigator.travelled_m - surveyed_at_m >= survey_spacing_m):
            surveyed_at_m = navigator.travelled_m
            scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(x, y, rng)}
            if scan:
                survey.append((estimate.position, scan))
                site.radio_map.add(Fingerprint(estimate.position, scan, "survey"))
    if not decision.finished:
        decision = navigator.finish(False, f"timed out after {max_time_s:g} s")
    progress = navigator.progress
    return TwoTierRun(decision.success, decision.message, (x, y), target, path_m, tuple(fix_errors),
                      tuple(tag_position_errors), tuple(tier_one_errors), progress.searches,
                      progress.search_length_m, tuple(progress.visited),
                      time_s, tuple(survey), bumps)


def answer(site: Site, navigator: TwoTierNavigator, request: Request, true_position: tuple[float, float],
           rng: np.random.Generator, locate: LocateSettings, tier_one_errors: list[float]):
    """The location server's answer to ``request``, as the node gets it over DDS."""
    if request.kind == LOCATE:
        scan = {reading.bssid: reading.rssi_dbm for reading in site.wifi.scan(*true_position, rng)}
        try:
            result = site.radio_map.locate(scan, locate)
        except LocateError:
            return navigator.on_located(None, 0.0)
        tier_one_errors.append(math.dist(result.position, true_position))
        return navigator.on_located(result.position, result.uncertainty_m)
    return navigator.on_tag_map(site.tags_near(request.centre, request.radius_m))


def robot_survey(site: Site, robot_map: RouteMap, seed: int, spacing_m: float = 0.5) -> list[Fingerprint]:
    """The robot's own survey into ``site``'s (empty) radio map: docked on the map's first landmark (a known
    start), it visits every landmark in turn and scans every ``spacing_m`` while fresh from a tag fix; its
    tier-one checks on the way use the map built so far."""
    rng = rng_for(seed, "robot survey")
    first = robot_map.tag_groups[0].centre
    pose = (first[0], first[1], 0.0)
    known = Fix(first, HF_READ_RANGE_M, TIER_TAG, f"{robot_map.tag_groups[0].group_id} (dock)")
    for leg, group in enumerate(robot_map.tag_groups[1:]):
        run = run_two_tier(site, pose, group.centre, SETTINGS, rng, derive_seed(seed, f"robot survey:{leg}"),
                           survey_spacing_m=spacing_m, known_start=known, floor=WallMap.of(robot_map))
        pose = (run.final_position[0], run.final_position[1], 0.0)
        known = None if not run.success else Fix(group.centre, HF_READ_RANGE_M, TIER_TAG, group.group_id)
    return list(site.radio_map.fingerprints)


def check_survey(world: World, robot_map: RouteMap, map_file: Path, grid_spacing_m: float | None) -> None:
    """What ``./rfidnav survey`` is asked can be done, before anything runs: a grid of at least one and at most
    MAX_GRID_POINTS points over the world's walled floor, or a map with landmarks for the robot's own survey."""
    if grid_spacing_m is None:
        if not robot_map.tag_groups:
            raise ConfigError(str(map_file), "tag_groups", "the robot's survey visits the map's landmarks: none")
        return
    if not world.walls:
        raise ConfigError("--grid", "", f"the world {world.name} has no walls: a grid survey covers the floor they "
                                        "enclose")
    points, (width, height) = grid_points(world, grid_spacing_m), floor_extent(world)
    if points > MAX_GRID_POINTS:
        raise ConfigError("--grid", "", f"a {grid_spacing_m:g} m grid over {world.name}'s {width:g} x {height:g} m "
                                        f"floor has {points:.3g} points, more than {MAX_GRID_POINTS:,} (about a minute "
                                        "of surveying): take a wider spacing")
    if points < 1:
        raise ConfigError("--grid", "", f"a {grid_spacing_m:g} m grid has no point on {world.name}'s {width:g} x "
                                        f"{height:g} m floor")


def survey(world: World, robot_map: RouteMap, grid_spacing_m: float | None,
           seed: int) -> tuple[list[Fingerprint], str]:
    """``./rfidnav survey`` (checked by :func:`check_survey`): a grid site survey at known positions, or the robot's
    own survey of the map's landmarks (grid_spacing_m None). Returns the fingerprints and a one-line description."""
    if grid_spacing_m is not None:
        fingerprints = list(grid_radio_map(world, grid_spacing_m, rng_for(seed, "grid survey")).fingerprints)
        return fingerprints, f"site survey of {world.name} on a {grid_spacing_m:g} m grid, seed {seed}"
    fingerprints = robot_survey(Site.of(world, RadioMap()), robot_map, seed)
    return fingerprints, (f"the robot's own survey of {world.name} through {len(robot_map.tag_groups)} landmarks, "
                          f"seed {seed}")
