"""reproduce partitions: the configurations, read ranges, levels, counts and seeds, the nodes' parameter files each
configuration runs from, and the tag deployments of the field."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

from rfidnav_common.tag_lattice import Deployment, make_deployment
from rfidnav_experiments.evaluation import current
from rfidnav_experiments.runners.partitions import RobotSpeeds
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_localization.parameters import PartitionLocalizerParameters
from rfidnav_localization.partition import LocalizerSettings
from rfidnav_planning.parameters import PartitionNavigatorParameters
from rfidnav_planning.partition_navigation import NavigatorSettings
from rfidnav_scenario.scenario import CONFIG_DIR

EXPERIMENT = "partitions"
FIELD = (0.0, 0.0, 5.0, 5.0)
NAVIGATION_RANGES_M = (0.02, 0.2, 0.5)
LEVELS = tuple(range(1, 9))
FILTER_LEVELS = (1, 2, 4, 8)   # ours on a log grid of the levels: the whole grid would add ~40 % runtime
DISTANCES_M = (1.0, 2.0, 3.0, 4.0, 5.0)
PAPER, FILTER, ABLATION = "paper", "filter", "filter_boom_spin"
METHODS = (PAPER, FILTER, ABLATION)
# (localizer file, navigator file) in config/params, as the nodes run them.
METHOD_FILES = {
    PAPER: ("partition_localizer_paper.yaml", "partition_navigator.yaml"),
    FILTER: ("partition_localizer_filter_paper_robot.yaml", "partition_navigator_filter_paper_robot.yaml"),
    ABLATION: ("partition_localizer_filter.yaml", "partition_navigator_filter.yaml"),
}
RUNS_PER_CURVE = 250
# The filter and both navigators were developed and tuned on the tasks of seed 1 (every run of this reproduction
# before issue 14, and the tests'); the reported figures come from seed 101's tasks, chosen once and never tuned on.
DEVELOPMENT_SEED = 1
EVALUATION_SEED = current("partitions").seeds[0]   # the ledger's (rfidnav_experiments.evaluation)
ODOMETRY_NOISE = 0.0           # exact odometry: the simulated motion is exact (paper 000 section 6.2)
COUNT_AREAS_M = (5, 10, 15, 20, 25, 30)
COUNT_RANGE_M = 0.2
ACCURACY_RANGES_M = (0.02, 0.05, 0.1, 0.2, 0.5)
ACCURACY_SAMPLES = 500
FIG11_RANGE_M = 0.02
FIG11_PARTITIONS = tuple(range(1, 13))
FIG11_RUNS = 250
TRAJECTORY_RANGE_M = 0.2       # the plotted example task
TRAJECTORY_DISTANCE_M = 3.0
# What paper 000 states in its text (the figures themselves are not in the text).
PAPER_BAND_2CM_PCT = (2.0, 6.0)
PAPER_SAVED_PCT = {"triangular": 31.0, "compressed": 9.0}
# Issue 14's targets for the filter on the paper's robot, rotation charged: at most 1 % at r = 2 cm, at most half
# the paper method's at 20 and 50 cm.
TARGET_2CM_PCT = 1.0
TARGET_FRACTION = 0.5


def params_path(name: str) -> Path:
    return CONFIG_DIR / "params" / name


@functools.cache
def localizer_parameters(method: str) -> PartitionLocalizerParameters:
    return file_parameters(PartitionLocalizerParameters, params_path(METHOD_FILES[method][0]), "partition_localizer")


@functools.cache
def navigator_parameters(method: str) -> PartitionNavigatorParameters:
    path = params_path(METHOD_FILES[method][1])
    return file_parameters(PartitionNavigatorParameters, path, "partition_navigator", map_file=str(path))


@functools.cache
def localizer_settings(method: str) -> LocalizerSettings:
    """The localizer as the node runs it from the method's file; the in-process robot is built with the antenna
    where this localizer believes it is."""
    settings = localizer_parameters(method).settings()
    return dataclasses.replace(settings, deployment_area=FIELD)   # the robot's map: where the floor is tagged


@functools.cache
def navigator_settings(method: str, level: int) -> NavigatorSettings:
    """The navigator as the node runs it beside that localizer, at approximation level ``level``."""
    return dataclasses.replace(navigator_parameters(method).settings(), approximation_level=level)


def robot_speeds(method: str) -> RobotSpeeds:
    return RobotSpeeds.of(navigator_parameters(method))


def headline_level() -> int:
    """The level the nodes run at (the paper navigator file's N), where the three configurations are compared."""
    return navigator_parameters(PAPER).approximation_level


def method_levels(method: str) -> tuple[int, ...]:
    """The paper's method at every level of Figs. 12-14; the filter at FILTER_LEVELS (the headline's among them);
    the ablation at the headline level only. Each run of the filter costs about twice the paper method's."""
    if method == ABLATION:
        return (headline_level(),)
    if method == FILTER:
        return tuple(level for level in LEVELS if level in FILTER_LEVELS or level == headline_level())
    return LEVELS


_deployments: dict[tuple[float, str], Deployment] = {}


def deployment(read_range_m: float, layout: str = "triangular") -> Deployment:
    key = (read_range_m, layout)
    if key not in _deployments:
        _deployments[key] = make_deployment(layout, read_range_m, FIELD)
    return _deployments[key]
