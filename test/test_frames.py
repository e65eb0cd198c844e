"""The robot's frames as plain data (REP 105): poses composed and inverted, map -> odom from an estimate, and
the mounting frames sensor nodes publish from their parameters."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rfidnav_common.config import node_parameter_values, parameters_from_mapping
from rfidnav_common.errors import ParameterError
from rfidnav_common.frames import Frame, compose, inverse, map_to_odom, rpy_to_quaternion
from rfidnav_drivers.parameters import LlrpReaderParameters
from rfidnav_sim.parameters import CompassParameters, ReaderParameters, RobotSimParameters, SonarParameters

pytestmark = pytest.mark.tier("unit")

poses = st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-math.pi, math.pi))


def rotate(quaternion: tuple[float, float, float, float], vector: np.ndarray) -> np.ndarray:
    x, y, z, w = quaternion
    u = np.array([x, y, z])
    return 2 * u.dot(vector) * u + (w * w - u.dot(u)) * vector + 2 * w * np.cross(u, vector)


def close(a: tuple[float, float, float], b: tuple[float, float, float]) -> bool:
    return math.dist(a[:2], b[:2]) < 1e-9 and abs(math.remainder(a[2] - b[2], 2 * math.pi)) < 1e-9


@given(poses, poses)
def test_map_to_odom_composed_with_the_odometry_gives_the_estimate_back(estimate, odometry) -> None:
    assert close(compose(map_to_odom(estimate, odometry), odometry), estimate)


@given(poses)
def test_a_pose_composed_with_its_inverse_is_the_identity(pose) -> None:
    assert close(compose(pose, inverse(pose)), (0.0, 0.0, 0.0))


def test_a_pitch_of_minus_90_degrees_points_the_x_axis_up_and_a_yaw_turns_it_left() -> None:
    np.testing.assert_allclose(rotate(rpy_to_quaternion(0, -math.pi / 2, 0), np.array([1.0, 0, 0])), [0, 0, 1],
                               atol=1e-12)
    np.testing.assert_allclose(rotate(rpy_to_quaternion(0, 0, math.pi / 2), np.array([1.0, 0, 0])), [0, 1, 0],
                               atol=1e-12)


def test_the_readers_antennas_hang_under_its_frame_at_their_positions_along_their_boresights() -> None:
    frames = ReaderParameters(world_file="w.yaml").antenna_frames()
    assert [(f.parent, f.child) for f in frames] == [("base_link", f"rfid_antenna_{port}") for port in (1, 2, 3)]
    assert [f.translation for f in frames] == [(0.0, 0.03, 0.30), (0.0, -0.03, 0.30), (0.0, 0.0, 0.05)]
    boresights = [rotate(f.rotation, np.array([1.0, 0, 0])) for f in frames]
    np.testing.assert_allclose(boresights, [[0, 0, 1], [0, 0, 1], [0, 0, -1]], atol=1e-12)   # up, up, down


def test_every_sonar_has_a_frame_looking_along_its_bearing() -> None:
    frames = {f.child: f for f in SonarParameters(world_file="w.yaml").frames()}
    assert len(frames) == 7 and {"sonar_front", "sonar_left", "sonar_right"} <= set(frames)
    np.testing.assert_allclose(rotate(frames["sonar_left"].rotation, np.array([1.0, 0, 0])), [0, 1, 0], atol=1e-12)


def test_the_compass_has_its_own_frame_unless_it_reports_in_base_link() -> None:
    assert [f.child for f in CompassParameters().frames()] == ["compass"]
    assert CompassParameters(frame_id="base_link").frames() == []


def test_the_start_pose_places_odom_in_the_map() -> None:
    frame = RobotSimParameters(world_file="w.yaml", start_x=-2.0, start_y=1.0, start_yaw_deg=90.0).start_frame()
    assert (frame.parent, frame.child, frame.translation) == ("map", "odom", (-2.0, 1.0, 0.0))
    np.testing.assert_allclose(rotate(frame.rotation, np.array([1.0, 0, 0])), [0, 1, 0], atol=1e-12)


@pytest.mark.parametrize("parent, child, translation", [("base_link", "base_link", (0, 0, 0)),
                                                        ("", "x", (0, 0, 0)),
                                                        ("base_link", "x", (math.nan, 0, 0))])
def test_a_frame_without_two_names_or_with_a_non_finite_value_is_refused(parent, child, translation) -> None:
    with pytest.raises(ValueError, match="frame"):
        Frame(parent, child, translation)


def test_the_llrp_driver_and_the_simulated_reader_put_the_shipped_robots_antennas_in_the_same_frames() -> None:
    """One robot, two readers: what a real run publishes on /tf_static is what the simulator publishes."""
    config = Path(__file__).resolve().parents[1] / "config" / "params"
    driver = parameters_from_mapping(LlrpReaderParameters, node_parameter_values(
        LlrpReaderParameters, config / "llrp_reader.yaml", "llrp_reader"), "llrp_reader.yaml")
    simulated = parameters_from_mapping(ReaderParameters, {**node_parameter_values(
        ReaderParameters, config / "reader_uhf_2ant.yaml", "rfid_reader_sim"), "world_file": "w.yaml"},
        "reader_uhf_2ant.yaml")
    assert driver.antenna_frames() == simulated.antenna_frames()
    assert [f.child for f in driver.antenna_frames()] == ["rfid_antenna_1", "rfid_antenna_2", "rfid_antenna_3"]


def test_the_driver_publishes_the_frames_of_the_ports_it_inventories_that_it_can_place() -> None:
    assert [f.child for f in LlrpReaderParameters(antennas=[3]).antenna_frames()] == ["rfid_antenna_3"]
    four_ports = LlrpReaderParameters(antennas=[1, 4])      # a fourth antenna the file does not place
    four_ports.validate()
    assert [f.child for f in four_ports.antenna_frames()] == ["rfid_antenna_1"]
    assert four_ports.undescribed_ports() == [4]
    with pytest.raises(ParameterError, match="antenna_positions"):
        LlrpReaderParameters(antenna_positions=[0.0, 0.0]).validate()
