"""Paper 003's two-tier navigation core: dead reckoning, go-to, geographic forwarding, the fix from one poll of
the HF reader, and seeded in-process runs through the simulated flat (config/worlds/two_tier_home.yaml), read by
the polled reader of reader_hf_floor.yaml, whose fixes stay within bounds."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rfidnav_common.tag_groups import TagGroup
from rfidnav_control.go_to import GoToSettings, go_to_command
from rfidnav_experiments.runners.two_tier import SETTINGS, Site, grid_radio_map, run_two_tier, survey_grid
from rfidnav_localization.dead_reckoning import TIER_TAG, TIER_WIFI, DeadReckoning, Fix
from rfidnav_localization.tag_fix import tag_fix
from rfidnav_planning.two_tier_navigation import (
    DONE,
    LOCATE,
    MAPPING,
    TAG_MAP,
    TO_LANDMARK,
    Landmark,
    MapTag,
    TwoTierNavigator,
    TwoTierSettings,
)
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.world import load_world

pytestmark = pytest.mark.tier("unit")

WORLD = CONFIG_DIR / "worlds" / "two_tier_home.yaml"


def test_dead_reckoning_moves_by_odometry_distance_along_the_compass_and_grows_its_sd() -> None:
    reckoning = DeadReckoning(drift_per_m=0.05)
    reckoning.on_odometry((0.0, 0.0, 1.0))            # the odometry frame's own heading is irrelevant
    reckoning.on_compass(math.pi / 2.0)
    reckoning.on_fix(Fix((2.0, 3.0), 0.05, TIER_TAG, "G1-00"))
    reckoning.on_odometry((math.cos(1.0), math.sin(1.0), 1.0))      # 1 m forward
    reckoning.on_odometry((math.cos(1.0) - 0.5 * math.cos(1.0), math.sin(1.0) - 0.5 * math.sin(1.0), 1.0))
    estimate = reckoning.estimate()                   # 1 m forward then 0.5 m back: 0.5 m north, 1.5 m driven
    assert estimate.position == pytest.approx((2.0, 3.5))
    assert estimate.distance_since_fix_m == pytest.approx(1.5)
    assert estimate.sd_m == pytest.approx(0.05 + 0.05 * 1.5)
    with pytest.raises(ValueError, match="odometry"):
        reckoning.on_odometry((math.nan, 0.0, 0.0))


def test_go_to_turns_on_the_spot_first_then_drives_and_stops_within_tolerance() -> None:
    settings = GoToSettings(tolerance_m=0.02)
    linear, angular = go_to_command((0.0, 0.0), 0.0, (0.0, 1.0), settings)
    assert linear == 0.0 and angular == pytest.approx(settings.turn_rate_radps)
    linear, angular = go_to_command((0.0, 0.0), math.pi / 2.0 - 0.1, (0.0, 1.0), settings)
    assert linear > 0.0 and angular > 0.0
    assert go_to_command((0.0, 0.99), math.pi / 2.0, (0.0, 1.0), settings) is None


def cross_tags(group_id: str, centre: tuple[float, float]) -> list[MapTag]:
    arm = [(-0.15, 0.0), (-0.1, 0.0), (0.1, 0.0), (0.15, 0.0), (0.0, -0.15), (0.0, 0.15), (0.0, 0.0)]
    return [MapTag(f"{group_id}-{k:02d}", (centre[0] + dx, centre[1] + dy), group_id, "cross")
            for k, (dx, dy) in enumerate(arm)]


def test_a_landmark_is_known_from_its_tags() -> None:
    landmark = Landmark.of(cross_tags("G", (1.0, 2.0)))
    assert landmark.centre == pytest.approx((1.0, 2.0)) and landmark.size_m == pytest.approx(0.3)


def test_the_flow_locates_downloads_the_map_then_forwards_through_the_landmark_nearest_the_target() -> None:
    navigator = TwoTierNavigator(TwoTierSettings(landmark_spacing_m=4.0))
    decision = navigator.start((9.0, 0.0))
    assert decision.request.kind == LOCATE and decision.command == (0.0, 0.0)
    decision = navigator.on_located((0.3, 0.2), 1.0)
    assert decision.phase == MAPPING and decision.request.kind == TAG_MAP
    assert decision.request.centre == (0.3, 0.2)
    tags = [*cross_tags("A", (0.0, 0.0)), *cross_tags("B", (3.0, 1.0)), *cross_tags("C", (3.4, -1.8)),
            *cross_tags("D", (6.0, 0.0)), *cross_tags("E", (9.0, 0.0))]
    decision = navigator.on_tag_map(tags)
    assert decision.phase == TO_LANDMARK and navigator.waypoint.group_id == "A"    # nearest to the estimate
    navigator.step((0.0, 0.0, 0.0), 0.0, [])
    navigator.step((0.01, 0.0, 0.0), 0.0, ["A-06"])              # reads A's centre tag: a fix
    assert navigator.reckoning.last_fix.tier == TIER_TAG and navigator.progress.visited == ["A"]
    # Within 4 m of the fix: B (3.2 m) and C (3.9 m); C is nearer to the target (5.9 m against 6.1 m).
    assert navigator.waypoint.group_id == "C"
    assert navigator.progress.fixes[0].tier == TIER_WIFI


def test_a_polls_fix_is_within_range_of_the_tags_read_and_out_of_range_of_their_neighbours() -> None:
    tags = cross_tags("A", (0.0, 0.0))
    positions = {tag.tag_id: tag.position for tag in tags}
    read = ["A-00", "A-01"]                                      # (-0.15, 0) and (-0.10, 0): the arm's end
    fix = tag_fix([(tag_id, positions[tag_id]) for tag_id in read],
                  [position for tag_id, position in positions.items() if tag_id not in read], 0.05)
    assert all(math.dist(fix.position, positions[tag_id]) <= 0.05 for tag_id in read)
    assert fix.position[0] == pytest.approx(-0.125, abs=0.003) and fix.position[1] == pytest.approx(0.0, abs=0.003)
    assert 0.0 < fix.sd_m < 0.05 and fix.tag_id in read


def test_a_polls_fix_is_nearer_the_robot_than_the_tags_it_read() -> None:
    """Over random positions above a 30 cm cross (tags 5 cm apart, read within 5 cm): the region the reads leave
    beats the paper's position of the tag read, and the mean of the tags read."""
    group = TagGroup("G", "cross", (0.0, 0.0), 0.30, 0.3)
    tags = list(group.tags())
    positions = np.array([position for _, position in tags])
    rng = np.random.default_rng(5)
    ours, first_tag, mean_of_tags = [], [], []
    while len(ours) < 600:
        robot = rng.uniform(-0.2, 0.2, 2)
        distance = np.hypot(*(positions - robot).T)
        read = np.flatnonzero(distance <= 0.05)
        if len(read) == 0:
            continue
        fix = tag_fix([tags[i] for i in read], [tags[i][1] for i in np.flatnonzero(distance > 0.05)], 0.05)
        ours.append(math.dist(fix.position, robot))
        first_tag.append(distance[read[0]])
        mean_of_tags.append(math.dist(positions[read].mean(axis=0), robot))
    assert np.median(ours) < np.median(mean_of_tags) < np.median(first_tag)
    assert np.median(ours) < 0.03


