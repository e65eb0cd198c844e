"""Differential-drive base: straight and turning motion, wheel speed and acceleration limits, command timeout,
and wheel odometry with and without systematic drift. Pure-module tests with numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_sim.kinematics import BaseLimits, DiffDriveBase, OdometryDrift, Pose2D
from support.reference_cores import ReferenceBase

pytestmark = pytest.mark.tier("unit")

DT = 0.01
LIMITS = BaseLimits(track_width_m=0.30, max_wheel_speed_mps=0.5, max_wheel_accel_mps2=1.0, command_timeout_s=0.5)


def make_base(start: Pose2D | None = None, drift: OdometryDrift | None = None, limits: BaseLimits = LIMITS,
              seed: int = 0) -> DiffDriveBase:
    return DiffDriveBase(start or Pose2D(), limits, drift or OdometryDrift(), np.random.default_rng(seed))


def drive(base: DiffDriveBase, linear: float, angular: float, duration_s: float) -> None:
    """Re-send the command every step (as a controller does), for ``duration_s``."""
    for _ in range(round(duration_s / DT)):
        base.set_command(linear, angular)
        base.step(DT)


def angle_difference(a: float, b: float) -> float:
    return math.remainder(a - b, 2.0 * math.pi)


@pytest.mark.parametrize("speed", [0.1, 0.2, 0.4, -0.3])
@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.8])
def test_straight_motion_covers_v_times_t_after_acceleration(speed, yaw):
    base = make_base(Pose2D(1.0, -2.0, yaw))
    ramp_s = abs(speed) / LIMITS.max_wheel_accel_mps2
    drive(base, speed, 0.0, ramp_s + 0.1)
    assert base.velocity[0] == pytest.approx(speed, abs=1e-12)
    before = (base.truth.x, base.truth.y)
    drive(base, speed, 0.0, 3.0)
    travelled = math.dist(before, (base.truth.x, base.truth.y))
    assert travelled == pytest.approx(abs(speed) * 3.0, rel=1e-9)
    # Along the heading (backwards for a negative speed), never sideways, never turning.
    direction = (math.cos(yaw), math.sin(yaw))
    along = (base.truth.x - before[0]) * direction[0] + (base.truth.y - before[1]) * direction[1]
    assert along == pytest.approx(speed * 3.0, rel=1e-9)
    assert base.truth.yaw == pytest.approx(yaw, abs=1e-12)


def test_total_distance_includes_the_acceleration_lag():
    base = make_base()
    speed, duration = 0.2, 5.0
    drive(base, speed, 0.0, duration)
    # A linear ramp at a to v covers v^2/(2a) less than v*t would.
    expected = speed * duration - speed ** 2 / (2.0 * LIMITS.max_wheel_accel_mps2)
    assert base.truth.x == pytest.approx(expected, abs=1e-9)
    assert base.distance_travelled_m == pytest.approx(expected, abs=1e-9)
    assert base.truth.y == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("angular", [1.0, -0.7, 3.0])
def test_pure_rotation_turns_in_place(angular):
    base = make_base(Pose2D(2.0, 3.0, 0.5))
    drive(base, 0.0, angular, 1.5)
    assert (base.truth.x, base.truth.y) == pytest.approx((2.0, 3.0), abs=1e-12)
    v, w = base.velocity
    assert v == pytest.approx(0.0, abs=1e-12)
    wheel = abs(angular) * LIMITS.track_width_m / 2.0
    expected_w = math.copysign(min(wheel, LIMITS.max_wheel_speed_mps) * 2.0 / LIMITS.track_width_m, angular)
    assert w == pytest.approx(expected_w, rel=1e-9)
    # Turned w * t less the half of the wheels' ramp time lost to acceleration.
    ramp_s = min(wheel, LIMITS.max_wheel_speed_mps) / LIMITS.max_wheel_accel_mps2
    expected_turn = expected_w * (1.5 - ramp_s / 2.0)
    # (a ramp time that is not a whole number of steps is off by at most a fraction of one step)
    assert angle_difference(base.truth.yaw, 0.5 + expected_turn) == pytest.approx(0.0, abs=1e-3)
    assert base.distance_travelled_m == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("linear, angular", [(1.0, 2.0), (0.8, -1.0), (-0.9, 0.5), (0.3, 6.0)])
def test_wheel_speed_limit_keeps_the_commanded_curvature(linear, angular):
    base = make_base()
    drive(base, linear, angular, 3.0)
    v, w = base.velocity
    assert max(abs(base.left_speed), abs(base.right_speed)) == pytest.approx(LIMITS.max_wheel_speed_mps)
    assert abs(v) < abs(linear)
    assert w / v == pytest.approx(angular / linear, rel=1e-9)


def test_command_within_the_limits_is_followed_exactly():
    base = make_base()
    drive(base, 0.2, 0.5, 2.0)
    assert base.velocity == pytest.approx((0.2, 0.5), rel=1e-9)


def test_acceleration_limit():
    base = make_base()
    speeds = []
    for _ in range(60):
        base.set_command(0.5, 0.0)
        base.step(DT)
        speeds.append(base.velocity[0])
    step_change = LIMITS.max_wheel_accel_mps2 * DT
    assert np.all(np.diff(speeds) <= step_change + 1e-12)
    assert speeds[0] == pytest.approx(step_change)
    assert speeds[9] == pytest.approx(10 * step_change)
    assert speeds[-1] == pytest.approx(0.5)
    # Braking is limited too: a reversal takes (0.5 + 0.5) / a = 1 s.
    for _ in range(50):
        base.set_command(-0.5, 0.0)
        base.step(DT)
    assert base.velocity[0] == pytest.approx(0.0, abs=1e-9)


def test_command_timeout_stops_the_base():
    base = make_base()
    drive(base, 0.2, 0.3, 1.0)
    assert base.velocity == pytest.approx((0.2, 0.3), rel=1e-9)
    # Commands stop: the base keeps going for the timeout, then brakes to a halt.
    for _ in range(round(0.4 / DT)):
        base.step(DT)
    assert base.velocity == pytest.approx((0.2, 0.3), rel=1e-9)
    for _ in range(round((0.1 + 0.3 + 0.1) / DT)):
        base.step(DT)
    assert base.velocity == pytest.approx((0.0, 0.0), abs=1e-12)
    stopped = (base.truth.x, base.truth.y, base.truth.yaw)
    for _ in range(100):
        base.step(DT)
    assert (base.truth.x, base.truth.y, base.truth.yaw) == stopped
    # A new command moves it again.
    drive(base, 0.2, 0.0, 0.5)
    assert base.velocity[0] == pytest.approx(0.2)


def test_no_command_ever_means_no_motion():
    base = make_base(Pose2D(1.0, 1.0, 1.0))
    for _ in range(100):
        base.step(DT)
    assert (base.truth.x, base.truth.y, base.truth.yaw) == (1.0, 1.0, 1.0)


def wiggly_drive(base: DiffDriveBase) -> None:
    for linear, angular, duration in ((0.2, 0.0, 2.0), (0.2, 0.8, 1.5), (0.1, -1.2, 2.0), (0.0, 2.0, 1.0),
                                      (0.3, 0.2, 2.0), (-0.2, 0.0, 1.0)):
        drive(base, linear, angular, duration)


@pytest.mark.parametrize("start", [Pose2D(0.0, 0.0, 0.0), Pose2D(-5.0, -5.0, math.pi / 2), Pose2D(3.0, 1.0, -2.0)])
def test_odometry_equals_truth_without_drift(start):
    base = make_base(Pose2D(start.x, start.y, start.yaw))
    wiggly_drive(base)
    # Odometry starts at the origin of the odom frame, which is the start pose in the map (REP 105).
    dx, dy = base.truth.x - start.x, base.truth.y - start.y
    c, s = math.cos(start.yaw), math.sin(start.yaw)
    in_odom = (c * dx + s * dy, -s * dx + c * dy)
    assert (base.odom.x, base.odom.y) == pytest.approx(in_odom, abs=1e-9)
    assert angle_difference(base.odom.yaw, base.truth.yaw - start.yaw) == pytest.approx(0.0, abs=1e-9)
    assert math.hypot(*in_odom) > 0.5   # it did move


@pytest.mark.parametrize("error", [0.01, -0.02])
def test_left_wheel_scale_error_bends_odometry_to_the_expected_side(error):
    base = make_base(drift=OdometryDrift(left_scale_error=error))
    distance = 2.0
    drive(base, 0.2, 0.0, distance / 0.2 + 0.1)
    travelled = base.truth.x
    assert base.truth.y == pytest.approx(0.0, abs=1e-12)
    # Over-reported left travel reads as a right (CW) turn: odometry yaw -e*D/track and a path bent to -y.
    expected_yaw = -error * travelled / LIMITS.track_width_m
    assert base.odom.yaw == pytest.approx(expected_yaw, rel=1e-6)
    assert math.copysign(1.0, base.odom.y) == -math.copysign(1.0, error)
    # Constant-curvature arc: y = (1 - cos(yaw)) * D' / yaw with D' = (1 + e/2) * D.
    arc = (1.0 + error / 2.0) * travelled
    assert base.odom.y == pytest.approx(arc * (1.0 - math.cos(expected_yaw)) / expected_yaw, rel=1e-6)


def test_right_wheel_scale_error_bends_odometry_left():
    base = make_base(drift=OdometryDrift(right_scale_error=0.01))
    drive(base, 0.2, 0.0, 10.0)
    assert base.odom.yaw > 0.0
    assert base.odom.y > 0.0
    assert base.odom.x == pytest.approx(base.truth.x * 1.005, rel=1e-3)


def test_track_width_error_scales_the_odometry_turn():
    base = make_base(drift=OdometryDrift(track_scale_error=0.05))
    drive(base, 0.0, 1.0, 1.0)
    turned = base.truth.yaw
    assert turned > 0.5
    assert base.odom.yaw == pytest.approx(turned / 1.05, rel=1e-9)


def test_slip_makes_odometry_wander_reproducibly():
    drift = OdometryDrift(slip_std=0.01)
    first, second, other = make_base(drift=drift, seed=1), make_base(drift=drift, seed=1), make_base(drift=drift,
                                                                                                      seed=2)
    for base in (first, second, other):
        wiggly_drive(base)
    assert (first.odom.x, first.odom.y, first.odom.yaw) == (second.odom.x, second.odom.y, second.odom.yaw)
    assert (first.odom.x, first.odom.y) != (other.odom.x, other.odom.y)
    # Truth does not depend on the odometry noise.
    assert (first.truth.x, first.truth.y) == (other.truth.x, other.truth.y)


# ------------------------------------------------------------------------------------------ walls

WALL_AHEAD = np.array([[1.0, -2.0, 1.0, 2.0]])       # a wall across the way at x = 1


def base_among(walls: np.ndarray, start: Pose2D) -> DiffDriveBase:
    return DiffDriveBase(start, LIMITS, OdometryDrift(), np.random.default_rng(0), walls)


def drive_recording(base: DiffDriveBase, linear: float, angular: float, duration_s: float) -> list:
    """``drive``, returning the base's /base/event records."""
    events = []
    for _ in range(round(duration_s / DT)):
        base.set_command(linear, angular)
        events += base.step(DT)
    return events


