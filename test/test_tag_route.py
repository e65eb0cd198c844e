"""Tag-route follower (paper 001 sec. IV-C): arrival on the floor tag, finishing, steering sign, the search for an
unheard target and the paper's unheard failure, validation of reads (NaN/Inf dropped, phase from I/Q), phase pairs
on one channel only, and the receding-target guard.

Pure-module tests with a linear heading controller and with the real fuzzy controller of the paper."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from rfidnav_common.rf import round_trip_phase, wavelength_m
from rfidnav_control.fuzzy import FuzzyHeadingController, paper_spec
from rfidnav_control.tag_route import (
    SEARCH_MODES,
    FollowerSettings,
    PhaseTrack,
    TagObservation,
    TagRouteFollower,
    observe,
    pair_phases,
)

pytestmark = pytest.mark.tier("unit")

FREQUENCY_HZ = 915e6
ROUND_S = 0.04
ARRIVAL_TAGS = {"C1": "F1", "C2": "F2", "C3": "F3"}


def linear_controller(delta_phi: float) -> float:
    return -0.05 * delta_phi


CONTROLLERS = {"linear": lambda: linear_controller, "fuzzy_paper": lambda: FuzzyHeadingController(paper_spec())}


@pytest.fixture(params=sorted(CONTROLLERS))
def controller(request):
    return CONTROLLERS[request.param]()


def follower(controller=linear_controller, **settings) -> TagRouteFollower:
    return TagRouteFollower(FollowerSettings(**settings), controller, ARRIVAL_TAGS)


def ceiling_pair(tag_id: str, left_phase: float, right_phase: float,
                 frequency_hz: float = FREQUENCY_HZ) -> list[TagObservation]:
    return [TagObservation(tag_id, 1, left_phase % (2 * math.pi), -60.0, frequency_hz),
            TagObservation(tag_id, 2, right_phase % (2 * math.pi), -60.0, frequency_hz)]


def floor_read(tag_id: str) -> TagObservation:
    return TagObservation(tag_id, 3, 1.0, -50.0, FREQUENCY_HZ)


# ------------------------------------------------------------------------------------------- arrival, finishing

def test_floor_tag_read_advances_the_target_and_the_last_one_finishes(controller):
    route = follower(controller)
    route.start(["C1", "C2", "C3"], 0.0)
    command = route.step(0.04, ceiling_pair("C1", 1.0, 1.0))
    assert (command.mode, command.target_index, command.target_tag_id, command.arrived_index) == ("seeking", 0,
                                                                                                  "C1", None)
    # Another route tag's floor tag is not an arrival.
    assert route.step(0.08, ceiling_pair("C1", 1.0, 1.0) + [floor_read("F2")]).arrived_index is None

    command = route.step(0.12, [floor_read("F1")] + ceiling_pair("C2", 0.5, 0.5))
    assert command.arrived_index == 0
    assert (command.target_index, command.target_tag_id) == (1, "C2")
    assert command.mode == "seeking" and command.linear_mps == pytest.approx(0.2)
    assert route.target == "C2"

    command = route.step(0.16, [floor_read("F2")])
    assert (command.arrived_index, command.target_tag_id) == (1, "C3")
    assert not route.finished

    command = route.step(0.20, [floor_read("F3")] + ceiling_pair("C3", 0.0, 0.0))
    assert command.mode == "finished"
    assert command.arrived_index == 2 and command.target_tag_id == "C3"
    assert (command.linear_mps, command.angular_radps) == (0.0, 0.0)
    assert route.finished


def test_single_tag_route_finishes_on_its_floor_tag():
    route = follower()
    route.start(["C2"], 0.0)
    assert route.step(0.04, [floor_read("F1")]).mode != "finished"   # F1 belongs to C1, not on this route
    assert route.step(0.08, [floor_read("F2")]).mode == "finished"


def floor_read_at(tag_id: str, range_m: float) -> TagObservation:
    return TagObservation(tag_id, 3, float(round_trip_phase(range_m, FREQUENCY_HZ)), -50.0, FREQUENCY_HZ)


def test_closest_approach_arrival_waits_for_the_floor_range_minimum_while_slowing_down():
    """The floor antenna passes 1 cm beside floor tag F1, 5 cm above it; arrival comes once the range has
    grown a millimetre past its minimum (about 1 cm of travel here), and from the first floor read the robot
    runs at the approach fraction."""
    route = follower(arrival="closest_approach", approach_speed_fraction=0.1)
    route.start(["C1", "C2"], 0.0)
    assert route.step(0.04, ceiling_pair("C1", 1.0, 1.0)).linear_mps == pytest.approx(0.2)
    along = [-0.08 + 0.004 * k for k in range(41)]           # 0.1 m/s over the floor tag, 4 mm per round
    closest = min(range(len(along)), key=lambda k: abs(along[k]))
    arrivals = []
    for k, x in enumerate(along):
        reads = [floor_read_at("F1", math.hypot(0.05, math.hypot(x, 0.01)))] + ceiling_pair("C1", 1.0, 1.0)
        command = route.step(0.08 + ROUND_S * k, reads)
        if command.arrived_index is not None:
            arrivals.append(k)
            break
        assert command.linear_mps == pytest.approx(0.02)
    assert arrivals and 0.0 < along[arrivals[0]] - along[closest] <= 0.015, (closest, arrivals)
    assert route.target == "C2"
    assert route.step(0.08 + ROUND_S * 50, ceiling_pair("C2", 1.0, 1.0)).linear_mps == pytest.approx(0.2)


def test_closest_approach_arrival_when_the_floor_tag_falls_silent():
    """A pass at the edge of the floor antenna's range may end before the range grows: silence after reads
    is arrival too, or the robot would drive on for ever."""
    route = follower(arrival="closest_approach")
    route.start(["C1"], 0.0)
    for k, range_m in enumerate((0.10, 0.09, 0.085)):
        assert route.step(ROUND_S * (k + 1), [floor_read_at("F1", range_m)]).mode != "finished"
    assert route.step(ROUND_S * 4, ceiling_pair("C1", 1.0, 1.0)).mode == "finished"


def test_an_unknown_tag_an_empty_route_or_a_tag_twice_in_a_row_is_refused_and_a_later_revisit_is_not():
    route = follower()
    with pytest.raises(ValueError, match="C9"):
        route.start(["C1", "C9"], 0.0)
    with pytest.raises(ValueError, match="empty"):
        route.start([], 0.0)
    assert route.refusal(["C1", "X", "C3", "Y"]) == "unknown tag ids X, Y (not in the route map)"
    with pytest.raises(ValueError, match=r"C3 twice in a row \(positions 2 and 3\)"):
        route.start(["C1", "C3", "C3"], 0.0)
    assert route.refusal(["C1", "C3", "C1"]) is None         # back along the same hallway


# ---------------------------------------------------------------------------------------------------- steering

@pytest.mark.parametrize("delta_phi", [-2.5, -1.0, -0.3])
def test_tag_on_the_left_commands_a_ccw_turn_and_on_the_right_a_cw_turn(controller, delta_phi):
    left = follower(controller)
    left.start(["C1"], 0.0)
    command = left.step(0.04, ceiling_pair("C1", 2.0 + delta_phi, 2.0))   # phi1 - phi2 = delta_phi < 0
    assert command.mode == "seeking"
    assert command.phase_difference_rad == pytest.approx(delta_phi)
    assert command.heading_change_rad > 0.0
    assert command.angular_radps > 0.0
    assert command.linear_mps == pytest.approx(0.2)

    right = follower(controller)
    right.start(["C1"], 0.0)
    mirrored = right.step(0.04, ceiling_pair("C1", 2.0 - delta_phi, 2.0))
    assert mirrored.angular_radps < 0.0
    assert mirrored.angular_radps == pytest.approx(-command.angular_radps, rel=1e-6, abs=1e-9)


def test_yaw_rate_is_the_heading_change_over_the_round_and_is_bounded():
    route = follower(max_yaw_rate_radps=2.0, receding_detection=False)
    route.start(["C1"], 0.0)
    first = route.step(0.04, ceiling_pair("C1", 0.0, 0.5))           # dphi = -0.5 -> dtheta = 0.025
    assert first.heading_change_rad == pytest.approx(0.025)
    assert first.angular_radps == pytest.approx(0.025 / ROUND_S)
    big = route.step(0.08, ceiling_pair("C1", 0.0, 3.0))             # dtheta = 0.15 / 0.04 s = 3.75 > 2
    assert big.angular_radps == pytest.approx(2.0)


def test_phase_difference_wraps_across_zero():
    route = follower()
    route.start(["C1"], 0.0)
    # phi1 = 0.1, phi2 = 2*pi - 0.1: the tag is slightly right (dphi = +0.2), not 2*pi - 0.2 to the left.
    command = route.step(0.04, ceiling_pair("C1", 0.1, -0.1))
    assert command.phase_difference_rad == pytest.approx(0.2)
    assert command.angular_radps < 0.0


def test_reads_of_other_tags_do_not_steer():
    route = follower()
    route.start(["C1"], 0.0)
    command = route.step(0.04, ceiling_pair("C2", 0.0, 2.0))
    assert command.mode == "unheard"
    assert command.angular_radps == 0.0 and command.linear_mps == pytest.approx(0.2)


# ------------------------------------------------------------------------------------- phase pairs, one channel

OTHER_CHANNEL_HZ = 927.25e6


def read(tag_id: str, antenna: int, phase: float, frequency_hz: float = FREQUENCY_HZ) -> TagObservation:
    return TagObservation(tag_id, antenna, phase, -60.0, frequency_hz)


def test_a_left_and_a_right_read_on_different_channels_make_no_pair_and_are_counted_as_such():
    pairing = pair_phases([read("C1", 1, 2.0), read("C1", 2, 0.5, OTHER_CHANNEL_HZ)], "C1", 1, 2)
    assert (pairing.left, pairing.right, pairing.cross_channel) == (None, None, True)
    with pytest.raises(ValueError, match="no same-channel pair"):
        _ = pairing.difference_rad
    # One antenna only, or nothing at all: no pair, and no cross-channel round either.
    assert not pair_phases([read("C1", 1, 2.0)], "C1", 1, 2).cross_channel
    assert not pair_phases([read("C2", 1, 2.0), read("C2", 2, 0.5)], "C1", 1, 2).cross_channel


def test_the_newest_same_channel_pair_of_a_batch_is_the_one_subtracted():
    # A 20 ms LLRP batch across a hop: left and right on the old channel, then left on the new one, then right
    # on the new one. The old channel's pair and the new one's are both same-channel; the new one is newer.
    batch = [read("C1", 1, 1.0), read("C1", 2, 0.8), read("C1", 1, 3.0, OTHER_CHANNEL_HZ),
             read("C2", 2, 6.0, OTHER_CHANNEL_HZ), read("C1", 2, 2.5, OTHER_CHANNEL_HZ)]
    pairing = pair_phases(batch, "C1", 1, 2)
    assert pairing.left is batch[2] and pairing.right is batch[4] and not pairing.cross_channel
    assert pairing.difference_rad == pytest.approx(0.5)
    # Without the new channel's right read, the old channel's pair is used, not left(new) - right(old).
    assert pair_phases(batch[:4], "C1", 1, 2).difference_rad == pytest.approx(0.2)


def test_a_cross_channel_round_does_not_steer_the_robot_and_is_counted():
    route = follower(unheard_timeout_s=1.0, unheard_search=False)
    route.start(["C1"], 0.0)
    # Left minus right across the channels would be -2.5 rad: a hard left turn on a meaningless difference.
    command = route.step(0.04, [read("C1", 1, 0.5), read("C1", 2, 3.0, OTHER_CHANNEL_HZ)])
    assert command.mode == "unheard" and command.angular_radps == 0.0
    assert route.cross_channel_rounds == 1
    assert route.step(0.08, ceiling_pair("C1", 0.5, 3.0)).angular_radps > 0.0       # same channel: it steers
    assert route.cross_channel_rounds == 1
    for t in (0.5, 1.0):
        route.step(t, [read("C1", 1, 0.5), read("C1", 2, 3.0, OTHER_CHANNEL_HZ)])
    failed = route.step(1.2, [read("C1", 1, 0.5), read("C1", 2, 3.0, OTHER_CHANNEL_HZ)])
    assert failed.mode == "failed" and route.cross_channel_rounds == 4
    assert "in 3 rounds heard by both antennas, but never on one channel" in failed.failure


# ------------------------------------------------------------------------------------------------ unheard target

def test_without_the_search_a_target_unheard_longer_than_the_timeout_fails_naming_the_tag():
    route = follower(unheard_timeout_s=2.0, unheard_search=False)
    route.start(["C1", "C2"], 0.0)
    route.step(0.5, ceiling_pair("C1", 1.0, 1.0))                 # heard at 0.5 s
    only_left = [TagObservation("C1", 1, 1.0, -60.0, FREQUENCY_HZ)]  # one antenna is not enough to steer
    for t in (1.0, 2.0, 2.5):
        command = route.step(t, only_left)
        assert command.mode == "unheard" and command.failure is None
    command = route.step(2.6, [])
    assert command.mode == "failed"
    assert (command.linear_mps, command.angular_radps) == (0.0, 0.0)
    assert "C1" in command.failure and "unheard" in command.failure


def test_unheard_clock_restarts_at_each_new_target():
    route = follower(unheard_timeout_s=2.0, unheard_search=False)
    route.start(["C1", "C2"], 0.0)
    assert route.step(1.9, [floor_read("F1")]).target_tag_id == "C2"
    assert route.step(3.8, []).mode == "unheard"       # 1.9 s since C2 became the target
    command = route.step(4.0, [])
    assert command.mode == "failed" and "C2" in command.failure


def drive(route: TagRouteFollower, until_s: float, heard=lambda x, y: False, start_s: float = 0.0):
    """Step ``route`` every round from ``start_s`` and integrate its commands (unicycle, from (0, 0) heading +x);
    ``heard(x, y)``: the target C2 is paired there. The commands and the poses they drove to."""
    x = y = yaw = 0.0
    commands, poses = [], []
    t = start_s
    while t < until_s:
        t += ROUND_S
        command = route.step(t, ceiling_pair("C2", 0.3, 0.3) if heard(x, y) else [])
        commands.append(command)
        if command.failure:
            break
        yaw += command.angular_radps * ROUND_S
        x += command.linear_mps * math.cos(yaw) * ROUND_S
        y += command.linear_mps * math.sin(yaw) * ROUND_S
        poses.append((x, y, yaw))
    return commands, poses


def at_c2(**settings) -> TagRouteFollower:
    route = follower(**settings)
    route.start(["C1", "C2"], 0.0)
    assert route.step(0.0, [floor_read("F1")]).target_tag_id == "C2"     # at C1: C2, the next, is unheard
    return route


def test_an_unheard_target_is_searched_for_with_a_full_turn_on_the_spot_then_an_expanding_square_spiral():
    commands, poses = drive(at_c2(search_radius_m=6.0, search_spacing_m=3.0), 400.0)
    modes = [command.mode for command in commands]
    first_turn = modes.index("search_turn")
    # A missed round is common: straight on for search_after_s (1 s) first.
    assert set(modes[:first_turn]) == {"unheard"} and first_turn * ROUND_S == pytest.approx(1.0, abs=2 * ROUND_S)
    turn = [c for c in commands if c.mode == "search_turn"]
    assert all(c.linear_mps == 0.0 and c.angular_radps == 1.0 for c in turn)
    assert len(turn) * ROUND_S == pytest.approx(2.0 * math.pi, abs=ROUND_S)          # one full turn at 1 rad/s
    spiral = [(c, pose) for c, pose in zip(commands, poses) if c.mode == "search_spiral"]
    assert all((c.linear_mps == 0.0) != (c.angular_radps == 0.0) for c, _ in spiral)  # drive, or turn on the spot
    # Legs 3, 3, 6, 6, 9, 9, 12, 12, 15 m: the first along the old heading, then quarter turns CCW.
    legs, length = [], 0.0
    for c, _ in spiral:
        if c.linear_mps:
            length += c.linear_mps * ROUND_S
        elif length:
            legs, length = legs + [length], 0.0
    legs.append(length)
    assert legs == pytest.approx([3, 3, 6, 6, 9, 9, 12, 12, 15], abs=0.05)
    xs, ys = [pose[0] for _, pose in spiral], [pose[1] for _, pose in spiral]
    # The square of half-width 6 m about where it began, 0.2 m on from the tag (turns held for whole rounds: 0.5 m).
    assert (min(xs), max(xs), min(ys), max(ys)) == pytest.approx((-5.8, 9.2, -6.0, 6.0), abs=0.5)
    assert commands[-1].mode == "failed"


def test_a_target_never_heard_fails_after_the_whole_search_saying_what_was_searched():
    commands, _ = drive(at_c2(), 1000.0)
    failed = commands[-1]
    searched_s = sum(ROUND_S for c in commands if c.mode in SEARCH_MODES)
    assert failed.mode == "failed" and (failed.linear_mps, failed.angular_radps) == (0.0, 0.0)
    assert "target tag 'C2'" in failed.failure and "not heard during the whole search" in failed.failure
    assert "a full turn on the spot at 1 rad/s, then a square spiral 3 m apart out to 6 m" in failed.failure
    assert f"{searched_s:.0f} s)" in failed.failure and "75 m driven" in failed.failure
    assert "unheard for" in failed.failure and searched_s > 10.0       # long past the paper's 10 s timeout


def test_the_search_ends_the_round_the_target_is_paired_and_seeking_resumes():
    """C2 at (-4, 5), heard within 3 m: out of reach from C1 and along the first legs, found on the spiral."""
    def heard(x, y):
        return math.hypot(x + 4.0, y - 5.0) < 3.0
    commands, poses = drive(at_c2(), 400.0, heard)
    found = next(i for i, c in enumerate(commands) if c.mode == "seeking")
    assert commands[found - 1].mode in SEARCH_MODES and heard(*poses[found - 1][:2])
    assert not any(heard(*pose[:2]) for pose in poses[:found - 1])     # the first round in reach ends it
    assert all(c.mode == "seeking" for c, pose in zip(commands[found:], poses[found - 1:]) if heard(*pose[:2]))


def test_a_search_starts_afresh_when_the_target_is_lost_again():
    route = at_c2()
    commands, _ = drive(route, 3.0)                                  # 1 s straight on, then the turn
    assert commands[-1].mode == "search_turn"
    assert route.step(3.04, ceiling_pair("C2", 0.3, 0.3)).mode == "seeking"
    commands, _ = drive(route, 6.0, start_s=3.04)
    modes = [c.mode for c in commands]
    assert modes[0] == "unheard" and "search_turn" in modes and "search_spiral" not in modes


def test_a_search_radius_below_its_spacing_is_refused():
    with pytest.raises(ValueError, match="search_radius_m"):
        follower(search_radius_m=1.0, search_spacing_m=3.0)
    follower(search_radius_m=1.0, search_spacing_m=3.0, unheard_search=False)


# -------------------------------------------------------------------------------------------- read validation

def test_observe_takes_a_read_as_the_controller_does_and_none_for_one_it_drops():
    """The checks themselves: test_inputs.py."""
    good = SimpleNamespace(tag_id="C1", antenna=1, i=0.0, q=0.0, phase_rad=7.0, rssi_dbm=-60.0,
                           frequency_hz=FREQUENCY_HZ)
    assert observe(good) == TagObservation("C1", 1, pytest.approx(7.0 - 2 * math.pi), -60.0, FREQUENCY_HZ)
    assert observe(SimpleNamespace(**{**vars(good), "rssi_dbm": math.nan})) is None


# --------------------------------------------------------------------------------------------- receding target

def rounds_with_range(start_m: float, step_m: float, count: int, t0: float = 0.0):
    """(time, reads) of rounds whose target range changes by ``step_m`` per round, dphi = 0."""
    for k in range(count):
        phase = float(round_trip_phase(start_m + step_m * k, FREQUENCY_HZ))
        yield t0 + ROUND_S * (k + 1), ceiling_pair("C1", phase, phase)


def test_receding_target_turns_after_a_few_rounds(controller):
    route = follower(controller)
    route.start(["C1"], 0.0)
    modes, commands = [], []
    for t, reads in rounds_with_range(3.0, +0.008, 8):     # 0.2 m/s away from the tag
        command = route.step(t, reads)
        modes.append(command.mode)
        commands.append(command)
    assert modes[0] == "seeking"                             # nothing to compare with yet
    assert "receding_turn" in modes[:4]
    assert modes[-1] == "receding_turn"
    assert commands[-1].angular_radps != 0.0
    assert abs(commands[-1].angular_radps) == pytest.approx(2.0)
    assert commands[-1].phase_difference_rad == pytest.approx(0.0, abs=1e-9)


def test_receding_turn_follows_the_side_the_phase_difference_points_to():
    route = follower()
    route.start(["C1"], 0.0)
    for k in range(6):
        base = float(round_trip_phase(3.0 + 0.008 * k, FREQUENCY_HZ))
        command = route.step(ROUND_S * (k + 1), ceiling_pair("C1", base + 0.05, base))   # tag slightly right
    assert command.mode == "receding_turn"
    assert command.angular_radps < 0.0


def test_approaching_target_keeps_seeking(controller):
    route = follower(controller)
    route.start(["C1"], 0.0)
    for t, reads in rounds_with_range(3.0, -0.008, 10):
        command = route.step(t, reads)
        assert command.mode == "seeking"
        assert command.angular_radps == pytest.approx(0.0, abs=1e-6)
        assert command.linear_mps == pytest.approx(0.2)


def test_seeking_resumes_when_the_range_shrinks_again():
    route = follower()
    route.start(["C1"], 0.0)
    for t, reads in rounds_with_range(3.0, +0.008, 6):
        command = route.step(t, reads)
    assert command.mode == "receding_turn"
    last_range = 3.0 + 0.008 * 5
    modes = [route.step(t, reads).mode for t, reads in rounds_with_range(last_range, -0.008, 12, t0=6 * ROUND_S)]
    assert modes[-1] == "seeking"


def test_receding_detection_can_be_switched_off():
    route = follower(receding_detection=False)
    route.start(["C1"], 0.0)
    modes = {route.step(t, reads).mode for t, reads in rounds_with_range(3.0, +0.008, 10)}
    assert modes == {"seeking"}


# ------------------------------------------------------------------------------------------------- phase track

def test_phase_track_gives_range_change_and_restarts_on_a_channel_hop():
    track = PhaseTrack()
    wavelength = wavelength_m(FREQUENCY_HZ)
    assert track.update(0.0, float(round_trip_phase(2.0, FREQUENCY_HZ)), FREQUENCY_HZ) is None
    change = track.update(0.04, float(round_trip_phase(2.008, FREQUENCY_HZ)), FREQUENCY_HZ)
    assert change[0] == pytest.approx(0.008, abs=1e-9)
    assert change[1] == pytest.approx(0.04)
    # Across the 0 / 2*pi wrap, closer by 5 mm.
    phase_at = lambda d: float(round_trip_phase(d, FREQUENCY_HZ))
    near_wrap = 10 * wavelength / 2 + 0.002                           # phase ~0.08 rad
    track.update(1.0, phase_at(near_wrap), FREQUENCY_HZ)
    assert track.update(1.04, phase_at(near_wrap - 0.005), FREQUENCY_HZ)[0] == pytest.approx(-0.005, abs=1e-9)
    assert track.update(1.08, 1.0, 927e6) is None                     # other channel: no comparison
    assert track.update(1.08, 1.0, 927e6) is None                     # same time: no rate