def test_every_round_that_reads_other_known_tags_is_a_fix_and_a_round_without_reads_is_none() -> None:
    navigator = TwoTierNavigator(TwoTierSettings())
    navigator.start((3.0, 0.0))
    navigator.on_located((0.0, 0.0), 1.0)
    navigator.on_tag_map([*cross_tags("A", (0.0, 0.0)), *cross_tags("B", (3.0, 0.0))])
    navigator.step((0.0, 0.0, 0.0), 0.0, [])
    fixes = len(navigator.progress.fixes)
    navigator.step((0.01, 0.0, 0.0), 0.0, ["A-06"])
    navigator.step((0.02, 0.0, 0.0), 0.0, [])                   # no round, or a failed poll: nothing known
    navigator.step((0.03, 0.0, 0.0), 0.0, ["A-06"])             # the same tags again: dead reckoning carries on
    assert navigator.estimate().position[0] == pytest.approx(navigator.progress.fixes[-1].position[0] + 0.02)
    navigator.step((0.12, 0.0, 0.0), 0.0, ["A-02", "X-99"])     # the next poll, 10 cm on; an unknown tag
    assert len(navigator.progress.fixes) == fixes + 2
    assert navigator.progress.fixes[-1].tag_id == "A-02" and navigator.progress.unknown_tags == 1
    assert navigator.progress.visited == ["A"]                  # the landmark is reached once


