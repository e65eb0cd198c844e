"""Bad input for paper 000's scenario: broken lattices, maps and parameters are one config error naming the file
and the field, before anything starts; the reader simulator reads a described lattice exactly."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_common.tag_lattice import decode_tag_id
from rfidnav_scenario.scenario import load_scenario
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.rfid_model import ReaderSimulator
from rfidnav_sim.world import load_world
from support.config_files import copy_config, edit
from support.runs import WORKSPACE, run_cli

pytestmark = pytest.mark.tier("unit")

CONFIG = WORKSPACE / "config"
SCENARIO = "scenarios/partition_field.yaml"
WORLD = "worlds/partition_field.yaml"
MAP = "maps/partition_field.yaml"
REFERENCED = (SCENARIO, WORLD, MAP, "params/robot_sim.yaml", "params/reader_floor_lattice.yaml",
              "params/partition_localizer_paper.yaml", "params/partition_navigator.yaml",
              "params/rfid_localizer_floor_lattice.yaml")
LATTICE = "{layout: triangular, read_range_m: 0.2, area: [0.0, 0.0, 5.0, 5.0]}"


@pytest.fixture
def config(tmp_path: Path) -> Path:
    return copy_config(tmp_path, REFERENCED)


CASES = {
    "zero read range": (WORLD, LATTICE, LATTICE.replace("0.2", "0.0"), "lattices[0].read_range_m", "positive"),
    "negative read range": (WORLD, LATTICE, LATTICE.replace("0.2", "-0.2"), "lattices[0].read_range_m", "positive"),
    "empty area": (WORLD, LATTICE, LATTICE.replace("5.0, 5.0]", "0.0, 5.0]"), "lattices[0].area", "x_max > x_min"),
    "NaN in the area": (WORLD, LATTICE, LATTICE.replace("5.0, 5.0]", ".nan, 5.0]"), "lattices[0].area[2]", "finite"),
    "unknown layout": (WORLD, LATTICE, LATTICE.replace("triangular", "hexagonal"), "lattices[0].layout", "hexagonal"),
    "unknown lattice field": (WORLD, LATTICE, LATTICE.replace("}", ", colour: red}"), "lattices[0].colour", "unknown"),
    "inverted deployment area": (MAP, "deployment_area: [0.0, 0.0, 5.0, 5.0]", "deployment_area: [5.0, 0.0, 0.0, 5.0]",
                                 "deployment_area", "max > min"),
    "goal off the deployment": (SCENARIO, "target: {x: 4.0,", "target: {x: 6.0,", "mission.goal", "outside"),
    "unknown localizer method": (
        "params/partition_localizer_paper.yaml", "method: paper ", "method: magic ",
        "partition_localizer.ros__parameters.method", "magic"),
    "unknown deviation check": (
        "params/partition_navigator.yaml", "deviation_check: partition", "deviation_check: vibes",
        "partition_navigator.ros__parameters.deviation_check", "vibes"),
}


def test_the_unbroken_copy_loads(config: Path) -> None:
    scenario = load_scenario(str(config / SCENARIO))
    assert scenario.route_map.deployment_area == (0.0, 0.0, 5.0, 5.0)
    assert scenario.world.deployments[0].tag_count() == 288
    assert scenario.mission.server == "partition_navigator"


@pytest.mark.parametrize("name", sorted(CASES))
def test_broken_file_is_one_config_error_naming_file_and_field(config: Path, name: str) -> None:
    relative, old, new, field, word = CASES[name]
    edit(config / relative, old, new)
    with pytest.raises(ConfigError) as caught:
        load_scenario(str(config / SCENARIO))
    error = caught.value
    assert Path(error.source).name == Path(relative).name, str(error)
    assert error.field == field, str(error)
    assert word in error.problem, str(error)


@pytest.mark.tier("graph")
def test_cli_run_of_a_broken_lattice_prints_one_line_and_starts_nothing(config: Path, tmp_path: Path) -> None:
    edit(config / WORLD, LATTICE, LATTICE.replace("0.2", "0.0"))
    out = tmp_path / "runs"
    result = run_cli("run", str(config / SCENARIO), "--out", str(out), timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "lattices[0].read_range_m" in lines[0] and "Traceback" not in result.stderr
    assert not out.exists() or not list(out.iterdir())


@pytest.mark.parametrize("layout", ["grid", "triangular", "compressed"])
def test_the_floor_antennas_read_exactly_the_lattice_tags_within_r(layout: str, tmp_path: Path) -> None:
    world_file = tmp_path / "world.yaml"
    world_file.write_text(f"name: w\nlattices:\n  - {{layout: {layout}, read_range_m: 0.2, area: [0, 0, 5, 5]}}\n")
    world = load_world(world_file)
    reader = ReaderParameters(world_file=str(world_file), antenna_positions=[0.0, 0.0, 0.05, 0.25, 0.0, 0.05,
                                                                             0.0, 0.0, 0.3],
                              antenna_facing=["down", "down", "up"], antenna_max_range_m=[0.1, 0.1, 12.0],
                              antenna_half_angle_deg=[60.0, 60.0, 85.0], antenna_phase_offset_rad=[0.0, 0.0, 0.0])
    simulator = ReaderSimulator.for_world(reader.reader_model(), world, np.random.default_rng(1))
    deployment = world.deployments[0]
    rng = np.random.default_rng(2)
    for x, y, yaw in zip(rng.uniform(0.3, 4.7, 50), rng.uniform(0.3, 4.7, 50), rng.uniform(-math.pi, math.pi, 50)):
        reads = simulator.inventory(x, y, yaw, 0.0)
        by_port: dict[int, set[tuple[int, int]]] = {1: set(), 2: set(), 3: set()}
        for read in reads:
            decoded = decode_tag_id(read.tag_id)
            assert decoded.layout == layout and 0.0 <= read.phase_rad < 2 * math.pi and math.isfinite(read.rssi_dbm)
            by_port[read.antenna].add(decoded.coordinate)
        assert by_port[1] == set(deployment.tags_reading(x, y)) and by_port[1]
        ahead = (x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw))
        assert by_port[2] == set(deployment.tags_reading(*ahead))
        assert by_port[3] == set()            # an upward antenna never reads floor tags


def test_reader_benchmark_reads_a_huge_described_floor() -> None:
    from rfidnav_experiments.bench.planner import reader_round_benchmark
    figures = reader_round_benchmark(rounds=50)
    assert figures["reader_tags"] > 860_000
    # At r = 2 cm and side r*sqrt(3) every point is read by 1 to 3 tags, about 1.2 on average.
    assert 1.0 <= figures["reader_tags_per_round"] <= 3.0
    assert figures["reader_round_us"] > 0.0


def test_the_localizer_takes_the_tagged_area_from_the_robot_map() -> None:
    """Positions come from the ids; the map's deployment_area only tells the filter where no tag can be."""
    from rfidnav_localization.parameters import PartitionLocalizerParameters
    assert PartitionLocalizerParameters().settings().deployment_area is None
    with_map = PartitionLocalizerParameters(map_file=str(CONFIG / MAP))
    assert with_map.settings().deployment_area == (0.0, 0.0, 5.0, 5.0)
    with pytest.raises(ConfigError, match="not found"):
        PartitionLocalizerParameters(map_file=str(CONFIG / "maps/nowhere.yaml")).settings()
