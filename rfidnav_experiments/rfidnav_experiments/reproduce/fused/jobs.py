"""reproduce fused: one run of a world as an engine task (the paper's navigator with the fused localizers beside, or
a navigator driving on the fused localizer), and every world's runs."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

from rfidnav_common.robot_map import RouteMap, load_route_map
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_common.tag_lattice import Deployment
from rfidnav_common.topological_map import load_topological_map
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.fused.conditions import (
    DRIVING,
    FLOOR_LATTICE_LOCALIZER,
    HALLWAY,
    PARTITION_DRIVING,
    PARTITION_ODOMETRY_NOISE,
    PARTITION_TASK_M,
    PARTITIONS,
    RING,
    TIER_ONE,
    UHF_2ANT_LOCALIZER,
    WALL_SIDE_LOCALIZER,
    WORLDS,
)
from rfidnav_experiments.reproduce.fused.riders import (
    driving_rider,
    fused_run,
    home_map,
    localizer_parameters,
    mission_of,
    paired_figures,
    reader_parameters,
    riders_for,
    scan_period_s,
)
from rfidnav_experiments.reproduce.fused.summary import FusedRun, TrackFigures
from rfidnav_experiments.reproduce.partitions import FILTER, PAPER, headline_level, robot_speeds
from rfidnav_experiments.reproduce.partitions import localizer_settings as partition_localizer_settings
from rfidnav_experiments.reproduce.partitions import navigator_settings as partition_navigator_settings
from rfidnav_experiments.reproduce.two_tier import home
from rfidnav_experiments.runners.fused import (
    Beside,
    FusedPartitions,
    PartitionBeside,
    PartitionDriving,
    RouteBeside,
    TopologicalBeside,
    drive_on_fused,
)
from rfidnav_experiments.runners.partitions import random_task, run_navigation
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_experiments.runners.tag_route import controller_parameters, run_tag_route
from rfidnav_experiments.runners.topological import FLOORS, mission_tasks, run_mission, start_pose_before_tag
from rfidnav_experiments.runners.two_tier import SETTINGS, run_two_tier
from rfidnav_localization.fused.filter import FusedSettings
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_localization.partition import PartitionLocalizer
from rfidnav_planning.parameters import PoseNavigatorParameters
from rfidnav_planning.pose_navigation import PoseNavigator
from rfidnav_scenario.scenario import load_scenario
from rfidnav_sim.world import load_world


def home_run(job: tuple[str, int, int]) -> FusedRun:
    """One two-tier mission of a world with the fused localizers beside; the same streams as reproduce two_tier's
    planned-legs run of that home and run number."""
    name, run, seed = job
    place = home(name)
    parameters = localizer_parameters(place)
    riders = riders_for(name, run, seed, parameters.settings(), home_map(place))
    beside = Beside(riders, parameters.ports())
    start, target = mission_of(place)
    result = run_two_tier(place.site, start, target, SETTINGS,
                          rng_for(seed, f"homes:{name}:{run}"), derive_seed(seed, f"homes:{name}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s, floor=place.floor, observe=beside,
                          reader_parameters=reader_parameters(place))
    return dataclasses.replace(fused_run(name, run, result.success, riders, beside.paper, result.duration_s),
                               final_error_m=result.final_error_m)


def tier_one_run(job: tuple[str, int, int]) -> FusedRun:
    """One mission of a home's ``*_fused`` scenario in-process: the two-tier navigator (paper 003's legs, tier two
    and searches) with tier one from the fused localizer's latest pose rather than the location server's
    fingerprint locate, as two_tier_navigator's ``tier_one_from`` has it over DDS; the localizer asks the server
    to locate each scan itself (the scenario's WiFi scan period), as rfid_localizer does. The same mission and
    random streams' seeds as the paper's runs of that home (home_run)."""
    name, run, seed = job
    paper_home = name.removesuffix("_fused")
    place = home(name)
    rider = driving_rider(place, name, run, seed)
    beside = Beside({"fused": rider}, localizer_parameters(place).ports())
    start, target = mission_of(place)
    result = run_two_tier(place.site, start, target, SETTINGS, rng_for(seed, f"homes:{paper_home}:{run}"),
                          derive_seed(seed, f"homes:{paper_home}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s, floor=place.floor, observe=beside,
                          reader_parameters=reader_parameters(place), tier_one=rider.tier_one,
                          scan_period_s=scan_period_s(place))
    return FusedRun(name, run, result.success, paired_figures(rider.track, beside.paper),
                    rider.track.settled_after(0.0), None, None, result.duration_s, result.final_error_m)


@dataclass(frozen=True)
class PartitionTask:
    """Run ``run``'s task on paper 000's field, the same whoever drives (partition_run, partition_driving_run): the
    field, a start and a goal PARTITION_TASK_M apart, the fused localizer's settings for the paper's robot."""
    route_map: RouteMap
    deployment: Deployment
    settings: FusedSettings
    start: tuple[float, float, float]
    goal: tuple[float, float]

    @classmethod
    def of(cls, run: int, seed: int) -> PartitionTask:
        scenario = load_scenario(PARTITIONS)
        assert scenario.route_map is not None and scenario.world.deployments
        field_deployment = scenario.world.deployments[0]
        settings = file_parameters(RfidLocalizerParameters, FLOOR_LATTICE_LOCALIZER, "rfid_localizer",
                                   map_file=str(scenario.map_file)).settings()
        start, goal = random_task(field_deployment, PARTITION_TASK_M,
                                  rng_for(seed, f"fused:{PARTITIONS}:{run}:task"))
        return cls(scenario.route_map, field_deployment, settings, start, goal)

    def fused_map(self) -> FusedMap:
        """A fresh map for each localizer (it learns the lattice from the first id read)."""
        return FusedMap.of_route_map(self.route_map)


def partition_run(job: tuple[str, int, int]) -> FusedRun:
    """One paper 000 navigation across the field: the partition navigator driving on the paper's localizer, the
    fused localizers beside on the same rounds (the floor antenna's tags and the odometry: the robot has nothing
    else)."""
    name, run, seed = job
    task = PartitionTask.of(run, seed)
    riders = riders_for(name, run, seed, task.settings, task.fused_map())
    beside = PartitionBeside(riders)
    result = run_navigation(task.deployment, task.start, task.goal, partition_localizer_settings(PAPER),
                            partition_navigator_settings(PAPER, headline_level()),
                            rng_for(seed, f"fused:{name}:{run}:robot"), odometry_noise=PARTITION_ODOMETRY_NOISE,
                            speeds=robot_speeds(PAPER), observer=beside)
    return dataclasses.replace(fused_run(name, run, result.success, riders, beside.paper, result.travel_time_s),
                               final_error_m=result.final_error_m)


def partition_driving_run(job: tuple[str, int, int]) -> FusedRun:
    """The same paper 000 task as partition_run's of that run number, the partition navigator driving on the fused
    localizer (with the navigator's settings for a pose estimate, as beside paper 000's particle filter:
    partition_navigator_filter_paper_robot.yaml) and paper 000's localizer beside it on the same rounds."""
    name, run, seed = job
    task = PartitionTask.of(run, seed)
    driving = FusedPartitions(FusedLocalizer(task.settings, task.fused_map(),
                                             rng_for(seed, f"fused:{name}:{run}:fused")))
    score = PartitionDriving(driving, PartitionLocalizer(partition_localizer_settings(PAPER),
                                                         rng_for(seed, f"fused:{name}:{run}:paper")))
    result = run_navigation(task.deployment, task.start, task.goal, partition_localizer_settings(PAPER),
                            partition_navigator_settings(FILTER, headline_level()),
                            rng_for(seed, f"fused:{name}:{run}:robot"), odometry_noise=PARTITION_ODOMETRY_NOISE,
                            speeds=robot_speeds(FILTER), observer=score, driving=driving)
    return FusedRun(name, run, result.success, paired_figures(score.fused, score.beside.paper),
                    score.fused.settled_after(0.0), None, None, result.travel_time_s, result.final_error_m)


def topological_run(job: tuple[str, int, int]) -> FusedRun:
    """One paper 004 mission on a generated floor (the mission executor's own task list), the fused localizers
    beside on the same control steps: the side antenna's wall tags and the odometry. Their map is the floor's tag
    survey (every plate, within the walls' bounding box), the robot map the scenario gives rfid_localizer over
    DDS."""
    name, run, seed = job
    floor = FLOORS[name]
    topological_map, world = load_topological_map(floor.map_path), load_world(floor.world_path)
    survey = load_scenario(name).nodes["rfid_localizer"].map_file
    assert survey is not None
    parameters = file_parameters(RfidLocalizerParameters, WALL_SIDE_LOCALIZER, "rfid_localizer",
                                 map_file=str(survey))
    riders = riders_for(name, run, seed, parameters.settings(), FusedMap.of_route_map(load_route_map(survey)))
    nodes = {node_name: node.position for node_name, node in topological_map.nodes.items()
             if node.position is not None}
    beside = TopologicalBeside(riders, parameters.wall_antenna, nodes)
    tag, goal = mission_tasks(topological_map, run + 1, seed)[run]
    result = run_mission(world, topological_map, start_pose_before_tag(world, tag), goal,
                         rng_for(seed, f"fused:{name}:{run}:mission"), observer=beside)
    return fused_run(name, run, result.success, riders, beside.paper, result.duration_s)


def route_run(job: tuple[str, int, int]) -> FusedRun:
    """One run of paper 001's hallway route (Figs. 12/13): the tag route follower steering by the ceiling tags'
    phase difference, the fused localizers beside on the same reader rounds and odometry. Their map is the
    hallway's tag survey in the scenario's robot map, as rfid_localizer has it over DDS: the ceiling tags and the
    floor tags under them, within the walls' bounding box."""
    name, run, seed = job
    scenario = load_scenario(name)
    parameters = file_parameters(RfidLocalizerParameters, UHF_2ANT_LOCALIZER, "rfid_localizer",
                                 map_file=str(scenario.map_file))
    assert scenario.route_map is not None
    riders = riders_for(name, run, seed, parameters.settings(), FusedMap.of_route_map(scenario.route_map))
    x, y, yaw_deg = scenario.robot
    beside = RouteBeside(riders, parameters.ports(), (x, y, math.radians(yaw_deg)))
    run_seed = derive_seed(seed, f"fused:{name}:{run}:route")
    result = run_tag_route(scenario, controller_parameters(scenario, None, run_seed), run_seed, observer=beside)
    return fused_run(name, run, result.success, riders, beside.paper, result.sim_duration_s)


def driving_run(job: tuple[str, int, int]) -> FusedRun:
    """One mission of ``mixed_floor_fused`` in-process: pose_navigator driving on the fused localizer's pose from
    the scenario's start to its goal, with the scenario's reader, WiFi scan period, navigator and localizer files.
    The localizer starts knowing only the map, as the node does."""
    name, run, seed = job
    place = home(name)
    rider = driving_rider(place, name, run, seed)
    navigation = file_parameters(PoseNavigatorParameters, place.scenario.nodes["pose_navigator"].param_files[0],
                                 "pose_navigator", map_file=str(place.scenario.map_file))
    start, target = mission_of(place)
    result = drive_on_fused(place.site, start, target, rider, localizer_parameters(place).ports(),
                            PoseNavigator(navigation.settings(), place.floor),
                            reader_parameters(place), rng_for(seed, f"fused:{name}:{run}:sensors"),
                            derive_seed(seed, f"fused:{name}:{run}:reader"), 1.0 / navigation.control_rate_hz,
                            scan_period_s(place), place.scenario.mission.timeout_s)
    return FusedRun(name, run, result.success, {"fused": TrackFigures.of(rider.track)},
                    rider.track.settled_after(0.0), None, None, result.duration_s, result.final_error_m)


def world_run(job: tuple[str, int, int]) -> FusedRun:
    if job[0] == DRIVING:
        return driving_run(job)
    if job[0] == PARTITION_DRIVING:
        return partition_driving_run(job)
    if job[0] in TIER_ONE:
        return tier_one_run(job)
    if job[0] == HALLWAY:
        return route_run(job)
    if job[0] == PARTITIONS:
        return partition_run(job)
    return topological_run(job) if job[0] == RING else home_run(job)


def fused_runs(runs: int, seed: int, worlds: Sequence[str] = WORLDS) -> list[FusedRun]:
    results = run_tasks(world_run, [(name, run, seed) for name in WORLDS if name in worlds for run in range(runs)],
                        "reproduce fused: worlds")
    return sorted(results, key=lambda r: (WORLDS.index(r.world), r.run))
