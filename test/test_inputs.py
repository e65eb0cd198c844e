"""rfidnav_common.inputs: the one check every node applies to the numbers and frames it takes in (pure, no rclpy)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from rfidnav_common import inputs
from rfidnav_common.geometry import wrap_angle, yaw_to_quaternion
from rfidnav_common.inputs import BadInput, Drops

pytestmark = pytest.mark.tier("unit")

FREQUENCY_HZ = 915e6
EXTREMES = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1.7e308]


def tag_reading(**overrides) -> SimpleNamespace:
    amplitude, phase = 1e-3, 2.5
    fields = dict(tag_id="C1", antenna=1, i=amplitude * math.cos(phase), q=amplitude * math.sin(phase),
                  phase_rad=phase, rssi_dbm=-60.0, frequency_hz=FREQUENCY_HZ)
    fields.update(overrides)
    return SimpleNamespace(**fields)


def quaternion(yaw: float) -> SimpleNamespace:
    return SimpleNamespace(**dict(zip("xyzw", yaw_to_quaternion(yaw))))


def odometry(x: float = 1.0, y: float = 2.0, yaw: float = 0.5, frame_id: str = "odom",
             child_frame_id: str = "base_link", q: SimpleNamespace | None = None) -> SimpleNamespace:
    pose = SimpleNamespace(position=SimpleNamespace(x=x, y=y, z=0.0), orientation=q or quaternion(yaw))
    return SimpleNamespace(header=SimpleNamespace(frame_id=frame_id), child_frame_id=child_frame_id,
                           pose=SimpleNamespace(pose=pose))


@pytest.mark.parametrize("field", ["i", "q", "phase_rad", "rssi_dbm", "frequency_hz"])
@pytest.mark.parametrize("bad", [math.inf, -math.inf])
def test_a_read_with_an_infinite_number_is_refused_naming_the_field(field, bad):
    with pytest.raises(BadInput, match=f"reading.{field}"):
        inputs.tag_read(tag_reading(**{field: bad}))


@pytest.mark.parametrize("field", ["i", "q", "rssi_dbm", "frequency_hz"])
def test_a_read_with_a_nan_is_refused_naming_the_field_when_the_node_needs_it(field):
    with pytest.raises(BadInput, match=f"reading.{field}"):
        inputs.tag_read(tag_reading(**{field: math.nan}))


def test_a_read_without_i_q_and_phase_is_refused_by_a_node_that_steers_on_the_phase():
    with pytest.raises(BadInput, match="reading.phase_rad: not reported"):
        inputs.tag_read(tag_reading(i=math.nan, q=math.nan, phase_rad=math.nan), required=("phase_rad",))


def test_a_read_whose_reader_did_not_report_rss_phase_or_channel_is_kept_by_a_node_that_needs_only_its_id():
    """The LLRP driver's NaN means 'not reported' (no phase in the report, a channel outside the hop table)."""
    read = inputs.tag_read(tag_reading(i=math.nan, q=math.nan, phase_rad=math.nan, rssi_dbm=math.nan,
                                       frequency_hz=math.nan), required=())
    assert (read.tag_id, read.antenna) == ("C1", 1)
    assert all(math.isnan(value) for value in (read.phase_rad, read.rssi_dbm, read.frequency_hz))


@pytest.mark.parametrize("field, bad", [("rssi_dbm", 1e308), ("rssi_dbm", -1e308), ("rssi_dbm", 200.0),
                                        ("frequency_hz", 0.0), ("frequency_hz", -915e6), ("frequency_hz", 1e308),
                                        ("antenna", 0), ("tag_id", "")])
def test_a_read_beyond_what_a_reader_reports_is_refused(field, bad):
    with pytest.raises(BadInput, match=f"reading.{field}"):
        inputs.tag_read(tag_reading(**{field: bad}))


