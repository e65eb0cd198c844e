"""In-process experiment runner: the scenario's core classes stepped in one loop, without DDS.

It uses the same world, map, parameter files, seeds and core classes (DiffDriveBase,
ReaderSimulator, TagRouteFollower, FuzzyHeadingController) as the node graph, and the same timing
rules (inventory rounds taken on the ground-truth samples), so a run here differs from ``./rfidnav
run`` only by the DDS graph's latency. ``./rfidnav reproduce flc`` runs hundreds of these.

Scoring (rfidnav_scenario.metrics): the stretch from the robot's entry (ground truth) into the first tag's read area
to its entry into the last one's, the read area being where the reader's floor antenna reads a floor tag
(:func:`floor_read_radius_m`), so two controllers in the same conditions are scored over the same stretch.

One open setting of paper 001 lives here, in-process only: how its eq. 3 (theta_new = theta_old + dtheta) becomes a
command (``heading_update``). ``rate``, the heading_controller node's: the yaw rate that turns the robot by dtheta
over the round, clipped at max_yaw_rate_radps. ``setpoint``: dtheta moves a heading reference, theta_ref +=
dtheta, and the base turns towards it (the wheel odometry's heading) at up to max_yaw_rate_radps, so a turn the
cap holds back is still made later (the reference winds up). The node has no such mode.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_control.fuzzy import FuzzyHeadingController
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import SEARCH_MODES, TagRouteFollower, observe
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_scenario.metrics import (
    TrackingMetrics,
    Trajectory,
    flagged_spans,
    ground_truth_objection,
    success_verdict,
    tracking_metrics,
)
from rfidnav_scenario.scenario import Scenario, node_parameters
from rfidnav_sim.parameters import ReaderParameters, RobotSimParameters
from rfidnav_sim.rfid_model import Read, reach_m
from rfidnav_sim.rig import Rig, steps_per_sample


@dataclass(frozen=True)
class RouteRun:
    scenario: str
    seed: int
    success: bool
    message: str
    sim_duration_s: float
    metrics: TrackingMetrics
    trajectory: Trajectory
    arrival_times_s: tuple[float, ...]


@dataclass(frozen=True)
class RouteRound:
    """What the robot's sensors gave in one reader round (an observer's view; ``truth`` is for scoring only)."""
    time_s: float
    odom: tuple[float, float, float]        # the wheel odometry pose, odom frame (the start pose at 0)
    reads: Sequence[Read]
    truth: tuple[float, float, float]


def role_parameters(scenario: Scenario, executable: str, seed: int):
    for spec in scenario.nodes.values():
        if spec.executable == executable:
            return node_parameters(scenario, spec, seed=seed, rtf=1.0)
    raise KeyError(f"scenario {scenario.name} has no {executable} node")


def controller_parameters(scenario: Scenario, params_file: Path | None, seed: int) -> HeadingControllerParameters:
    if params_file is None:
        return role_parameters(scenario, "heading_controller", seed)
    return file_parameters(HeadingControllerParameters, params_file, "heading_controller", "heading_controller",
                           map_file=str(scenario.map_file))


HEADING_UPDATES = ("rate", "setpoint")
READER = "rfid_reader_sim"      # the rig's reader, named after the node it stands for


def floor_read_radius_m(reader: ReaderParameters, controller: HeadingControllerParameters) -> float:
    """How far from a floor tag (on the floor) the controller's floor antenna reads it: a route tag's read area."""
    model = reader.reader_model()
    return reach_m(model, model.antennas[controller.floor_antenna - 1], 0.0)


def tag_points(scenario: Scenario, route: list[str]) -> np.ndarray:
    """Ground projections of the route's tags (ground truth: for metrics only)."""
    return np.array([scenario.world.tag(tag_id).position[:2] for tag_id in route], dtype=float)


def run_tag_route(scenario: Scenario, controller: HeadingControllerParameters, seed: int,
                  reader: ReaderParameters | None = None, timeout_s: float | None = None,
                  command_delay_s: float = 0.0, observer: Callable[[RouteRound], None] | None = None,
                  heading_update: str = "rate") -> RouteRun:
    """One run of the scenario's route, in-process and in lockstep.

    ``command_delay_s`` applies each command that much sim time after the round it answers: the latency of
    reads -> controller -> /cmd_vel over DDS, which at a high RTF on a loaded machine spans several rounds.
    ``observer`` is shown each reader round (a localizer riding beside the follower: reproduce fused).
    ``heading_update``: how dtheta becomes a yaw rate (module docstring; ``rate`` is the node's)."""
    if heading_update not in HEADING_UPDATES:
        raise ValueError(f"heading_update '{heading_update}' is not one of {', '.join(HEADING_UPDATES)}")
    robot: RobotSimParameters = role_parameters(scenario, "robot_sim", seed)
    reader = reader or role_parameters(scenario, "rfid_reader_sim", seed)
    world = scenario.world
    rig = Rig(robot.base(world.wall_segments()), robot.step_s, steps_per_sample(robot.step_s, robot.odom_rate_hz),
              {READER: reader.simulated_reader(world, seed)}, command_delay_s)
    follower = TagRouteFollower(controller.follower_settings(), FuzzyHeadingController(controller.fuzzy_spec()),
                                scenario.route_map.arrival_tags)
    route = list(scenario.mission.goal["tag_ids"])
    follower.start(route, 0.0)
    limit_s = timeout_s if timeout_s is not None else scenario.mission.timeout_s
    round_period_s = 1.0 / reader.rate_hz
    arrivals: list[float] = []
    round_times: list[float] = []
    searching: list[bool] = []              # each round's command a search's (the feedback's mode over DDS)
    success, message, now = False, "timeout", 0.0
    reference: float | None = None          # heading_update "setpoint": theta_ref of eq. 3, unwrapped [rad]
    heading, last_yaw = 0.0, rig.base.odom.yaw  # the odometry's heading, unwrapped [rad]
    while now < limit_s:
        sample = rig.advance()
        now = sample.time_s
        reads = sample.readings.get(READER)
        if reads is None:
            continue
        if observer is not None:
            observer(RouteRound(now, sample.odom, reads, sample.truth))
        command = follower.step(now, [o for o in map(observe, reads) if o is not None])
        if command.arrived_index is not None:
            arrivals.append(now)
        round_times.append(now)
        searching.append(command.mode in SEARCH_MODES)
        if heading_update == "setpoint":
            odom_yaw = sample.odom[2]
            heading, last_yaw = heading + wrap_angle(odom_yaw - last_yaw), odom_yaw
            if command.mode == "seeking":
                reference = (heading if reference is None else reference) + command.heading_change_rad
                cap = controller.max_yaw_rate_radps
                turn = min(max((reference - heading) / round_period_s, -cap), cap)
                command = dataclasses.replace(command, angular_radps=turn)
            else:
                reference = None
        rig.command(command.linear_mps, command.angular_radps, now)
        if command.failure:
            message = command.failure
            break
        if follower.finished:
            success, message = True, f"reached all {len(route)} tags"
            break
    trajectory = Trajectory(*rig.track())
    metrics = tracking_metrics(trajectory, tag_points(scenario, route), arrivals, 0.0, now,
                               read_radius_m=floor_read_radius_m(reader, controller),
                               searching=flagged_spans(round_times, searching, now))
    objection = ground_truth_objection(success_verdict(metrics.as_dict(), scenario.mission.success_within_m))
    if success and objection is not None:
        success, message = False, f"{message}; but it {objection}"
    return RouteRun(scenario.name, seed, success, message, now, metrics, trajectory, tuple(arrivals))
