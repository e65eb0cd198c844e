"""Partition localization of paper 000 and the particle filter: pure-module tests with numbers.

Drives are simulated exactly: the robot's true pose moves a few millimetres per inventory round and each
round reads the deployment's true partition there (``Deployment.partition_at``), as the ids a reader reports.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest

from rfidnav_common.config import node_parameter_values, parameters_from_mapping
from rfidnav_common.errors import ConfigError
from rfidnav_common.tag_lattice import (
    LAYOUTS,
    Deployment,
    make_deployment,
    partitions_along_segment,
)
from rfidnav_localization.parameters import PartitionLocalizerParameters
from rfidnav_localization.partition import (
    LocalizationEstimate,
    LocalizerSettings,
    PartitionLocalizer,
    orientation_bounds,
    read_range_of,
)
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

ROUND_S = 0.04


def angle_error(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2.0 * math.pi))


def within_bounds(angle: float, bounds: tuple[float, float], tolerance: float = 1e-9) -> bool:
    lower, upper = bounds
    return math.remainder(angle - lower, 2.0 * math.pi) % (2.0 * math.pi) <= upper - lower + tolerance \
        or angle_error(angle, lower) <= tolerance


def deployment(layout: str, r: float) -> Deployment:
    return make_deployment(layout, r, (-200.0 * r, -200.0 * r, 200.0 * r, 200.0 * r))


def read_ids(field: Deployment, x: float, y: float) -> list[str]:
    return [field.lattice.tag_id(c) for c in field.partition_at(x, y)]


@dataclass
class Round:
    tag_ids: list[str]
    odom: tuple[float, float, float]
    truth: tuple[float, float, float]


class Robot:
    """A robot driving straight or rotating in place over a deployment; odometry in its own frame (rotated
    and shifted from the map) with optional relative errors on each step."""

    def __init__(self, field: Deployment, rng: np.random.Generator, odometry_noise: float = 0.0,
                 step_m: float = 0.004, antenna_offset_m: float = 0.0) -> None:
        self.field = field
        self.antenna_offset_m = antenna_offset_m
        self.rng = rng
        self.noise = odometry_noise
        self.step_m = step_m
        r = field.read_range_m
        self.x, self.y = rng.uniform(-5.0 * r, 5.0 * r, 2)
        self.yaw = rng.uniform(-math.pi, math.pi)
        self.odom = [1.0, -2.0, 0.7]
        self.rounds: list[Round] = []

    def record(self) -> None:
        antenna = (self.x + self.antenna_offset_m * math.cos(self.yaw),
                   self.y + self.antenna_offset_m * math.sin(self.yaw))
        self.rounds.append(Round(read_ids(self.field, *antenna), tuple(self.odom), (self.x, self.y, self.yaw)))

    def drive(self, distance_m: float) -> None:
        for _ in range(int(distance_m / self.step_m)):
            self.x += self.step_m * math.cos(self.yaw)
            self.y += self.step_m * math.sin(self.yaw)
            measured = self.step_m * (1.0 + self.noise * self.rng.normal())
            self.odom[0] += measured * math.cos(self.odom[2])
            self.odom[1] += measured * math.sin(self.odom[2])
            self.record()

    def rotate(self, angle: float, steps: int = 10) -> None:
        for _ in range(steps):
            self.yaw += angle / steps
            self.odom[2] = math.remainder(self.odom[2] + angle / steps * (1.0 + self.noise * self.rng.normal()),
                                          2.0 * math.pi)
            self.record()


def replay(localizer: PartitionLocalizer, rounds: list[Round]) -> list[LocalizationEstimate]:
    return [localizer.update(k * ROUND_S, round_.tag_ids, round_.odom) for k, round_ in enumerate(rounds)]


def paper_localizer(seed: int = 0, **settings) -> PartitionLocalizer:
    return PartitionLocalizer(LocalizerSettings(**settings), np.random.default_rng(seed))


# ------------------------------------------------------------------------------------------- position

@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("r", [0.02, 0.5])
def test_position_is_the_mean_of_the_tags_read_with_the_region_spread_as_covariance(layout: str, r: float) -> None:
    field = deployment(layout, r)
    rng = np.random.default_rng(7)
    localizer = paper_localizer()
    for k, (x, y) in enumerate(rng.uniform(-20.0 * r, 20.0 * r, (60, 2))):
        tags = field.partition_at(x, y)
        estimate = localizer.update(k * ROUND_S, read_ids(field, x, y), (0.0, 0.0, 0.0))
        expected = field.lattice.positions(np.array(sorted(tags))).mean(axis=0)
        assert estimate.position == pytest.approx(tuple(expected), abs=1e-12)
        assert estimate.partition == tags
        assert list(estimate.partition_tag_ids) == sorted(field.lattice.tag_id(c) for c in tags)
        var_x, cov_xy, var_y = estimate.position_covariance
        # A partition lies within r of its tags' mean, and has an area: a positive definite spread below r^2.
        assert 0.0 < var_x < r * r and 0.0 < var_y < r * r and cov_xy * cov_xy < var_x * var_y
        # The true point is a typical member of the region: within a few standard deviations.
        assert math.dist((x, y), estimate.position) <= r * (1.0 + 1e-9)
    assert estimate.read_range_m == pytest.approx(r, abs=1e-12)
    assert estimate.lattice == field.lattice
    assert (estimate.rogue_count, estimate.undecodable_count) == (0, 0)


def test_the_read_range_is_recovered_from_the_spacing_in_the_ids() -> None:
    for layout in LAYOUTS:
        for r in (0.02, 0.0913, 0.2, 0.5, 1.0):
            lattice = make_deployment(layout, r, (0.0, 0.0, 1.0, 1.0)).lattice
            assert read_range_of(lattice) == pytest.approx(r, abs=1e-15)


def test_undecodable_ids_and_tags_of_another_lattice_are_ignored_and_counted() -> None:
    field = deployment("triangular", 0.02)
    other = deployment("grid", 0.02)
    localizer = paper_localizer()
    good = read_ids(field, 0.003, 0.001)
    centre = field.lattice.positions(np.array(sorted(field.partition_at(0.003, 0.001)))).mean(axis=0)
    junk = ["F1", "", "E28011606000020000000000", "A2ZZ0000000000000000000", good[0][:-1]]
    estimate = localizer.update(0.0, junk + good + good, (0.0, 0.0, 0.0))   # repeats count once
    assert estimate.undecodable_count == len(junk)
    assert estimate.partition == field.partition_at(0.003, 0.001)
    # The first lattice seen is the robot's; a tag of another lattice cannot be placed in its frame.
    foreign = other.lattice.tag_id((0, 0))
    estimate = localizer.update(ROUND_S, good + [foreign], (0.0, 0.0, 0.0))
    assert estimate.undecodable_count == len(junk) + 1
    assert estimate.partition == field.partition_at(0.003, 0.001) and estimate.lattice == field.lattice
    # Nothing decodable at all: an empty round, which keeps the position.
    estimate = localizer.update(2 * ROUND_S, ["junk"], (0.0, 0.0, 0.0))
    assert estimate.partition == frozenset() and estimate.undecodable_count == len(junk) + 2
    assert estimate.position == pytest.approx(tuple(centre))


@pytest.mark.parametrize("method", ["paper", "filter"])
@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_rogue_tag_read_with_the_true_ones_is_rejected_and_reported(method: str, layout: str, seed: int) -> None:
    r = 0.02
    field = deployment(layout, r)
    rng = np.random.default_rng(seed)
    localizer = paper_localizer(seed, method=method)
    x, y = rng.uniform(-5.0 * r, 5.0 * r, 2)
    while len(field.partition_at(x, y)) < 2:   # one against one would be a tie (see the next test)
        x, y = rng.uniform(-5.0 * r, 5.0 * r, 2)
    rogue = field.lattice.tag_id((int(rng.integers(40, 80)), int(rng.integers(-80, 80))))
    estimate = localizer.update(0.0, read_ids(field, x, y) + [rogue], (0.0, 0.0, 0.0))
    assert estimate.rejected_tag_ids == (rogue,)
    assert estimate.rogue_count == 1
    assert estimate.partition == field.partition_at(x, y)
    assert math.dist(estimate.position, (x, y)) <= r
    # Counted since start, reported per round.
    estimate = localizer.update(ROUND_S, read_ids(field, x, y), (0.0, 0.0, 0.0))
    assert (estimate.rejected_tag_ids, estimate.rogue_count) == ((), 1)


def test_a_tie_between_rogue_groups_keeps_the_one_near_the_previous_estimate() -> None:
    field = deployment("triangular", 0.02)
    localizer = paper_localizer()
    here = field.lattice.tag_id((0, 0))
    far = field.lattice.tag_id((50, 0))
    localizer.update(0.0, [here], (0.0, 0.0, 0.0))
    estimate = localizer.update(ROUND_S, [far, here], (0.0, 0.0, 0.0))   # one against one
    assert estimate.partition == frozenset({(0, 0)}) and estimate.rejected_tag_ids == (far,)


def test_an_empty_round_keeps_the_estimate_and_is_not_a_partition_change() -> None:
    field = deployment("compressed", 0.02)
    localizer = paper_localizer()
    first = localizer.update(0.0, read_ids(field, 0.001, 0.002), (0.0, 0.0, 0.0))
    assert first.partition_changed and first.partitions_traversed == 0
    empty = localizer.update(ROUND_S, [], (0.0, 0.0, 0.0))
    assert empty.partition == frozenset() and empty.partition_tag_ids == () and not empty.partition_changed
    assert empty.position == first.position and empty.position_covariance == first.position_covariance
    again = localizer.update(2 * ROUND_S, read_ids(field, 0.001, 0.002), (0.0, 0.0, 0.0))
    assert not again.partition_changed and again.partitions_traversed == 0


def test_before_any_tag_there_is_no_position_and_no_heading() -> None:
    for method in ("paper", "filter"):
        estimate = paper_localizer(method=method).update(0.0, [], (0.0, 0.0, 0.0))
        assert (estimate.position, estimate.yaw, estimate.yaw_bounds, estimate.lattice) == (None, None, None, None)
        assert estimate.partitions_traversed == 0 and not estimate.partition_changed


# ---------------------------------------------------------------------------------------- orientation

def random_traversals(layout: str, r: float, count: int, seed: int):
    """(heading, partitions passed in order) of straight segments 15 r long at random places and headings."""
    field = deployment(layout, r)
    rng = np.random.default_rng(seed)
    for _ in range(count):
        start = rng.uniform(-10.0 * r, 10.0 * r, 2)
        heading = rng.uniform(-math.pi, math.pi)
        end = start + 15.0 * r * np.array((math.cos(heading), math.sin(heading)))
        yield heading, [piece.tags for piece in partitions_along_segment(field, tuple(start), tuple(end))], field


@pytest.mark.parametrize("layout", LAYOUTS)
def test_orientation_bounds_contain_the_true_heading_and_shrink_with_more_partitions(layout: str) -> None:
    r = 0.02
    widths: dict[int, list[float]] = {2: [], 4: [], 8: []}
    checked = 0
    for heading, partitions, field in random_traversals(layout, r, 150, seed=11):
        lattice = field.lattice
        assert orientation_bounds(lattice, r, partitions[:1]) is None
        for count in range(2, min(len(partitions), 12) + 1):
            bounds = orientation_bounds(lattice, r, partitions[:count])
            lower, upper = bounds
            assert -math.pi < lower <= math.pi and upper >= lower
            assert within_bounds(heading, bounds, tolerance=1e-6), (count, bounds, heading)
            checked += 1
            if count in widths:
                widths[count].append(upper - lower)
    assert checked > 1000
    mean_width = {count: float(np.mean(values)) for count, values in widths.items()}
    assert mean_width[2] > mean_width[4] > mean_width[8], mean_width
    assert mean_width[8] < math.radians(45.0), mean_width


@pytest.mark.parametrize("layout, limit_deg", [("grid", 8.0), ("triangular", 5.0), ("compressed", 5.0)])
def test_paper_yaw_error_after_eight_partitions_at_2_cm_is_a_few_degrees(layout: str, limit_deg: float) -> None:
    r = 0.02
    errors = []
    for seed in range(30):
        robot = Robot(deployment(layout, r), np.random.default_rng(seed), step_m=0.002)
        robot.drive(12.0 * r)
        localizer = paper_localizer(seed)
        for estimate, round_ in zip(replay(localizer, robot.rounds), robot.rounds):
            if estimate.partitions_traversed == 8:
                assert within_bounds(round_.truth[2], estimate.yaw_bounds, tolerance=1e-6)
                errors.append(angle_error(estimate.yaw, round_.truth[2]))
                break
    assert len(errors) >= 25
    assert math.degrees(np.mean(errors)) < limit_deg, math.degrees(np.mean(errors))


# -------------------------------------------------------------------------------- turns and stretches

def test_a_turn_detected_from_odometry_starts_a_new_stretch_and_carries_the_heading() -> None:
    r = 0.02
    robot = Robot(deployment("triangular", r), np.random.default_rng(5), step_m=0.002)
    robot.drive(15.0 * r)
    straight = len(robot.rounds)
    robot.rotate(math.pi / 2.0)
    turned = len(robot.rounds)
    robot.drive(1.5 * r)
    localizer = paper_localizer()
    estimates = replay(localizer, robot.rounds)
    before = estimates[straight - 1]
    assert before.partitions_traversed >= 8 and before.yaw is not None
    fraction = LocalizerSettings().motion_noise_fraction
    after_turn = estimates[turned - 1]
    assert after_turn.partitions_traversed == 0
    assert angle_error(after_turn.yaw, before.yaw + math.pi / 2.0) < 1e-9
    half_before = (before.yaw_bounds[1] - before.yaw_bounds[0]) / 2.0
    half_after = (after_turn.yaw_bounds[1] - after_turn.yaw_bounds[0]) / 2.0
    assert half_after == pytest.approx(half_before + fraction * math.pi / 2.0)
    assert after_turn.yaw_std == pytest.approx(half_after / 2.0)
    # One partition change after the turn: its region-to-boundary bound is far wider, the carried one stays.
    first_change = next(e for e in estimates[turned:] if e.partitions_traversed == 1)
    assert first_change.yaw == pytest.approx(after_turn.yaw) and first_change.yaw_bounds == after_turn.yaw_bounds
    # Exact odometry: the heading error after the turn is the one before it.
    error_before = angle_error(before.yaw, robot.rounds[straight - 1].truth[2])
    assert angle_error(estimates[-1].yaw, robot.rounds[-1].truth[2]) == pytest.approx(error_before)


def test_after_a_turn_a_narrower_partition_bound_replaces_the_carried_heading() -> None:
    r = 0.02
    robot = Robot(deployment("compressed", r), np.random.default_rng(2), step_m=0.002)
    robot.drive(2.0 * r)              # a short first stretch: a wide bound to carry
    straight = len(robot.rounds)
    robot.rotate(-1.0)
    robot.drive(20.0 * r)
    estimates = replay(paper_localizer(), robot.rounds)
    carried = estimates[straight + 9]
    final = estimates[-1]
    assert carried.partitions_traversed == 0 and final.partitions_traversed >= 10
    assert final.yaw_std < carried.yaw_std / 2.0
    assert within_bounds(robot.rounds[-1].truth[2], final.yaw_bounds, tolerance=1e-6)


# ------------------------------------------------------------------------------------ particle filter

def straight_then_turning(r: float, seed: int, odometry_noise: float) -> Robot:
    robot = Robot(deployment("triangular", r), np.random.default_rng(seed), odometry_noise=odometry_noise)
    robot.drive(10.0 * r)
    robot.rotate(float(np.random.default_rng(seed).uniform(0.5, 2.0)))
    robot.drive(10.0 * r)
    return robot


def final_errors(method: str, robot: Robot, seed: int) -> tuple[float, float, LocalizationEstimate]:
    estimate = replay(paper_localizer(seed, method=method), robot.rounds)[-1]
    x, y, yaw = robot.rounds[-1].truth
    return math.dist(estimate.position, (x, y)), angle_error(estimate.yaw, yaw), estimate


@pytest.mark.tier("slow")
@pytest.mark.parametrize("r, odometry_noise", [(0.02, 0.0), (0.02, 0.02), (0.2, 0.02), (0.5, 0.02)])
def test_the_filter_ends_far_closer_than_the_paper_method_on_a_straight_then_turning_drive(
        r: float, odometry_noise: float) -> None:
    paper, filtered = [], []
    for seed in range(4):
        robot = straight_then_turning(r, seed, odometry_noise)
        paper.append(final_errors("paper", robot, seed))
        filtered.append(final_errors("filter", robot, seed))
        assert filtered[-1][2].filter_reinitialisations == 0
        assert filtered[-1][1] <= 3.0 * filtered[-1][2].yaw_std, "the heading sd is honest"
    paper_position = np.mean([e[0] for e in paper])
    filter_position = np.mean([e[0] for e in filtered])
    assert filter_position < paper_position / 2.0, (filter_position, paper_position)
    assert filter_position < 0.25 * r
    assert math.degrees(np.mean([e[1] for e in filtered])) < 3.0


@pytest.mark.tier("slow")
@pytest.mark.parametrize("r, turn_deg", [(0.02, 180.0), (0.2, 360.0)])
def test_turning_on_the_spot_with_the_antenna_ahead_of_the_axis_finds_the_heading(r: float, turn_deg: float) -> None:
    """The antenna sweeps a circle of crossings; paired crossings fix the heading without driving."""
    offset = 0.25
    errors = []
    for seed in range(4):
        robot = Robot(deployment("triangular", r), np.random.default_rng(seed), antenna_offset_m=offset)
        robot.record()
        turn = math.radians(turn_deg)
        robot.rotate(turn, steps=math.ceil(abs(turn) * offset / 0.004))
        localizer = paper_localizer(seed, method="filter", antenna_offset_m=offset)
        final = replay(localizer, robot.rounds)[-1]
        x, y, yaw = robot.rounds[-1].truth
        assert final.filter_reinitialisations == 0
        assert final.yaw_std < math.radians(10.0)
        assert angle_error(final.yaw, yaw) < math.radians(10.0)
        assert math.dist(final.position, (x, y)) < r
        errors.append(angle_error(final.yaw, yaw))
    assert math.degrees(np.mean(errors)) < 3.0


def test_the_filter_counts_partitions_per_stretch_and_knows_no_heading_before_a_crossing() -> None:
    r = 0.02
    robot = Robot(deployment("triangular", r), np.random.default_rng(3))
    robot.drive(8.0 * r)
    straight = len(robot.rounds)
    robot.rotate(1.0)
    estimates = replay(paper_localizer(3, method="filter"), robot.rounds)
    first_change = next(k for k, e in enumerate(estimates) if e.partitions_traversed == 1)
    assert all(e.yaw is None for e in estimates[:first_change])
    assert estimates[first_change].yaw is not None and estimates[first_change].yaw_std > 0.0
    assert estimates[straight - 1].partitions_traversed >= 4
    assert estimates[-1].partitions_traversed == 0
    lower, upper = estimates[-1].yaw_bounds
    assert upper - lower == pytest.approx(4.0 * estimates[-1].yaw_std)


def test_the_filter_reinitialises_when_the_robot_is_kidnapped_and_finds_it_again() -> None:
    r = 0.02
    robot = Robot(deployment("triangular", r), np.random.default_rng(4))
    robot.drive(10.0 * r)
    robot.x += 30.0 * r        # carried away: the odometry knows nothing of it
    robot.y -= 12.0 * r
    robot.drive(15.0 * r)
    estimates = replay(paper_localizer(4, method="filter"), robot.rounds)
    final = estimates[-1]
    assert final.filter_reinitialisations >= 1
    assert math.dist(final.position, robot.rounds[-1].truth[:2]) < r


def test_settings_and_parameters_name_the_bad_field() -> None:
    with pytest.raises(ValueError, match="^method: "):
        PartitionLocalizer(LocalizerSettings(method="magic"), np.random.default_rng(0))
    with pytest.raises(ValueError, match="^boundary_softness_m: "):
        LocalizerSettings(boundary_softness_m=0.0).validate()
    with pytest.raises(ConfigError, match="^test.yaml: antenna: "):
        parameters_from_mapping(PartitionLocalizerParameters, {"antenna": 0}, "test.yaml")
    with pytest.raises(ConfigError, match="particles"):
        parameters_from_mapping(PartitionLocalizerParameters, {"particles": 3}, "test.yaml")


@pytest.mark.parametrize("name, method", [("paper", "paper"), ("filter", "filter"), ("filter_paper_robot", "filter")])
def test_parameter_files_set_every_parameter_and_the_paper_file_equals_the_defaults(name: str, method: str) -> None:
    path = WORKSPACE / f"config/params/partition_localizer_{name}.yaml"
    values = node_parameter_values(PartitionLocalizerParameters, path, "partition_localizer")
    assert set(values) == {f.name for f in dataclasses.fields(PartitionLocalizerParameters)}
    parameters = parameters_from_mapping(PartitionLocalizerParameters, values, str(path))
    assert parameters.settings().method == method
    if name == "paper":
        assert parameters == PartitionLocalizerParameters()
    else:
        assert dataclasses.replace(parameters, method="paper", antenna=1, antenna_offset_m=0.0) == \
            PartitionLocalizerParameters()
    # The antenna the localizer listens to reads where the localizer thinks: the reader's file agrees.
    from rfidnav_sim.parameters import ReaderParameters
    reader_file = WORKSPACE / "config/params/reader_floor_lattice.yaml"
    reader = ReaderParameters(**{**node_parameter_values(ReaderParameters, reader_file, "rfid_reader_sim"),
                                 "world_file": "unused"})
    antenna = reader.reader_model().antennas[parameters.antenna - 1]
    assert not antenna.facing_up
    assert antenna.position[:2] == pytest.approx((parameters.antenna_offset_m, 0.0))