@pytest.mark.parametrize("phase", [0.0, 0.3, 2.5, 3.5, 6.0])
def test_a_read_takes_its_phase_from_i_and_q(phase):
    read = inputs.tag_read(tag_reading(i=2e-4 * math.cos(phase), q=2e-4 * math.sin(phase), phase_rad=1.234,
                                       antenna=2))
    assert 0.0 <= read.phase_rad < 2 * math.pi
    assert abs(math.remainder(read.phase_rad - phase, 2 * math.pi)) < 1e-9   # from I/Q, not 1.234
    assert (read.tag_id, read.antenna, read.rssi_dbm, read.frequency_hz) == ("C1", 2, -60.0, FREQUENCY_HZ)


@pytest.mark.parametrize("huge", [1e308, -1e308, 1.7e308, 123456.789])
def test_a_read_with_a_huge_phase_and_no_i_q_takes_it_wrapped(huge):
    read = inputs.tag_read(tag_reading(i=0.0, q=0.0, phase_rad=huge))
    assert 0.0 <= read.phase_rad < 2 * math.pi
    assert read.phase_rad == pytest.approx(math.fmod(huge, 2 * math.pi) % (2 * math.pi))


def test_a_read_with_huge_i_and_q_still_has_a_phase():
    read = inputs.tag_read(tag_reading(i=1.7e308, q=-1.7e308))
    assert read.phase_rad == pytest.approx(7 * math.pi / 4)


@pytest.mark.parametrize("angle", [1e308, -1e308, 1.7e308, -0.0, 1e16 + 0.5])
def test_wrap_angle_is_exact_for_any_finite_angle(angle):
    wrapped = wrap_angle(angle)
    assert -math.pi < wrapped <= math.pi
    assert wrapped == math.remainder(angle, 2 * math.pi) or wrapped == math.pi


@pytest.mark.parametrize("bad", [math.inf, -math.inf, math.nan])
def test_wrap_angle_names_a_non_finite_angle(bad):
    with pytest.raises(ValueError, match="not a finite angle"):
        wrap_angle(bad)


@pytest.mark.parametrize("field", ["x", "y"])
@pytest.mark.parametrize("bad", EXTREMES + [1.000001e5])
def test_an_odometry_pose_far_beyond_any_map_is_refused(field, bad):
    with pytest.raises(BadInput, match=f"pose.position.{field}"):
        inputs.odometry_pose(odometry(**{field: bad}))


@pytest.mark.parametrize("q", [(0.0, 0.0, 0.0, 0.0), (1e308, 1e308, 1e308, 1e308), (0.0, 0.0, 0.5, 0.5),
                               (0.0, 0.0, math.nan, 1.0), (0.0, 0.0, 0.0, math.inf)])
def test_a_quaternion_that_is_no_rotation_is_refused(q):
    with pytest.raises(BadInput, match="orientation"):
        inputs.odometry_pose(odometry(q=SimpleNamespace(**dict(zip("xyzw", q)))))


@pytest.mark.parametrize("frames", [("map", "base_link"), ("", "base_link"), ("odom", "other_robot")])
def test_odometry_in_another_frame_is_refused_naming_both_frames(frames):
    frame_id, child = frames
    with pytest.raises(BadInput, match="expected 'odom'|expected 'base_link'"):
        inputs.odometry_pose(odometry(frame_id=frame_id, child_frame_id=child))


def test_a_good_odometry_pose_passes_unchanged():
    assert inputs.odometry_pose(odometry(-3.0, 4.0, 2.0)) == pytest.approx((-3.0, 4.0, 2.0))
    assert inputs.odometry_pose(odometry(frame_id="map"), frame_id="map")[0] == 1.0


@pytest.mark.parametrize("linear, angular, expected", [
    (0.1, 0.2, (0.1, 0.2, False)),
    (1.0, 0.0, (0.5, 0.0, True)),             # twice the speed: half of it, straight on
    (1.0, 8.0, (0.25, 2.0, True)),            # the yaw rate is twice as far beyond as the speed: a quarter
    (1.7e308, 1.7e308, (0.5, 0.5, True)),
    (-1e308, 0.0, (-0.5, 0.0, True)),
    (-0.0, -0.0, (0.0, 0.0, False)),
])
def test_a_velocity_beyond_the_limits_is_scaled_down_keeping_its_arc(linear, angular, expected):
    command = inputs.velocity(linear, angular, 0.5, 2.0)
    assert (command.linear_mps, command.angular_radps, command.clamped) == pytest.approx(expected)
    assert abs(command.linear_mps) <= 0.5 and abs(command.angular_radps) <= 2.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_velocity_is_refused(bad):
    with pytest.raises(BadInput, match="not finite"):
        inputs.velocity(0.1, bad, 0.5, 2.0)


