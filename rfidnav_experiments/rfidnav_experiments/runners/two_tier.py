"""In-process two-tier navigation (paper 003): the navigator core of the DDS node driving an idealised robot through a
simulated flat, for the paper's statistics.

The robot is a unicycle stepped at the navigator's control rate with the commanded velocities (no motor dynamics),
as round as robot_sim's base: a step into one of the flat's walls is not made (and not counted by the odometry), as
robot_sim stalls its base there; ``TwoTierRun.bumps`` counts those steps, and ``TwoTierRun.wall_crossings`` the
walls its true track crossed all the same (the report's metric: a run that crossed one is no success). The
navigator is the two_tier_navigator node's, with its shipped parameters (config/params/two_tier_navigator.yaml).
What it sees is simulated as the nodes simulate it: wheel odometry whose distance is off by ``odometry_scale_error``
(paper 003: about 1 m per 20 m with a load), the e-compass of compass_sim.yaml, the HF floor reader of
reader_hf_floor.yaml (the rfid_reader_sim node's reader: polled every 500-600 ms, some polls failing; a poll falls on
the first step at or after its time) and the location server (the WiFi model's scan at the true position matched
against a radio map). Only the simulation knows the true pose.

``./rfidnav survey --grid`` plans its points here (:func:`survey_grid`): the grid over the floor's extent, clear of
the walls and reachable on foot from the scenario's start.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from rfidnav_common.errors import ConfigError
from rfidnav_common.geometry import point_segment_distance
from rfidnav_common.robot_map import RouteMap, bounding_box
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_experiments.runners.shipped import file_parameters, shipped_parameters
from rfidnav_localization.dead_reckoning import DeadReckoningEstimate, Fix
from rfidnav_localization.errors import LocateError
from rfidnav_localization.fingerprint import Fingerprint, LocateResult, LocateSettings, RadioMap
from rfidnav_localization.parameters import LocationServerParameters
from rfidnav_planning.parameters import TwoTierNavigatorParameters
from rfidnav_planning.two_tier_navigation import (
    LOCATE,
    Decision,
    MapTag,
    Request,
    TwoTierNavigator,
    TwoTierSettings,
)
from rfidnav_planning.two_tier_survey import SURVEY_SPACING_M, RobotSurvey, SurveyLeg, SurveyRule
from rfidnav_planning.wall_paths import WallMap
from rfidnav_scenario.metrics import ground_truth_objection, wall_crossings
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.kinematics import IdealUnicycle
from rfidnav_sim.parameters import CompassParameters, ReaderParameters, RobotSimParameters, WifiSimParameters
from rfidnav_sim.rfid_model import Read
from rfidnav_sim.rig import Rig, ScheduledSensor, Sensor
from rfidnav_sim.wifi_model import WifiModel
from rfidnav_sim.world import World

NAVIGATOR = shipped_parameters(TwoTierNavigatorParameters, "two_tier_navigator")    # the node's, as shipped
SETTINGS = NAVIGATOR.settings()
STEP_S = 1.0 / NAVIGATOR.control_rate_hz    # control and simulation step
ODOMETRY_SCALE_ERROR = 0.05        # odometry distance 5 % long: paper 003 sec. 4.1, 1 m of error per 20 m
COMPASS = shipped_parameters(CompassParameters, "compass_sim").model()   # the compass_sim node's
FOOTPRINT_RADIUS_M = shipped_parameters(RobotSimParameters, "robot_sim", world_file="-").footprint_radius_m
FLOOR_READER_FILE = CONFIG_DIR / "params" / "reader_hf_floor.yaml"       # two_tier_home's rfid_reader role
FLOOR_READER = file_parameters(ReaderParameters, FLOOR_READER_FILE, "rfid_reader_sim", world_file="unused")
# The location server's fingerprint matcher (k nearest neighbours, the RSS of an AP heard on one side only), as the
# location_server node is shipped: the locate every in-process run asks.
LOCATION_SERVER = shipped_parameters(LocationServerParameters, "location_server")
LOCATE_SETTINGS = LOCATION_SERVER.locate_settings()


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

    def locate_scan(self, position: tuple[float, float], rng: np.random.Generator,
                    locate: LocateSettings) -> LocateResult | None:
        """The location server's answer to a scan taken at ``position`` (drawn from ``rng``), as a node gets it
        from /location_server/locate; None when it cannot locate it (nothing heard that the radio map knows)."""
        scan = {reading.bssid: reading.rssi_dbm for reading in self.wifi.scan(*position, rng)}
        try:
            return self.radio_map.locate(scan, locate)
        except LocateError:
            return None


def wifi_model(world: World) -> WifiModel:
    """The world's WiFi heard by the receiver of config/params/wifi_sim.yaml (its noise and sensitivity), as the
    wifi_sim node hears it."""
    receiver = shipped_parameters(WifiSimParameters, "wifi_sim", world_file="unused")
    settings = dataclasses.replace(world.wifi, scan_noise_sd_db=receiver.scan_noise_sd_db,
                                   sensitivity_dbm=receiver.sensitivity_dbm)
    return WifiModel(world.access_points, world.wall_segments(), settings, world.wifi_seed)


MAX_GRID_POINTS = 100_000     # a grid survey's points at most (~0.5 ms each)
SURVEY_CLEARANCE_M = 0.2      # a grid point closer to a wall is not surveyed: the surveyor stands in the room
WALK_CELL_M = 0.1             # the raster the surveyor's walk from the start is flood-filled on
MAX_WALK_CELLS = 4_000_000    # ... over at most 40,000 m^2 of floor
# A raster cell is blocked when its centre is this close to a wall: every grid point clear of the walls then lies in
# a free cell (its cell's centre is within half a diagonal), and no step between two free cells crosses a wall
# (such a step has an end within half a cell of the wall).
WALK_BLOCKED_M = SURVEY_CLEARANCE_M - WALK_CELL_M / math.sqrt(2.0)
assert WALK_BLOCKED_M >= WALK_CELL_M / 2.0


@dataclass(frozen=True)
class SurveyGrid:
    """Where a grid survey scans: the points of a ``spacing_m`` grid over the floor's extent that are clear of the
    walls (by SURVEY_CLEARANCE_M) and that a surveyor walking from ``start`` reaches; the other free points are
    ``enclosed`` (walled off, not open to the extent's edge: a closet, a room without a door) or ``outside`` (cut
    off from the start but open to the extent's edge: beyond the walls, e.g. round an L-shaped flat)."""
    extent: tuple[float, float, float, float]
    spacing_m: float
    start: tuple[float, float]
    points: tuple[tuple[float, float], ...]
    enclosed: tuple[tuple[float, float], ...] = ()
    outside: int = 0
    near_wall: int = 0


def floor_extent(world: World) -> tuple[float, float, float, float]:
    """The floor a grid survey covers, (x_min, y_min, x_max, y_max): the world's declared ``extent``, else its walls'
    bounding box, wherever the map's origin lies. A ConfigError naming the world file if it has neither."""
    if world.extent is not None:
        return world.extent
    if not world.walls:
        raise ConfigError(world.source, "walls", "a grid survey covers the floor within the walls or the extent: "
                                                 "this world has neither (add extent: [x_min, y_min, x_max, y_max])")
    return bounding_box(world.walls)


def grid_counts(extent: tuple[float, float, float, float], spacing_m: float) -> tuple[float, float]:
    """How many columns and rows a ``spacing_m`` grid over ``extent`` has (floats: they may be far beyond any
    integer loop)."""
    x_min, y_min, x_max, y_max = extent
    return (max(0.0, float(np.ceil((x_max - x_min) / spacing_m - 0.5))),
            max(0.0, float(np.ceil((y_max - y_min) / spacing_m - 0.5))))


def wall_distance(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Each point's (N x 2) distance from the nearest wall (inf without walls)."""
    distance = np.full(len(points), np.inf)
    for wall in walls:
        np.minimum(distance, point_segment_distance(points, wall[:2], wall[2:]), out=distance)
    return distance


def lattice(extent: tuple[float, float, float, float], step_m: float, counts: tuple[int, int]) -> np.ndarray:
    """``counts`` columns by rows of points ``step_m`` apart from half a step inside ``extent``'s low corner, x-major
    (N x 2: x, then y)."""
    xs = extent[0] + step_m * (np.arange(counts[0]) + 0.5)
    ys = extent[1] + step_m * (np.arange(counts[1]) + 0.5)
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


def survey_grid(world: World, spacing_m: float, start: tuple[float, float], start_source: str = "start") -> SurveyGrid:
    """The grid survey's points (:class:`SurveyGrid`), checked before anything is scanned: at least one and at most
    MAX_GRID_POINTS grid points, a floor of at most MAX_WALK_CELLS raster cells, the start on the floor and clear
    of the walls; every refusal a ConfigError (``start_source`` names where the start comes from)."""
    extent = floor_extent(world)
    x_min, y_min, x_max, y_max = extent
    size = f"{world.name}'s {x_max - x_min:g} x {y_max - y_min:g} m floor"
    columns, rows = grid_counts(extent, spacing_m)
    if columns * rows > MAX_GRID_POINTS:
        raise ConfigError("--grid", "", f"a {spacing_m:g} m grid over {size} has {columns * rows:.3g} points, more "
                                        f"than {MAX_GRID_POINTS:,} (about a minute of surveying): take a wider spacing")
    if columns * rows < 1:
        raise ConfigError("--grid", "", f"a {spacing_m:g} m grid has no point on {size}")
    cells = (math.ceil((x_max - x_min) / WALK_CELL_M), math.ceil((y_max - y_min) / WALK_CELL_M))
    if math.prod(cells) > MAX_WALK_CELLS:
        raise ConfigError(world.source, "extent", f"{size} is more than the {MAX_WALK_CELLS * WALK_CELL_M ** 2:,.0f} "
                                                  "m^2 a grid survey walks")
    if not (x_min <= start[0] <= x_max and y_min <= start[1] <= y_max):
        raise ConfigError(start_source, "", f"the survey starts at ({start[0]:g}, {start[1]:g}), off {size} "
                                            f"[{x_min:g}, {y_min:g}, {x_max:g}, {y_max:g}]")
    walls = world.wall_segments()
    free = wall_distance(lattice(extent, WALK_CELL_M, cells), walls).reshape(cells) >= WALK_BLOCKED_M
    regions, _ = ndimage.label(free)         # 4-connected: the surveyor steps from cell to cell

    def region(x: float, y: float) -> int:
        column, row = int((x - x_min) / WALK_CELL_M), int((y - y_min) / WALK_CELL_M)
        return int(regions[min(column, cells[0] - 1), min(row, cells[1] - 1)])

    home = region(*start)
    if home == 0:
        raise ConfigError(start_source, "", f"the survey starts at ({start[0]:g}, {start[1]:g}), within "
                                            f"{WALK_BLOCKED_M:.2f} m of a wall of {world.name}")
    open_to_edge = set(np.concatenate((regions[0], regions[-1], regions[:, 0], regions[:, -1])).tolist())
    grid = lattice(extent, spacing_m, (int(columns), int(rows)))
    clear = wall_distance(grid, walls) >= SURVEY_CLEARANCE_M
    points, enclosed, outside = [], [], 0
    for (x, y) in grid[clear].tolist():
        label = region(x, y)
        if label == home:
            points.append((x, y))
        elif label in open_to_edge:
            outside += 1
        else:
            enclosed.append((x, y))
    return SurveyGrid(extent, spacing_m, start, tuple(points), tuple(enclosed), outside,
                      int(np.count_nonzero(~clear)))


def grid_radio_map(world: World, points: Sequence[tuple[float, float]], rng: np.random.Generator,
                   scans_per_point: int = 3) -> RadioMap:
    """A site survey at known positions (the usual manual way), e.g. :func:`survey_grid`'s points: each fingerprint
    is the mean of a few scans, as surveyors average."""
    wifi = wifi_model(world)
    fingerprints = []
    for x, y in points:
        scans = [wifi.scan(x, y, rng) for _ in range(scans_per_point)]
        heard: dict[str, list[float]] = {}
        for scan in scans:
            for reading in scan:
                heard.setdefault(reading.bssid, []).append(reading.rssi_dbm)
        if heard:
            fingerprints.append(Fingerprint((x, y), {b: float(np.mean(v)) for b, v in heard.items()}, "grid"))
    return RadioMap(fingerprints)


READER, COMPASS_SENSOR, WIFI = "rfid_reader_sim", "compass_sim", "location_server"   # the rig's sensors


def floor_rig(site: Site, start: tuple[float, float, float], odometry_scale_error: float, step_s: float,
              sensors: Mapping[str, Sensor]) -> Rig[IdealUnicycle]:
    """The in-process runs' robot on a home's floor (an ideal unicycle that stalls at the walls, its odometry
    ``odometry_scale_error`` long) among ``sensors``, sampled every ``step_s`` step (the control rate)."""
    robot = IdealUnicycle(start, site.world.wall_segments(), FOOTPRINT_RADIUS_M, odometry_scale_error)
    return Rig(robot, step_s, 1, sensors)


@dataclass(frozen=True)
class Located:
    """The location server's answer to one scan: None when it cannot locate it."""
    result: LocateResult | None


def located_scans(site: Site, period_s: float, rng: np.random.Generator,
                  locate: LocateSettings) -> ScheduledSensor[Located]:
    """A WiFi scan every ``period_s`` (drawn from ``rng``) located by the location server, as a localizer that
    asks for every scan gets it."""
    return ScheduledSensor(period_s, lambda truth, draw: Located(site.locate_scan(truth[:2], draw, locate)), rng)


@dataclass(frozen=True)
class StepSeen:
    """What the robot's sensors gave in one step of a run, with the truth and the navigator's own estimate after
    it: for a localizer run beside the paper's on the same streams (rfidnav_experiments.reproduce.fused)."""
    time_s: float
    truth: tuple[float, float, float]
    odom: tuple[float, float, float]
    compass_yaw_rad: float
    round_reads: tuple[Read, ...] | None                   # every antenna's reads; None: no round this step
    wifi_fix: tuple[tuple[float, float], float] | None     # the location server's answer this step, if any
    paper: DeadReckoningEstimate


# Tier one from a localizer's pose: its latest (position, sd [m]), None before it has one.
TierOne = Callable[[], tuple[tuple[float, float], float] | None]


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
    wall_crossings: int = 0                # rfidnav_scenario.metrics.wall_crossings of the true track

    @property
    def final_error_m(self) -> float:
        return math.dist(self.final_position, self.target)


def run_two_tier(site: Site, start: tuple[float, float, float], target: tuple[float, float],
                 settings: TwoTierSettings, rng: np.random.Generator, reader_seed: int,
                 odometry_scale_error: float = ODOMETRY_SCALE_ERROR, compass: CompassModel = COMPASS,
                 locate: LocateSettings = LOCATE_SETTINGS, max_time_s: float = 1800.0,
                 survey_spacing_m: float | None = None, known_start: Fix | None = None,
                 floor: WallMap = WallMap(), observe: Callable[[StepSeen], None] | None = None,
                 reader_parameters: ReaderParameters = FLOOR_READER, tier_one: TierOne | None = None,
                 scan_period_s: float | None = None) -> TwoTierRun:
    """One navigation from ``start`` (true pose) to ``target``, the compass and WiFi drawn from ``rng``, the floor
    reader's streams seeded from ``reader_seed`` (as the rfid_reader_sim node seeds them from its seed). With
    ``survey_spacing_m`` the robot also surveys (paper 003's automatic radio map construction,
    rfidnav_planning.two_tier_survey.SurveyRule): a scan every that many metres while its position is fresh from
    a tag fix, recorded at the position it believes (never the true one) and added to the site's radio map at
    once, as the add_fingerprint service does. ``floor``: the walls and extent of the robot's map, which its legs
    are planned round. ``observe`` is called after every step with what the sensors gave (:class:`StepSeen`); it
    draws nothing.
    ``reader_parameters``: the robot's reader (the navigator reads its floor antenna's port). ``tier_one``: where
    the navigator's locate requests are answered from instead of the location server (two_tier_navigator's
    ``tier_one_from`` naming a localizer's pose; the robot stands still until it answers). ``scan_period_s``: a
    scan this often located by the server for the observers (a localizer that asks for every scan, as
    rfid_localizer does), in place of the answers to the navigator's own requests."""
    sensors: dict[str, Sensor] = {
        READER: reader_parameters.simulated_reader(site.world, reader_seed),
        COMPASS_SENSOR: ScheduledSensor(STEP_S, lambda truth, draw: compass.measure(truth[2], draw), rng)}
    if scan_period_s is not None:
        sensors[WIFI] = located_scans(site, scan_period_s, rng, locate)
    rig = floor_rig(site, start, odometry_scale_error, STEP_S, sensors)
    x, y, _ = start
    floor_port = NAVIGATOR.floor_antenna
    positions = {tag.tag_id: tag.position for tag in site.tag_map}
    survey: list[tuple[tuple[float, float], dict[str, float]]] = []
    survey_rule = None if survey_spacing_m is None else SurveyRule(survey_spacing_m)
    navigator = TwoTierNavigator(settings, floor)
    decision = navigator.start(target, known_start)
    fix_errors: list[float] = []
    tag_position_errors: list[float] = []
    tier_one_errors: list[float] = []
    fixes_seen = len(navigator.progress.fixes)      # a known start is no fix of the reader's
    located: list[tuple[tuple[float, float], float]] = []
    while not decision.finished and rig.now_s < max_time_s:
        waiting = None                  # a locate request tier_one cannot answer yet
        if decision.request is not None:
            if tier_one is None or decision.request.kind != LOCATE:
                decision = answer(site, navigator, decision.request, (x, y), rng, locate, tier_one_errors, located)
                continue
            answered = tier_one()
            if answered is not None:
                tier_one_errors.append(math.dist(answered[0], (x, y)))
                decision = navigator.on_located(*answered)
                continue
            waiting = decision.request
        rig.command(*decision.command, rig.now_s)
        seen = rig.advance()
        (x, y, _), time_s = seen.truth, seen.time_s
        due = seen.readings.get(READER)
        reads = [read.tag_id for read in due or () if read.antenna == floor_port]
        compass_yaw = seen.readings[COMPASS_SENSOR]
        if WIFI in seen.readings:
            result = seen.readings[WIFI].result      # None: scanned, not located
            located[:] = [] if result is None else [(result.position, result.uncertainty_m)]
        decision = navigator.step(seen.odom, compass_yaw, reads)
        if waiting is not None and not decision.finished:
            decision = Decision(decision.phase, (0.0, 0.0), waiting)    # still to be answered
        if observe is not None:
            observe(StepSeen(time_s, seen.truth, seen.odom, compass_yaw, None if due is None else tuple(due),
                             located.pop() if located else None, navigator.estimate()))
        fixes = navigator.progress.fixes
        for fix in fixes[fixes_seen:]:
            if fix.tag_id:
                fix_errors.append(math.dist(fix.position, (x, y)))
                read_at = np.mean([positions[tag_id] for tag_id in reads if tag_id in positions], axis=0)
                tag_position_errors.append(math.dist(read_at, (x, y)))
        fixes_seen = len(fixes)
        surveyed_at = None if survey_rule is None else survey_rule.due(navigator.estimate(), navigator.travelled_m)
        if surveyed_at is not None:
            scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(x, y, rng)}
            if scan:
                survey.append((surveyed_at, scan))
                site.radio_map.add(Fingerprint(surveyed_at, scan, "survey"))
    if not decision.finished:
        decision = navigator.finish(False, f"timed out after {max_time_s:g} s")
    progress = navigator.progress
    crossings = wall_crossings(rig.track()[1], site.world.wall_segments())
    objection = ground_truth_objection({"wall_crossings": crossings})
    robot = rig.base
    return TwoTierRun(decision.success and objection is None,
                      decision.message if objection is None else f"{decision.message}; but it {objection}",
                      (x, y), target, robot.distance_travelled_m, tuple(fix_errors), tuple(tag_position_errors),
                      tuple(tier_one_errors), progress.searches, progress.search_length_m, tuple(progress.visited),
                      rig.now_s, tuple(survey), robot.bumps, crossings)


def answer(site: Site, navigator: TwoTierNavigator, request: Request, true_position: tuple[float, float],
           rng: np.random.Generator, locate: LocateSettings, tier_one_errors: list[float],
           located: list[tuple[tuple[float, float], float]] | None = None):
    """The location server's answer to ``request``, as the node gets it over DDS (a position found is appended
    to ``located`` with its uncertainty)."""
    if request.kind == LOCATE:
        result = site.locate_scan(true_position, rng, locate)
        if result is None:
            return navigator.on_located(None, 0.0)
        tier_one_errors.append(math.dist(result.position, true_position))
        if located is not None:
            located[:] = [(result.position, result.uncertainty_m)]
        return navigator.on_located(result.position, result.uncertainty_m)
    return navigator.on_tag_map(site.tags_near(request.centre, request.radius_m))


def robot_survey(site: Site, robot_map: RouteMap, seed: int, spacing_m: float = SURVEY_SPACING_M,
                 dock: str = "", landmarks: Sequence[str] = ()) -> list[Fingerprint]:
    """The robot's own survey (rfidnav_planning.two_tier_survey) into ``site``'s (empty) radio map: docked on
    ``dock`` (the map's first landmark), it visits ``landmarks`` (every other) in turn and scans every
    ``spacing_m`` while fresh from a tag fix; its tier-one checks on the way use the map built so far."""
    rng = rng_for(seed, "robot survey")
    plan = RobotSurvey(robot_map.tag_groups, dock, landmarks)
    leg: SurveyLeg | None = plan.first_leg()
    x, y = plan.dock_group.centre
    pose = (x, y, 0.0)
    while leg is not None:
        run = run_two_tier(site, pose, leg.target, SETTINGS, rng, derive_seed(seed, f"robot survey:{leg.index}"),
                           survey_spacing_m=spacing_m, known_start=leg.known_start, floor=WallMap.of(robot_map))
        pose = (run.final_position[0], run.final_position[1], 0.0)
        leg = plan.leg_ended(run.success)
    return list(site.radio_map.fingerprints)


def plan_survey(world: World, robot_map: RouteMap, map_file: Path, grid_spacing_m: float | None,
                start: tuple[float, float], start_source: str) -> SurveyGrid | None:
    """What ``./rfidnav survey`` is asked can be done, before anything runs: a grid survey's points walked from
    ``start`` (:func:`survey_grid`), or None for the robot's own survey (grid_spacing_m None) of a map with
    landmarks; either scans the world's access points."""
    grid = survey_grid(world, grid_spacing_m, start, start_source) if grid_spacing_m is not None else None
    if grid is None and not robot_map.tag_groups:
        raise ConfigError(str(map_file), "tag_groups", "the robot's survey visits the map's landmarks: none")
    if not world.access_points:
        raise ConfigError(world.source, "access_points", "a survey records the WiFi heard: this world has none")
    return grid


MAX_LISTED = 8        # unreachable points named in the warning, the rest counted


def survey_warnings(grid: SurveyGrid) -> list[str]:
    """One line naming the free grid points the surveyor cannot walk to from the start (none: no line)."""
    if not grid.enclosed:
        return []
    listed = ", ".join(f"({x:g}, {y:g})" for x, y in grid.enclosed[:MAX_LISTED])
    more = f" and {len(grid.enclosed) - MAX_LISTED} more" if len(grid.enclosed) > MAX_LISTED else ""
    return [f"{len(grid.enclosed)} grid point{'s' if len(grid.enclosed) > 1 else ''} clear of the walls cannot be "
            f"reached from ({grid.start[0]:g}, {grid.start[1]:g}), walled off (a closet? a door narrower than about "
            f"{2 * WALK_BLOCKED_M + WALK_CELL_M:.2f} m?): {listed}{more}; not surveyed"]


def survey(world: World, robot_map: RouteMap, grid: SurveyGrid | None, seed: int) -> tuple[list[Fingerprint], str]:
    """``./rfidnav survey`` (planned by :func:`plan_survey`): a grid site survey at known positions, or the robot's
    own survey of the map's landmarks (grid None). Returns the fingerprints and a one-line description."""
    if grid is not None:
        fingerprints = list(grid_radio_map(world, grid.points, rng_for(seed, "grid survey")).fingerprints)
        left_out = [f"{count} {what}" for count, what in (
            (grid.near_wall, f"within {SURVEY_CLEARANCE_M:g} m of a wall"), (grid.outside, "outside the walls"),
            (len(grid.enclosed), "walled off")) if count]
        x_min, y_min, x_max, y_max = grid.extent
        return fingerprints, (f"site survey of {world.name} on a {grid.spacing_m:g} m grid over [{x_min:g}, {y_min:g}, "
                              f"{x_max:g}, {y_max:g}] walked from ({grid.start[0]:g}, {grid.start[1]:g}), seed {seed}"
                              + (f"; grid points left out: {', '.join(left_out)}" if left_out else ""))
    fingerprints = robot_survey(Site.of(world, RadioMap()), robot_map, seed)
    return fingerprints, (f"the robot's own survey of {world.name} through {len(robot_map.tag_groups)} landmarks, "
                          f"seed {seed}")