def test_a_base_driving_at_a_wall_stops_at_its_footprint_and_presses_both_bumpers() -> None:
    base = base_among(WALL_AHEAD, Pose2D())
    events = drive_recording(base, 0.3, 0.0, 6.0)
    radius = LIMITS.footprint_radius_m
    assert base.truth.x == pytest.approx(1.0 - radius, abs=0.01)
    assert base.truth.x <= 1.0 - radius
    assert [(e.event, e.active, e.action) for e in events] == [("bump_left", True, "forward_blocked"),
                                                              ("bump_right", True, "forward_blocked")]
    assert base.bumps == 1
    assert base.odom.x == pytest.approx(base.truth.x, abs=0.01)   # stalled wheels count nothing more


def test_a_wall_touched_on_the_left_presses_only_the_left_bumper_and_turning_away_releases_it() -> None:
    # Heading 60 degrees left of the wall's normal: the wall is met 60 degrees to the right of straight ahead.
    base = base_among(WALL_AHEAD, Pose2D(0.0, 0.0, math.radians(60.0)))
    events = drive_recording(base, 0.3, 0.0, 8.0)
    assert [e.event for e in events if e.active] == ["bump_right"]
    turning = drive_recording(base, 0.3, 1.0, 3.0)      # forward is refused: it turns on the spot, then leaves
    assert ("bump_right", False, "released") in [(e.event, e.active, e.action) for e in turning]
    assert base.truth.x < 1.0 - LIMITS.footprint_radius_m