def test_a_wifi_scan_refuses_an_rss_beyond_physics_an_empty_bssid_and_a_bssid_listed_twice():
    def scan(*aps):
        return SimpleNamespace(access_points=[SimpleNamespace(bssid=b, rssi_dbm=r) for b, r in aps])
    assert inputs.wifi_rss(scan(("aa", -50.0), ("bb", -90.0))) == {"aa": -50.0, "bb": -90.0}
    for twice in ("aa", "AA"):
        with pytest.raises(BadInput,
                           match=rf"access_points\[2\].bssid: {twice} listed twice \(also access_points\[0\]\)"):
            inputs.wifi_rss(scan(("aa", -50.0), ("bb", -90.0), (twice, -40.0)))
    for bad in EXTREMES:
        with pytest.raises(BadInput, match=r"access_points\[1\].rssi_dbm \(bb\)"):
            inputs.wifi_rss(scan(("aa", -50.0), ("bb", bad)))
    with pytest.raises(BadInput, match="bssid: empty"):
        inputs.wifi_rss(scan(("", -50.0)))


def test_drops_are_counted_per_input_and_warned_about_at_most_once_a_period():
    lines: list[str] = []
    now = [0.0]
    drops = Drops(lines.append, period_s=5.0, clock=lambda: now[0])
    drops.drop("/odom", "pose.position.x: inf is not finite")
    drops.drop("/odom", "again")
    drops.drop("/rfid/reads", "reading.antenna: port 0", count=3, unit="read")
    drops.clamp("/cmd_vel", "2 m/s")
    assert lines == ["/odom: dropped a message: pose.position.x: inf is not finite (1 dropped so far)",
                     "/rfid/reads: dropped 3 reads: reading.antenna: port 0 (3 dropped so far)",
                     "/cmd_vel: clamped: 2 m/s (1 clamped so far)"]
    now[0] = 5.0
    drops.drop("/odom", "late")
    assert lines[-1] == "/odom: dropped a message: late (3 dropped so far)"
    assert (drops.dropped("/odom"), drops.dropped("/rfid/reads"), drops.dropped(), drops.clamped()) == (3, 3, 6, 1)


def clocked_node(nanoseconds: int, sim_time: bool) -> SimpleNamespace:
    clock = SimpleNamespace(ros_time_is_active=sim_time, now=lambda: SimpleNamespace(nanoseconds=nanoseconds))
    return SimpleNamespace(get_clock=lambda: clock)


def test_stamps_are_checked_against_sim_time_once_its_clock_has_started_and_never_on_wall_time():
    from builtin_interfaces.msg import Time

    from rfidnav_common.ros import sim_clock_seconds, stamp_seconds

    assert sim_clock_seconds(clocked_node(100_000_000_000, True)) == 100.0
    assert sim_clock_seconds(clocked_node(0, True)) is None              # no /clock heard yet
    assert sim_clock_seconds(clocked_node(100_000_000_000, False)) is None
    far = Time(sec=2 ** 31 - 1)
    assert stamp_seconds(clocked_node(0, True), far) == 2 ** 31 - 1
    assert stamp_seconds(clocked_node(100_000_000_000, False), far) == 2 ** 31 - 1
    with pytest.raises(BadInput, match="from this node's clock"):
        stamp_seconds(clocked_node(100_000_000_000, True), far)


def test_a_stamp_a_minute_or_more_from_the_nodes_clock_is_refused():
    assert inputs.stamp_near(130.0, 100.0) == 130.0 and inputs.stamp_near(40.5, 100.0) == 40.5
    for far in (160.5, 39.0, float(2 ** 31 - 1), math.nan, math.inf):
        with pytest.raises(BadInput, match=r"header.stamp: .* from this node's clock \(100.000 s\), more than 60 s"):
            inputs.stamp_near(far, 100.0)
