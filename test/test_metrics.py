"""Tracking metrics of a tag-route run (paper 001 sec. V, eq. 4), wall crossings and ground truth's verdict on a run,
on synthetic trajectories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_scenario.metrics import (
    READ_AREA_RADIUS_M,
    Trajectory,
    area_entries,
    flagged_spans,
    ground_truth_objection,
    signed_segment_error,
    success_verdict,
    tracking_error,
    tracking_metrics,
    wall_crossings,
    within_bound,
)

pytestmark = pytest.mark.tier("unit")

LINE_TAGS = np.array([[0.0, 0.0], [0.0, 5.0]])
JUST_PAST_3CM = 0.0301     # a read area the offset runs below enter where their leg starts and leave where it ends


def straight_run(offset_m: float, *, speed: float = 0.2, approach_s: float = 10.0, dt: float = 0.01):
    """Approach sideways to the first tag's projection shifted by ``offset_m``, from beyond it on that side (never
    over the tag), then drive parallel to the segment (0,0)->(0,5) at that constant lateral offset (positive = left
    of the direction of travel = -x)."""
    approach = np.arange(0.0, approach_s, dt)
    leg_s = 5.0 / speed
    leg = np.arange(0.0, leg_s + dt / 2, dt)
    times = np.concatenate((approach, approach_s + leg))
    side = math.copysign(speed, offset_m)
    xy = np.concatenate((
        np.column_stack((-offset_m - side * (approach_s - approach), np.zeros_like(approach))),
        np.column_stack((np.full_like(leg, -offset_m), speed * leg)),
    ))
    return Trajectory(times, xy), [approach_s, approach_s + leg_s]


@pytest.mark.parametrize("offset_m", [0.03, -0.03])
def test_constant_offset_gives_rmse_and_max_of_the_offset(offset_m):
    trajectory, arrivals = straight_run(offset_m)
    metrics = tracking_metrics(trajectory, LINE_TAGS, arrivals, mission_start_s=0.0, mission_end_s=arrivals[-1],
                               read_radius_m=JUST_PAST_3CM)
    assert metrics.tracking_rmse_m == pytest.approx(0.03, abs=1e-9)
    assert metrics.tracking_max_abs_m == pytest.approx(0.03, abs=1e-9)
    assert metrics.tags_reached == 2 and metrics.tags_entered == 2
    assert metrics.approach_s == pytest.approx(10.0)     # the read area is entered where the leg starts
    # The approach before the first read area does not count: it is 2 m off the line at the start.
    errors = tracking_error(trajectory, LINE_TAGS, read_radius_m=JUST_PAST_3CM).xy[:, 0]
    assert errors.size > 2000
    assert np.allclose(errors, offset_m, atol=1e-9)   # positive on the left (x < 0 when travelling +y)


def test_the_stretch_is_ground_truths_not_the_declared_arrivals():
    """Two controllers that declare their arrivals at different times are scored over the same stretch: from the
    entry into the first tag's read area to the entry into the last one's."""
    trajectory, arrivals = straight_run(0.03)
    scored = [tracking_metrics(trajectory, LINE_TAGS, declared, 0.0, arrivals[-1])
              for declared in (arrivals, [arrivals[0] - 3.0, arrivals[1] - 2.0], [arrivals[0] + 4.0], [])]
    assert len({(m.tracking_rmse_m, m.tracking_max_abs_m, m.approach_s, m.scored_s) for m in scored}) == 1
    assert [m.tags_reached for m in scored] == [2, 2, 1, 0]
    # The shipped floor antenna's read area (8.66 cm): entered 5.66 cm (0.28 s) before the leg starts.
    first = scored[0]
    assert first.approach_s == pytest.approx(10.0 - (READ_AREA_RADIUS_M - 0.03) / 0.2, abs=0.011)
    assert first.tracking_max_abs_m == pytest.approx(READ_AREA_RADIUS_M, abs=0.003)   # where it enters
    assert first.tracking_rmse_m == pytest.approx(0.03, abs=1e-3)


def test_rmse_is_the_root_mean_square_of_a_varying_error():
    times = np.linspace(0.0, 10.0, 10001)
    amplitude = 0.05
    lateral = amplitude * np.sin(2 * np.pi * times / 2.0)             # 5 full periods
    trajectory = Trajectory(times, np.column_stack((-lateral, 0.5 * times)))
    metrics = tracking_metrics(trajectory, LINE_TAGS, [0.0, 10.0], 0.0, 10.0, read_radius_m=1e-6)   # 0 to 10 s
    assert metrics.tracking_rmse_m == pytest.approx(amplitude / math.sqrt(2), rel=1e-3)
    assert metrics.tracking_max_abs_m == pytest.approx(amplitude, rel=1e-6)


def test_sign_is_positive_on_the_left_of_the_direction_of_travel():
    start, end = np.array([1.0, 1.0]), np.array([4.0, 1.0])           # travelling +x: left is +y
    points = np.array([[2.0, 1.5], [2.0, 0.2], [3.0, 1.0], [5.0, 1.0], [0.0, 2.0]])
    errors = signed_segment_error(points, start, end)
    assert errors[0] == pytest.approx(0.5)
    assert errors[1] == pytest.approx(-0.8)
    assert errors[2] == pytest.approx(0.0)
    assert abs(errors[3]) == pytest.approx(1.0)                        # past the end: distance to the end point
    assert errors[4] == pytest.approx(math.sqrt(2.0))                  # before the start, on the left
    reverse = signed_segment_error(points[:2], end, start)
    assert reverse == pytest.approx(-errors[:2])


def l_route_run() -> tuple[np.ndarray, Trajectory]:
    """An L route (0,0) -> (4,0) -> (4,3); the robot drives 0.1 m left of each leg at 1 m/s, turning at (3.9, 0.1),
    0.1414 m from the corner tag."""
    tags = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])
    t1 = np.linspace(0.0, 3.9, 391)
    leg1 = np.column_stack((t1, np.full_like(t1, 0.1)))                # travelling +x, left is +y
    t2 = np.linspace(3.91, 6.8, 290)
    leg2 = np.column_stack((np.full_like(t2, 3.9), 0.1 + (t2 - 3.9)))  # travelling +y, left is -x
    return tags, Trajectory(np.concatenate((t1, t2)), np.concatenate((leg1, leg2)))


def test_segments_switch_where_ground_truth_enters_the_next_read_area():
    tags, trajectory = l_route_run()
    radius = 0.1415                                                    # the corner's area: entered at the turn
    assert area_entries(trajectory, tags, radius) == pytest.approx([0.0, 3.9, 6.7], abs=1e-9)
    error = tracking_error(trajectory, tags, read_radius_m=radius)
    segment = error.xy[:, 1]
    assert set(segment) == {0.0, 1.0}
    assert np.all(error.times_s[segment == 0.0] < 3.9)
    assert np.all(error.times_s[segment == 1.0] >= 3.9)
    assert np.all(np.diff(segment) >= 0.0)
    assert error.times_s[-1] == pytest.approx(6.7)                     # the last area's entry ends the stretch
    # Against the wrong segment, (3.9, y) would be up to 2.9 m off the first leg; against the right one 0.1 m.
    assert np.allclose(error.xy[:, 0], 0.1, atol=1e-9)
    for declared in ([0.0, 3.9, 6.8], [0.0, 6.0, 6.8]):               # a late declared switch changes nothing
        metrics = tracking_metrics(trajectory, tags, declared, 0.0, 6.8, read_radius_m=radius)
        assert metrics.tracking_max_abs_m == pytest.approx(0.1, abs=1e-9)
        assert metrics.tracking_rmse_m == pytest.approx(0.1, abs=1e-9)
    # A robot that never enters the corner's area (a smaller one) is scored on nothing after the first tag.
    assert area_entries(trajectory, tags, 0.14) == [0.0]
    assert tracking_metrics(trajectory, tags, [0.0, 3.9, 6.8], 0.0, 6.8, read_radius_m=0.14).tracking_rmse_m is None


def test_error_stops_at_the_last_read_area_and_needs_two():
    trajectory, arrivals = straight_run(0.03)
    # After the last tag the robot wanders 1 m off: not part of e(t).
    extra_t = np.arange(arrivals[-1] + 0.01, arrivals[-1] + 5.0, 0.01)
    wandering = Trajectory(np.concatenate((trajectory.times_s, extra_t)),
                           np.concatenate((trajectory.xy, np.column_stack((np.full_like(extra_t, 1.0),
                                                                           np.full_like(extra_t, 5.0))))))
    metrics = tracking_metrics(wandering, LINE_TAGS, arrivals, 0.0, extra_t[-1], read_radius_m=JUST_PAST_3CM)
    assert metrics.tracking_max_abs_m == pytest.approx(0.03, abs=1e-9)
    short = trajectory.between(0.0, arrivals[-1] - 1.0)                # stops 20 cm before the last tag
    only_first = tracking_metrics(short, LINE_TAGS, arrivals, 0.0, arrivals[-1])
    assert only_first.tracking_rmse_m is None and only_first.tracking_max_abs_m is None
    assert only_first.tags_reached == 2 and only_first.tags_entered == 1 and only_first.scored_s is None


def test_time_to_first_tag_is_measured_from_the_mission_start():
    times = np.arange(0.0, 30.0, 0.01)
    # Straight at the first tag's projection from 2 m away at 0.1 m/s, starting at t = 5 s.
    y = np.clip(-2.0 + 0.1 * (times - 5.0), -2.0, 0.5)
    trajectory = Trajectory(times, np.column_stack((np.zeros_like(times), y)))
    metrics = tracking_metrics(trajectory, LINE_TAGS, [], mission_start_s=5.0, mission_end_s=30.0)
    # Within 1 cm of (0, 0) once y >= -0.01: 1.99 m / 0.1 m/s = 19.9 s after the start.
    assert metrics.time_to_first_tag_s == pytest.approx(19.9, abs=0.011)
    later = tracking_metrics(trajectory, LINE_TAGS, [], mission_start_s=10.0, mission_end_s=30.0)
    assert later.time_to_first_tag_s == pytest.approx(metrics.time_to_first_tag_s - 5.0, abs=0.011)


def test_time_to_first_tag_is_none_when_never_within_1_cm():
    times = np.arange(0.0, 20.0, 0.01)
    trajectory = Trajectory(times, np.column_stack((np.full_like(times, 0.011), 0.5 * times - 5.0)))
    metrics = tracking_metrics(trajectory, LINE_TAGS, [], 0.0, 20.0)
    assert metrics.time_to_first_tag_s is None
    closer = Trajectory(times, np.column_stack((np.full_like(times, 0.009), 0.5 * times - 5.0)))
    assert tracking_metrics(closer, LINE_TAGS, [], 0.0, 20.0).time_to_first_tag_s is not None


def test_path_length_of_a_known_polyline():
    corners = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0], [0.0, 0.0], [-1.0, 0.0]])   # 3 + 4 + 5 + 1
    trajectory = Trajectory(np.arange(len(corners), dtype=float), corners)
    assert tracking_metrics(trajectory, LINE_TAGS, [], 0.0, 10.0).path_length_m == pytest.approx(13.0)
    # Only the part of the run between mission start and end counts.
    assert tracking_metrics(trajectory, LINE_TAGS, [], 1.0, 3.0).path_length_m == pytest.approx(9.0)
    single = Trajectory(np.array([0.0]), np.array([[1.0, 1.0]]))
    assert tracking_metrics(single, LINE_TAGS, [], 0.0, 1.0).path_length_m == 0.0


def test_as_dict_has_the_summary_keys():
    trajectory, arrivals = straight_run(0.03)
    keys = tracking_metrics(trajectory, LINE_TAGS, arrivals, 0.0, arrivals[-1]).as_dict()
    assert {"tracking_rmse_m", "tracking_max_abs_m", "time_to_first_tag_s", "path_length_m"} <= set(keys)


# A wall x = 6 from y = 0 to 8 with a door at y 3.0-4.2, drawn as two segments (two_tier_home's middle wall).
DOOR_WALLS = np.array([[6.0, 0.0, 6.0, 3.0], [6.0, 4.2, 6.0, 8.0]])


def track(*corners: tuple[float, float], step_m: float = 0.01) -> np.ndarray:
    """A polyline through ``corners`` sampled every ``step_m`` or closer, the corners among the samples."""
    points = [np.asarray(corners[0], dtype=float)]
    for start, end in zip(corners, corners[1:]):
        count = max(1, math.ceil(math.dist(start, end) / step_m))
        points.extend(np.asarray(start) + (np.asarray(end) - np.asarray(start)) * k / count
                      for k in range(1, count + 1))
    return np.array(points)


def test_a_track_through_a_wall_crosses_it_once_however_it_is_sampled():
    assert wall_crossings(track((5.0, 1.0), (7.0, 1.0)), DOOR_WALLS) == 1
    assert wall_crossings(track((5.0, 1.0), (7.0, 1.0), step_m=5.0), DOOR_WALLS) == 1          # one long step
    assert wall_crossings(track((5.0, 1.0), (6.0, 1.0), (6.0, 1.0), (7.0, 1.0)), DOOR_WALLS) == 1   # stops on it
    assert wall_crossings(track((7.0, 2.0), (5.0, 1.0)), DOOR_WALLS) == 1                     # either way, slanted


def test_a_track_that_touches_or_stalls_at_a_wall_and_turns_back_crosses_nothing():
    touching = track((5.0, 1.0), (6.0, 1.0), (5.0, 2.0))
    stalled = np.concatenate((track((5.0, 1.0), (6.0 - 1e-9, 1.0)), np.full((200, 2), (6.0 - 1e-9, 1.0)),
                              track((6.0 - 1e-9, 1.0), (5.0, 1.0))))
    against = track((5.0, 1.0), (5.83, 1.0), (5.83, 2.5), (5.0, 2.5))       # a 17 cm base pressed to the wall
    assert [wall_crossings(t, DOOR_WALLS) for t in (touching, stalled, against)] == [0, 0, 0]


def test_a_track_parallel_to_a_wall_or_along_its_line_crosses_nothing():
    assert wall_crossings(track((5.5, 0.0), (5.5, 8.0)), DOOR_WALLS) == 0
    assert wall_crossings(track((6.0, -1.0), (6.0, 9.0)), DOOR_WALLS) == 0


def test_a_track_through_the_door_gap_or_past_a_walls_end_crosses_nothing():
    assert wall_crossings(track((5.0, 3.6), (7.0, 3.6)), DOOR_WALLS) == 0
    assert wall_crossings(track((5.0, 3.01), (7.0, 3.01), step_m=2.0), DOOR_WALLS) == 0   # 1 cm past its end
    assert wall_crossings(track((5.0, -0.5), (7.0, -0.5)), DOOR_WALLS) == 0                # beyond the wall
    # Along the wall's line through the door, then out of it: the track left the line in the gap.
    assert wall_crossings(track((5.0, 3.4), (6.0, 3.4), (6.0, 3.8), (7.0, 3.8)), DOOR_WALLS) == 0


def test_a_track_out_through_a_wall_and_back_crosses_twice():
    assert wall_crossings(track((5.0, 1.0), (7.0, 1.0), (7.0, 6.0), (5.0, 6.0)), DOOR_WALLS) == 2
    # Out through the wall and back through the door: once.
    assert wall_crossings(track((5.0, 1.0), (7.0, 1.0), (7.0, 3.6), (5.0, 3.6)), DOOR_WALLS) == 1
    assert wall_crossings(track((5.0, 1.0), (7.0, 1.0)), np.empty((0, 4))) == 0               # no walls


def test_ground_truth_objects_to_a_run_that_crossed_a_wall_or_missed_the_goal():
    assert ground_truth_objection({"wall_crossings": 0, "success": True}) is None
    assert ground_truth_objection({"wall_crossings": 0}) is None
    assert ground_truth_objection({"wall_crossings": 22}) == "made 22 wall crossings (metrics.wall_crossings)"
    assert ground_truth_objection({"wall_crossings": 1, "success": False, "final_distance_m": 3.25}) == (
        "did not reach the goal (metrics.success false, 3.25 m from it) and made 1 wall crossing "
        "(metrics.wall_crossings)")


def detour_run(detour_m: float = 1.0, dt: float = 0.01):
    """On the line (0,0)->(0,5) at 0.2 m/s, but from 10 s to 20 s out to x = ``detour_m`` and back (a search:
    5 s out, 5 s back, standing still in y); the time the detour starts and ends."""
    times = np.arange(0.0, 35.0 + dt / 2, dt)
    y = 0.2 * np.clip(times, None, 10.0) + 0.2 * np.clip(times - 20.0, 0.0, None)
    x = np.where((times > 10.0) & (times < 20.0), detour_m * (1.0 - np.abs(times - 15.0) / 5.0), 0.0)
    return Trajectory(times, np.column_stack((x, y))), (10.0, 20.0)


def test_a_search_is_left_out_of_the_tracking_error_and_reported_apart():
    trajectory, search = detour_run(detour_m=1.0)
    with_search = tracking_metrics(trajectory, LINE_TAGS, [], 0.0, 35.0)
    without = tracking_metrics(trajectory, LINE_TAGS, [], 0.0, 35.0, searching=[search])
    assert with_search.tracking_rmse_m > 0.3 and with_search.tracking_max_abs_m == pytest.approx(1.0, abs=0.01)
    assert without.tracking_rmse_m == pytest.approx(0.0, abs=1e-9)
    assert without.tracking_max_abs_m == pytest.approx(0.0, abs=1e-9)
    assert (without.searches, without.search_s) == (1, 10.0)
    assert without.search_length_m == pytest.approx(2.0, abs=1e-6)          # 1 m out and 1 m back
    assert with_search.searches == 0 and with_search.search_length_m == 0.0
    assert without.path_length_m == pytest.approx(with_search.path_length_m)   # driven either way


def test_the_way_back_from_where_a_search_ended_is_left_out_up_to_the_next_read_area_and_the_next_leg_scored():
    """Route (0,0) -> (0,5) -> (0,10): on the line to y = 2, a search out to (1, 2), up to (1, 5) a metre off the
    leg, sideways into T2's read area, then the last leg 3 cm to the left of its line."""
    tags = np.array([[0.0, 0.0], [0.0, 5.0], [0.0, 10.0]])
    knots_t = [0.0, 4.0, 6.0, 9.0, 10.0, 20.0]
    knots_xy = [(0.0, 0.0), (0.0, 2.0), (1.0, 2.0), (1.0, 5.0), (-0.03, 5.0), (-0.03, 10.0)]
    times = np.arange(0.0, 20.0 + 1e-9, 0.01)
    xy = np.column_stack([np.interp(times, knots_t, [p[axis] for p in knots_xy]) for axis in (0, 1)])
    trajectory = Trajectory(times, xy)
    scored = tracking_metrics(trajectory, tags, [], 0.0, 20.0, searching=[(4.0, 6.0)])
    assert scored.tags_entered == 3 and (scored.searches, scored.search_s) == (1, 2.0)
    assert scored.search_length_m == pytest.approx(1.0)          # the search proper: out to (1, 2)
    assert scored.tracking_max_abs_m <= READ_AREA_RADIUS_M + 1e-9  # the metre-off way back is not scored...
    assert 0.02 < scored.tracking_rmse_m < 0.031      # ...the last leg is (3 cm off), and the first (on the line)
    assert tracking_metrics(trajectory, tags, [], 0.0, 20.0).tracking_max_abs_m == pytest.approx(1.0, abs=1e-6)