def test_a_base_backing_into_a_wall_stalls_without_a_bumper_event() -> None:
    base = base_among(np.array([[0.0, -2.0, 0.0, 2.0]]), Pose2D(0.5, 0.0, 0.0))     # the wall behind it
    assert drive_recording(base, -0.3, 0.0, 4.0) == []
    assert base.truth.x == pytest.approx(LIMITS.footprint_radius_m, abs=0.01)


def test_without_walls_the_base_drives_anywhere() -> None:
    base = make_base()
    assert drive_recording(base, 0.3, 0.0, 5.0) == []
    assert base.truth.x > 1.0


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_base_among_walls_steps_as_the_step_of_commit_249c210_did_to_the_bit(seed: int) -> None:
    # Seeded random commands (forward, back, turning, beyond the wheel limits, gaps past the command timeout) in a
    # 3 m box with a pillar: it bumps, stalls and gets free; truth, odometry (slip drawn in batches), speeds,
    # bumps and events equal those of the old step at every step.
    walls = np.array([[-1.5, -1.5, 1.5, -1.5], [1.5, -1.5, 1.5, 1.5], [1.5, 1.5, -1.5, 1.5], [-1.5, 1.5, -1.5, -1.5],
                      [0.4, 0.4, 0.6, 0.6]])
    drift = OdometryDrift(0.004, -0.004, 0.01, 0.002)
    new, old = (kind(Pose2D(0.0, 0.0, 0.3), LIMITS, drift, np.random.default_rng(seed), walls)
                for kind in (DiffDriveBase, ReferenceBase))
    commands = np.random.default_rng([seed, 1])
    bumped = 0
    for step in range(6000):
        if step % 50 == 0:
            linear, angular, silent = commands.uniform(-0.4, 0.8), commands.uniform(-2.5, 2.5), commands.random() < 0.1
        if not silent:
            new.set_command(linear, angular)
            old.set_command(linear, angular)
        assert new.step(DT) == old.step(DT)
        assert (new.truth, new.odom, new.left_speed, new.right_speed, new.bumps, new.distance_travelled_m) == \
            (old.truth, old.odom, old.left_speed, old.right_speed, old.bumps, old.distance_travelled_m)
        bumped += new.bumped
    assert new.bumps > 0 and bumped > 0 and new.distance_travelled_m > 5.0      # it did meet the walls