def test_a_target_without_landmarks_near_the_estimate_fails_with_the_reason() -> None:
    navigator = TwoTierNavigator(TwoTierSettings())
    navigator.start((1.0, 1.0))
    navigator.on_located((0.0, 0.0), 1.0)
    decision = navigator.on_tag_map([])
    assert decision.finished and not decision.success and "no landmark" in decision.message
    assert navigator.phase == DONE


@pytest.fixture(scope="module")
def site() -> Site:
    world = load_world(WORLD)
    return Site.of(world, grid_radio_map(world, survey_grid(world, 1.0, (1.0, 1.0)).points, np.random.default_rng(1)))


@pytest.mark.tier("slow")
@pytest.mark.parametrize("seed", [0, 1, 2, 4])
def test_a_seeded_run_through_the_flat_arrives_and_its_fixes_stay_within_bounds(site: Site, seed: int) -> None:
    run = run_two_tier(site, (1.0, 1.0, 0.3), (10.8, 6.8), SETTINGS, np.random.default_rng(seed), seed)
    assert run.success, run.message
    assert run.final_error_m < 0.10
    assert run.fix_errors_m and max(run.fix_errors_m) < 0.06      # a tag fix: within the 5 cm reader range
    assert float(np.median(run.fix_errors_m)) < 0.04
    assert run.visited[-1] == "T5" and run.searches >= 1
    assert all(error < 5.0 for error in run.tier_one_errors_m)


@pytest.mark.tier("slow")
def test_a_run_whose_search_drives_into_a_wall_backs_off_asks_tier_one_and_still_arrives(site: Site) -> None:
    # Seed 3, no floor plan: the WiFi estimate puts the first spiral in the flat's south-west corner, where the walls
    # stop it. The stalled wheels (odometry that does not follow the command) send it back and to tier one.
    run = run_two_tier(site, (1.0, 1.0, 0.3), (10.8, 6.8), SETTINGS, np.random.default_rng(3), 3, max_time_s=300.0)
    assert run.success, run.message
    assert 0 < run.bumps <= SETTINGS.stall_steps * SETTINGS.max_stalls     # pressed only until it noticed, each time


def test_without_intermediate_landmarks_dead_reckoning_drifts_further(site: Site) -> None:
    """Fig. 11 of paper 003 in one pair: direct moving accumulates more error than indirect moving. The flat's
    walls are taken away: this is about drift, and a run that stalls at a wall has no final error."""
    open_flat = dataclasses.replace(site, world=dataclasses.replace(site.world, walls=()))
    rng_seed = 7
    direct = run_two_tier(open_flat, (1.0, 1.0, 0.3), (11.0, 1.0), dataclasses.replace(
        SETTINGS, landmark_spacing_m=0.5, calibration_distance_m=100.0), np.random.default_rng(rng_seed), rng_seed)
    indirect = run_two_tier(open_flat, (1.0, 1.0, 0.3), (11.0, 1.0), dataclasses.replace(
        SETTINGS, landmark_spacing_m=4.0, calibration_distance_m=100.0), np.random.default_rng(rng_seed), rng_seed)
    assert direct.success and indirect.success
    assert direct.bumps == indirect.bumps == 0
    assert indirect.final_error_m < direct.final_error_m