def test_the_final_distance_is_from_the_last_route_tag():
    trajectory, _ = detour_run()
    metrics = tracking_metrics(trajectory, LINE_TAGS, [], 0.0, 34.0)       # stopped at y = 4.8
    assert metrics.final_distance_m == pytest.approx(0.2, abs=1e-9)
    assert tracking_metrics(trajectory, LINE_TAGS, [], 100.0, 200.0).final_distance_m is None     # no track


def test_flagged_spans_start_at_the_first_flag_and_end_at_the_next_unflagged_sample():
    times = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert flagged_spans(times, [False, True, True, False, True, False], 9.0) == [(1.0, 3.0), (4.0, 5.0)]
    assert flagged_spans(times, [True, False, False, False, False, True], 9.0) == [(0.0, 1.0), (5.0, 9.0)]
    assert flagged_spans(times, [False] * 6, 9.0) == [] and flagged_spans([], [], 9.0) == []


def test_success_is_stopping_within_the_declared_bound():
    assert within_bound(0.10, 0.10) is True and within_bound(0.1001, 0.10) is False
    assert within_bound(None, 0.10) is None and within_bound(0.05, None) is None
    assert within_bound(math.nan, 0.5) is None          # a run without a track
    assert ground_truth_objection({"success": False, "final_error_m": 0.318, "success_within_m": 0.17}) == (
        "did not reach the goal (metrics.success false, 0.32 m from it, more than the scenario's 0.17 m)")
    assert ground_truth_objection({"success": None, "final_error_m": 0.318}) is None    # no criterion: no say


def test_the_verdict_reads_each_kinds_final_distance_under_its_own_name():
    assert success_verdict({"final_distance_m": 0.3}, 0.5) == {"success_within_m": 0.5, "success": True}
    assert success_verdict({"final_error_m": 0.318}, 0.17) == {"success_within_m": 0.17, "success": False}
    assert success_verdict({"final_distance_m": None, "path_length_m": 3.0}, 0.1)["success"] is None   # no track
    assert success_verdict({"final_error_m": 0.05}, None)["success"] is None               # no criterion
