"""Several robots in one world (issue 35): a scenario's ``robots:``, each robot's nodes under its namespace with
seeds of its own, the one simulator's bases that stop at each other as at a wall, and the run plan that starts it
all. Pure tests (no process, no DDS); the runs over DDS are test_fleet_graph's."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_bringup.report import RunRecord, closest_approach
from rfidnav_bringup.run_plan import RunOptions, RunPlan
from rfidnav_common.errors import ConfigError, ParameterError
from rfidnav_common.frames import Frame, frame_prefix, prefixed
from rfidnav_common.seeding import robot_seed
from rfidnav_scenario.metrics import Trajectory
from rfidnav_scenario.scenario import injected_parameters, load_scenario, node_parameters, robot_action
from rfidnav_sim.kinematics import BaseLimits, DiffDriveBase, OdometryDrift, Pose2D
from rfidnav_sim.parameters import RobotSimParameters
from support.runs import scenario_document

pytestmark = pytest.mark.tier("unit")

DT = 0.01
LIMITS = BaseLimits(track_width_m=0.30, max_wheel_speed_mps=0.5, max_wheel_accel_mps2=1.0, command_timeout_s=0.5,
                    footprint_radius_m=0.17)


def base_at(x: float, y: float, yaw: float, seed: int = 0) -> DiffDriveBase:
    return DiffDriveBase(Pose2D(x, y, yaw), LIMITS, OdometryDrift(), np.random.default_rng(seed))


def test_two_bases_driving_at_each_other_stop_touching_and_press_their_bumpers() -> None:
    left, right = base_at(0.0, 0.0, 0.0), base_at(2.0, 0.0, math.pi)
    left.others, right.others = [right], [left]
    pressed = {"left": [], "right": []}
    for _ in range(round(6.0 / DT)):
        for name, base in (("left", left), ("right", right)):
            base.set_command(0.3, 0.0)
            pressed[name] += [event.event for event in base.step(DT) if event.active]
    gap = math.hypot(right.truth.x - left.truth.x, right.truth.y - left.truth.y)
    # Each stops where it would next overlap the other: footprints touching, never crossing.
    assert 2 * LIMITS.footprint_radius_m - 0.01 < gap < 2 * LIMITS.footprint_radius_m + 0.01
    assert pressed["left"] and pressed["right"]
    assert left.bumps >= 1 and right.bumps >= 1


def test_a_base_moving_away_from_one_it_touches_is_let_go() -> None:
    left, right = base_at(0.0, 0.0, 0.0), base_at(0.34, 0.0, 0.0)
    left.others, right.others = [right], [left]
    for _ in range(round(2.0 / DT)):
        right.set_command(0.3, 0.0)
        right.step(DT)
    assert right.truth.x > 0.6


def test_a_base_passes_another_beside_it_untouched() -> None:
    """Two bases side by side, 0.5 m apart, drive past each other in opposite directions: neither stalls."""
    north, south = base_at(-2.0, 0.25, 0.0), base_at(2.0, -0.25, math.pi)
    north.others, south.others = [south], [north]
    for _ in range(round(16.0 / DT)):
        for base in (north, south):
            base.set_command(0.3, 0.0)
            base.step(DT)
    assert north.truth.x > 2.0 and south.truth.x < -2.0 and north.bumps == south.bumps == 0


def simulator(**values) -> RobotSimParameters:
    return RobotSimParameters(world_file="world.yaml", **values)


def test_the_simulator_makes_a_base_per_robot_with_its_own_odometry_stream_and_the_others_as_obstacles() -> None:
    parameters = simulator(robots=["r1", "r2"], robot_starts=[0.0, 0.0, 0.0, 3.0, 1.0, 90.0], odom_slip_std=0.01,
                           seed=4)
    parameters.validate()
    bases = parameters.fleet()
    assert list(bases) == ["r1", "r2"]
    assert (bases["r2"].truth.x, bases["r2"].truth.y) == (3.0, 1.0)
    assert bases["r2"].truth.yaw == pytest.approx(math.pi / 2)
    assert bases["r1"].others == [bases["r2"]] and bases["r2"].others == [bases["r1"]]
    assert bases["r1"].slip() != bases["r2"].slip()
    # One robot, no names: the base of the root namespace, as before robots were.
    alone = simulator(start_x=1.0).fleet()
    assert list(alone) == [""] and alone[""].others == []
    assert [f.child for f in parameters.start_frames()] == ["r1/odom", "r2/odom"]


@pytest.mark.parametrize(("values", "field", "words"), [
    ({"robots": ["r1"], "robot_starts": [0.0, 0.0]}, "robot_starts", "2 values for 1 robots"),
    ({"robots": ["1r"], "robot_starts": [0.0, 0.0, 0.0]}, "robots", "no robot name"),
    ({"robots": ["r1", "r1"], "robot_starts": [0.0, 0.0, 0.0, 5.0, 0.0, 0.0]}, "robots", "given twice"),
    ({"robots": ["r1", "r2"], "robot_starts": [0.0, 0.0, 0.0, 0.2, 0.0, 0.0]}, "robot_starts", "overlapping"),
])
def test_robots_the_simulator_cannot_place_are_refused_naming_the_parameter(values, field, words) -> None:
    with pytest.raises(ParameterError) as caught:
        simulator(**values).validate()
    assert caught.value.field == field and words in str(caught.value)


def test_a_robots_frames_carry_its_namespace_and_the_map_is_shared() -> None:
    assert frame_prefix("/r1") == "r1/" and frame_prefix("/") == "" and frame_prefix("") == ""
    odom = prefixed(Frame.planar("map", "odom", (1.0, 2.0, 0.0)), "r1/")
    assert (odom.parent, odom.child) == ("map", "r1/odom")
    antenna = prefixed(Frame.mounted("base_link", "rfid_antenna_1", (0.1, 0.0, 0.2)), "r2/")
    assert (antenna.parent, antenna.child) == ("r2/base_link", "r2/rfid_antenna_1")
    assert prefixed(antenna, "") is antenna


def test_a_scenario_of_two_robots_runs_every_role_per_robot_but_the_simulator_and_the_shared() -> None:
    scenario = load_scenario("two_tier_flat_pair")
    instances = scenario.instances()
    assert instances["robot_sim"].robot is None and instances["location_server"].robot is None
    assert {key for key, spec in instances.items() if spec.robot == "r1"} == {
        "r1.rfid_reader", "r1.wifi", "r1.compass", "r1.two_tier_navigator"}
    assert instances["r2.two_tier_navigator"].fqn == "/r2/two_tier_navigator"
    assert [(robot, mission.action) for robot, mission in scenario.missions()] == [
        ("r1", "/r1/navigate_to_point"), ("r2", "/r2/navigate_to_point")]
    assert [mission.goal["target"]["x"] for _, mission in scenario.missions()] == [5.0, -5.5]
    assert scenario.mission_server("r2") == "r2.two_tier_navigator"
    assert {spec.fqn for spec in scenario.step_participants()} >= {"/location_server", "/r1/wifi_sim", "/r2/wifi_sim"}
    # Each robot's nodes draw from a seed of its own; the shared ones and the simulator from the run's.
    assert injected_parameters(scenario, instances["r1.rfid_reader"], 7, 1.0)["seed"] == robot_seed(7, "r1")
    assert robot_seed(7, "r1") != robot_seed(7, "r2")
    assert injected_parameters(scenario, instances["location_server"], 7, 1.0)["seed"] == 7
    simulator_values = node_parameters(scenario, instances["robot_sim"], 7, 1.0)
    assert simulator_values.robots == ["r1", "r2"]
    assert simulator_values.robot_starts == [-6.2, 0.0, 0.0, 3.5, -2.5, 180.0]
    assert robot_action("r1", "navigate_to_point") == robot_action("r1", "/navigate_to_point") == \
        "/r1/navigate_to_point"


def test_the_run_plan_starts_each_robots_nodes_in_its_namespace_with_files_only_they_read(tmp_path: Path) -> None:
    plan = RunPlan(load_scenario("building_ring_pair"), RunOptions(), tmp_path / "run")
    processes = {process.name: process.command for process in plan.write()}
    assert set(processes) == {"recorder", "simulator", "r1.wall_follower", "r2.wall_follower",
                              "r1.mission_executor", "r2.mission_executor"}
    follower = processes["r2.wall_follower"]
    assert follower[follower.index("-r") + 1] == "__ns:=/r2"
    container = processes["simulator"]
    assert "rfidnav_sim:sonar_sim@/r1" in container and "rfidnav_sim:rfid_reader_sim@/r2" in container
    assert "-r" not in container       # the namespace is each node's, not the whole process's
    file = yaml.safe_load((tmp_path / "run/params/r2.rfid_reader.yaml").read_text())
    assert list(file) == ["/r2/rfid_reader_sim"]
    assert "/r1/mission_executor" in plan.stepped_with and "/mission_executor" not in plan.stepped_with
    assert plan.expected_graph().nodes >= {"robot_sim", "r1/sonar_sim", "r2/wall_follower"}
    assert plan.mission_process("r1") == "r1.mission_executor"
    written = yaml.safe_load((tmp_path / "run/scenario.yaml").read_text())
    assert [robot["mission"]["goal"] for robot in written["robots"]] == [{"goal_node": "F"}, {"goal_node": "A"}]


def test_either_robots_reader_reads_a_tag_group_under_it_in_the_one_world() -> None:
    """Each robot's simulated reader reads the world's tags by its own robot's pose: the same tag group under r1 or
    under r2, and nothing under the one that is elsewhere."""
    scenario = load_scenario("two_tier_flat_pair")
    instances = scenario.instances()
    readers = {robot: node_parameters(scenario, instances[f"{robot}.rfid_reader"], 3, 1.0) for robot in ("r1", "r2")}
    group = next(g for g in scenario.world.tag_groups if g.group_id == "S2")
    under, elsewhere = (group.centre[0], group.centre[1], 0.0), (-6.2, 0.0, 0.0)

    def tags_read(robot: str, pose: tuple[float, float, float]) -> set[str]:
        reader = readers[robot].simulated_reader(scenario.world, readers[robot].seed)
        rounds = [reader.sample(pose, step * 0.02) for step in range(100)]
        return {read.tag_id for reads in rounds if reads for read in reads}

    assert tags_read("r1", under) and tags_read("r2", under)
    assert not tags_read("r1", elsewhere) & tags_read("r2", under)


def fleet_file(tmp_path: Path, change) -> str:
    document = scenario_document("two_tier_flat_pair")
    change(document)
    path = tmp_path / "fleet.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return str(path)


@pytest.mark.parametrize(("change", "field", "words"), [
    (lambda d: d["robots"][1].update(name="r1"), "robots[1].name", "listed twice"),
    (lambda d: d["robots"][0].update(name="robot one"), "robots[0].name", "no robot name"),
    (lambda d: d.update(robot={"x": 0.0, "y": 0.0}), "robot", "each robot gives its start"),
    (lambda d: d["robots"][1]["mission"]["goal"]["target"].update(x=40.0), "robots[1].mission.goal",
     "outside the map"),
    (lambda d: d["nodes"]["wifi"].update(shared=True), "nodes.wifi.shared", "runs per robot"),
    (lambda d: d["robots"][0].update(speed=1.0), "robots[0].speed", ""),
])
def test_a_bad_robot_entry_is_one_error_naming_its_field(tmp_path: Path, change, field, words) -> None:
    with pytest.raises(ConfigError) as caught:
        load_scenario(fleet_file(tmp_path, change))
    assert field in str(caught.value) and words in str(caught.value)


def test_a_shared_role_needs_robots_and_a_goal_from_the_command_line_is_refused_for_several(tmp_path: Path) -> None:
    document = scenario_document("two_tier_flat")
    document["nodes"]["location_server"]["shared"] = True
    single = tmp_path / "single.yaml"
    single.write_text(yaml.safe_dump(document))
    with pytest.raises(ConfigError, match="nodes.location_server.shared"):
        load_scenario(str(single))
    with pytest.raises(ConfigError, match="each gives its goal in its entry"):
        load_scenario("two_tier_flat_pair", goal={"target": {"x": 1.0, "y": 0.0, "z": 0.0}})


def test_a_robot_may_have_a_profile_of_its_own_that_changes_its_roles_only(tmp_path: Path) -> None:
    def real_reader_on_r2(document: dict) -> None:
        document["robots"][1]["profile"] = "sim_base_llrp"

    document = scenario_document("building_ring_pair")
    real_reader_on_r2(document)
    path = tmp_path / "ring.yaml"
    path.write_text(yaml.safe_dump(document))
    scenario = load_scenario(str(path))
    instances = scenario.instances()
    assert (instances["r1.rfid_reader"].package, instances["r2.rfid_reader"].package) == ("rfidnav_sim",
                                                                                          "rfidnav_drivers")
    assert instances["r2.rfid_reader"].robot == "r2" and instances["r2.rfid_reader"].fqn == "/r2/llrp_reader"
    assert instances["robot_sim"] == scenario.nodes["robot_sim"]
    # The driver runs free beside the stepped clock; r1's simulated reader still takes part.
    participants = {spec.fqn for spec in scenario.step_participants()}
    assert "/r1/rfid_reader_sim" in participants and "/r2/llrp_reader" not in participants
    plan = RunPlan(scenario, RunOptions(), tmp_path / "run")
    commands = {process.name: process.command for process in plan.write()}
    assert "r2.rfid_reader" in commands and "__ns:=/r2" in commands["r2.rfid_reader"]
    assert list(yaml.safe_load((tmp_path / "run/params/r2.rfid_reader.yaml").read_text())) == ["/r2/llrp_reader"]


@pytest.mark.parametrize(("profile", "words"), [
    ("create2_llrp", "replaces the simulated base"),
    ("no_such_profile", "no robot profile 'no_such_profile'"),
])
def test_a_robots_profile_that_would_change_the_world_or_does_not_exist_is_refused_at_its_entry(
        tmp_path: Path, profile: str, words: str) -> None:
    with pytest.raises(ConfigError) as caught:
        load_scenario(fleet_file(tmp_path, lambda d: d["robots"][0].update(profile=profile)))
    assert "robots[0].profile" in str(caught.value) and words in str(caught.value)


def track(robot: str, times: np.ndarray, xy: np.ndarray) -> RunRecord:
    return RunRecord(Path("run"), Path("run/bag"), None, [], Trajectory(times, xy), 0.0, float(times[-1]),  # type: ignore[arg-type]
                     "succeeded", [], [], {}, None, "/navigate_to_node", robot=robot)


def test_the_closest_approach_is_the_nearest_two_robots_came_at_one_time_not_along_their_paths() -> None:
    times = np.arange(0.0, 10.02, 0.02)
    east = track("r1", times, np.column_stack([times, np.zeros_like(times)]))            # (t, 0)
    # r2 crosses r1's path at x = 5 at t = 0 (r1 is 5 m away then); r3 runs beside r1, 1 m off, but only from t = 4.
    north = track("r2", times, np.column_stack([np.full_like(times, 5.0), times - 0.0]))
    beside = track("r3", times[200:], np.column_stack([times[200:], np.full(len(times) - 200, 1.0)]))
    approach = closest_approach([east, north])
    # |(t, 0) - (5, t)| is least at t = 2.5: 3.54 m, though the paths cross.
    assert approach["closest_approach_m"] == pytest.approx(math.hypot(2.5, 2.5), abs=1e-6)
    assert approach["closest_approach_at_s"] == pytest.approx(2.5) and approach["closest_pair"] == "r1, r2"
    everyone = closest_approach([east, north, beside])
    assert everyone["closest_approach_m"] == pytest.approx(1.0) and everyone["closest_pair"] == "r1, r3"
    assert closest_approach([east]) == {}
