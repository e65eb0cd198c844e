"""Every read a simulated reader reports passes every consumer's input check (rfidnav_common.inputs.tag_read), at
the poses that test the model hardest: each antenna right over each tag it can read. Before the receiver
saturated (``max_rssi_dbm``), the HF floor reader reported up to +50.7 dBm 2 mm from a tag, and every consumer
dropped these, the closest and best reads (12-21 % of a two-tier run's reads over DDS; none in-process)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time

from rfidnav_common import inputs
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_scenario.scenario import load_scenario
from rfidnav_sim.conversions import reads_message
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.world import World
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

SCENARIOS = sorted(path.stem for path in (WORKSPACE / "config" / "scenarios").glob("*.yaml"))
YAWS = (0.0, 1.3, 2.9, -2.2)


def tag_points(world: World) -> list[tuple[float, float]]:
    """Where on the floor plan the world's tags are: listed tags, wall tags (a few cm out from the wall, where the
    side antenna's area begins) and the corners and centre of each lattice deployment's area."""
    points = [(tag.position[0], tag.position[1]) for tag in world.tags]
    points += [(tag.position[0] + 0.05 * tag.normal[0], tag.position[1] + 0.05 * tag.normal[1])
               for tag in world.wall_tags]
    for deployment in world.deployments:
        x_min, y_min, x_max, y_max = deployment.area
        points += [(x_min, y_min), (x_max, y_max), ((x_min + x_max) / 2, (y_min + y_max) / 2)]
    return points


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_read_of_the_simulated_reader_passes_the_consumers_input_check(name: str) -> None:
    scenario = load_scenario(name)
    spec = scenario.nodes.get("rfid_reader")
    if spec is None or not spec.sim:
        pytest.skip(f"{name} has no simulated reader")
    params = file_parameters(ReaderParameters, Path(spec.param_files[-1]), "rfid_reader_sim",
                             world_file=str(scenario.world_file), **spec.overrides)
    simulator = params.simulated_reader(scenario.world, seed=1).simulator
    antennas = np.reshape(params.antenna_positions, (-1, 3))[:, :2]
    reads = 0
    strongest = -math.inf
    for x, y in tag_points(scenario.world):
        for yaw in YAWS:
            cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
            for ax, ay in antennas:          # the robot placed with this antenna right over the point
                robot_x, robot_y = x - (cos_yaw * ax - sin_yaw * ay), y - (sin_yaw * ax + cos_yaw * ay)
                message = reads_message(simulator.inventory(robot_x, robot_y, yaw, 0.0), Time(), params.frame_id)
                for index, reading in enumerate(message.readings):
                    inputs.tag_read(reading, f"{name}: readings[{index}]", required=())
                    strongest = max(strongest, reading.rssi_dbm)
                reads += len(message.readings)
    assert reads > 0, f"{name}: the reader read nothing over any tag"
    assert strongest <= params.max_rssi_dbm
