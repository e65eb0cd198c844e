"""The fused localizer's measurement models (rfidnav_localization.fused.models) against likelihoods computed by
hand, and against what the simulator's sensors produce; the filter's handling of absent and unknown evidence; a
new kind of evidence as one class (rfidnav_localization.fused.measurement) defined here, outside the package."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.rf import wavelength_m
from rfidnav_common.wall_tags import InductionArea, WallTag
from rfidnav_localization.fused.filter import HELD_READINGS, FusedFilter, HeldReadings
from rfidnav_localization.fused.kinds import MEASUREMENTS, PhaseReading
from rfidnav_localization.fused.measurement import Evidence, Likelihoods, Measurement, Particles
from rfidnav_localization.fused.models import (
    CompassModel,
    FloorModel,
    PhaseDifferenceModel,
    WallTagModel,
    WifiModel,
    robust_gaussian,
)
from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_sim.rfid_model import Antenna, ReaderModel, ReaderSimulator

pytestmark = pytest.mark.tier("unit")

EPS = 0.01


def pose(x: float, y: float, yaw: float) -> np.ndarray:
    return np.array([[x], [y], [yaw]])


def sigmoid(value: float) -> float:
    return 1.0 / (1.0 + math.exp(-value))


def phase_by_hand(residual: float, sd: float, sd_best: float) -> float:
    """A phase reading's Gaussian density (1 / sd kept) mixed with 1 % outliers uniform over the circle, relative
    to a perfect reading at the smallest sd."""
    def density(r: float, s: float) -> float:
        return EPS / (2 * math.pi) + (1 - EPS) * math.exp(-0.5 * (r / s) ** 2) / (math.sqrt(2 * math.pi) * s)
    return math.log(density(residual, sd) / density(0.0, sd_best))


def test_a_floor_tag_read_scores_the_soft_disc_at_the_mounted_antenna_and_an_unread_one_its_complement() -> None:
    model = FloorModel(antenna_xy=(0.1, 0.0), softness_m=0.004, eps=EPS)
    # Heading +y, so the antenna 0.1 m ahead sits at (1, 2.1); the tag is 0.05 m from it, inside r = 0.06.
    tag = np.array([[1.03, 2.14]])
    # Scaled by the best a tag can score (1 - eps), so that a perfect round scores 0.
    read_by_hand = math.log(EPS + (1 - 2 * EPS) * sigmoid((0.06 - 0.05) / 0.004)) - math.log(1 - EPS)
    unread_by_hand = math.log(EPS + (1 - 2 * EPS) * sigmoid(-(0.06 - 0.05) / 0.004)) - math.log(1 - EPS)
    state = pose(1.0, 2.0, math.pi / 2)
    assert model.log_likelihood(state, tag, np.zeros((0, 2)), 0.06)[0] == pytest.approx(read_by_hand, rel=1e-9)
    assert model.log_likelihood(state, np.zeros((0, 2)), tag, 0.06)[0] == pytest.approx(unread_by_hand, rel=1e-9)
    assert read_by_hand == pytest.approx(-0.08812 + 0.01005, abs=1e-4)


def test_the_phase_difference_of_the_two_antennas_scores_the_round_trip_path_difference_modulo_two_pi() -> None:
    model = PhaseDifferenceModel((0.0, 0.03, 0.30), (0.0, -0.03, 0.30), noise_rad_per_m=0.02, floor_rad=0.02,
                                 eps=EPS)
    tag, frequency = (1.0, 0.5, 3.0), 915.25e6
    d1 = math.sqrt(1.0 ** 2 + 0.47 ** 2 + 2.7 ** 2)
    d2 = math.sqrt(1.0 ** 2 + 0.53 ** 2 + 2.7 ** 2)
    predicted = 4 * math.pi * (d1 - d2) / (299_792_458.0 / frequency)
    sd = math.sqrt((0.02 * d1) ** 2 + (0.02 * d2) ** 2 + 0.02 ** 2)
    at_origin = pose(0.0, 0.0, 0.0)
    assert model.log_likelihood(at_origin, tag, predicted + 0.05, frequency)[0] == pytest.approx(
        phase_by_hand(0.05, sd, 0.02), rel=1e-9)
    # Phase is modulo 2 pi: a whole turn more is the same reading.
    wrapped = predicted + 0.05 + 2 * math.pi
    assert model.log_likelihood(at_origin, tag, wrapped, frequency)[0] == pytest.approx(
        phase_by_hand(0.05, sd, 0.02), rel=1e-9)
    # Even a perfect reading scores below 0 at this distance: a farther tag's phase says less.
    assert model.log_likelihood(at_origin, tag, predicted, frequency)[0] == pytest.approx(
        phase_by_hand(0.0, sd, 0.02), rel=1e-9)
    assert phase_by_hand(0.0, sd, 0.02) == pytest.approx(math.log(0.02 / sd), abs=0.01)


def test_each_antennas_phase_change_since_the_last_round_scores_the_change_of_its_round_trip_distance() -> None:
    model = PhaseDifferenceModel((0.0, 0.03, 0.30), (0.0, -0.03, 0.30), offset1_rad=0.4, noise_rad_per_m=0.02,
                                 floor_rad=0.02, eps=EPS)
    tag, frequency = (1.0, 0.5, 3.0), 915.25e6
    wavelength = 299_792_458.0 / frequency
    before, now = pose(0.0, 0.0, 0.0), pose(0.01, 0.0, 0.0)          # 1 cm towards the tag's side
    changes, sds = [], []
    for lateral in (0.03, -0.03):
        d_before = math.sqrt(1.0 ** 2 + (0.5 - lateral) ** 2 + 2.7 ** 2)
        d_now = math.sqrt(0.99 ** 2 + (0.5 - lateral) ** 2 + 2.7 ** 2)
        changes.append(4 * math.pi * (d_now - d_before) / wavelength)    # the port offsets cancel
        sds.append(math.sqrt((0.02 * d_before) ** 2 + (0.02 * d_now) ** 2 + 0.02 ** 2))
    off = (changes[0] + 0.03, changes[1] - 0.03)
    assert model.range_change_log_likelihood(before, now, tag, off, frequency)[0] == pytest.approx(
        sum(phase_by_hand(0.03, sd, 0.02) for sd in sds), rel=1e-9)
    assert model.range_change_log_likelihood(before, now, tag, tuple(changes), frequency)[0] == pytest.approx(
        sum(phase_by_hand(0.0, sd, 0.02) for sd in sds), rel=1e-9)
    # Closing in and moving away differ in sign: the tag ahead and the tag behind are told apart.
    assert model.range_change_log_likelihood(now, before, tag, tuple(changes), frequency)[0] < -5.0


def test_a_ceiling_tag_heard_again_on_the_same_channel_gives_its_range_rate_and_not_across_a_hop() -> None:
    fused = FusedFilter(FusedSettings(particles=50, phase=PhaseDifferenceModel((0.0, 0.03, 0.3), (0.0, -0.03, 0.3))),
                        FusedMap(extent=(0.0, 0.0, 10.0, 10.0), ceiling_tags={"C1": (5.0, 5.0, 3.0)}),
                        np.random.default_rng(4))
    fused.initialise_global()
    assert fused.update(Evidence(phase=(PhaseReading("C1", 0.3, 0.2, 915e6),))).used == ("ceiling_phase",)
    fused.predict(0.01, 0.0, 0.0)
    assert fused.update(Evidence(phase=(PhaseReading("C1", 0.35, 0.26, 915e6),))).used == \
        ("ceiling_phase", "ceiling_range_rate")
    fused.predict(0.01, 0.0, 0.0)
    assert fused.update(Evidence(phase=(PhaseReading("C1", 1.35, 1.26, 916e6),))).used == ("ceiling_phase",)


def test_the_phase_model_peaks_where_the_simulated_reader_stood() -> None:
    antennas = (Antenna(1, (0.0, 0.03, 0.30), True, 12.0, math.radians(85)),
                Antenna(2, (0.0, -0.03, 0.30), True, 12.0, math.radians(85)))
    reader = ReaderSimulator(ReaderModel(antennas, (915.25e6,), phase_noise_rad_per_m=0.0), ["C1"],
                             np.array([[2.0, 1.0, 3.0]]), np.array([0.7]), np.random.default_rng(1))
    reads = {read.antenna: read for read in reader.inventory(0.5, 0.2, 0.3, 0.0)}
    dphi = reads[1].phase_rad - reads[2].phase_rad      # the tag's own 0.7 rad cancels
    model = PhaseDifferenceModel(antennas[0].position, antennas[1].position)
    # The truth; turned 0.1 rad; 0.5 m aside across the bearing to the tag: both change d1 - d2 by millimetres,
    # several standard deviations of the difference's phase noise.
    states = np.array([[0.5, 0.5, 0.5 + 0.5 * 0.9], [0.2, 0.2, 0.2 - 0.5 * 0.43], [0.3, 0.4, 0.3]])
    scores = model.log_likelihood(states, (2.0, 1.0, 3.0), dphi, reads[1].frequency_hz)
    assert scores[0] - scores[1] > 0.5 and scores[0] - scores[2] > 1.0


def test_a_wall_tag_read_scores_its_depth_into_the_induction_area_and_nothing_for_a_plate_facing_away() -> None:
    model = WallTagModel(InductionArea((0.0, 0.0), math.pi / 2, 0.40, 1.00), softness_m=0.02, eps=EPS)
    robot = pose(0.0, 0.0, 0.0)        # looking along +x: the area reaches 1 m to the left (+y), 0.4 m wide
    inside = WallTag("8", (0.1, 0.5), (0.0, -1.0))            # 0.1 m from the area's side edge
    by_hand = math.log(EPS + (1 - EPS) * sigmoid(0.1 / 0.02))
    assert model.log_likelihood(robot, inside)[0] == pytest.approx(by_hand, rel=1e-9)
    facing_away = WallTag("9", (0.1, 0.5), (0.0, 1.0))
    assert model.log_likelihood(robot, facing_away)[0] == pytest.approx(math.log(EPS), rel=1e-12)
    outside = WallTag("10", (0.5, 0.5), (0.0, -1.0))          # 0.3 m beyond the side edge
    assert model.log_likelihood(robot, outside)[0] == pytest.approx(
        math.log(EPS + (1 - EPS) * sigmoid(-0.3 / 0.02)), rel=1e-9)


def test_a_wifi_fix_scores_a_gaussian_of_its_uncertainty_never_tighter_than_the_floor() -> None:
    model = WifiModel(sd_scale=1.0, sd_floor_m=1.0, eps=EPS)
    state = pose(1.5, 0.0, 0.0)
    assert model.log_likelihood(state, (0.0, 0.0), 2.0)[0] == pytest.approx(
        math.log(EPS + (1 - EPS) * math.exp(-0.5 * (1.5 / 2.0) ** 2)), rel=1e-9)
    assert model.log_likelihood(state, (0.0, 0.0), 0.3)[0] == pytest.approx(     # 0.3 m claimed: the 1 m floor
        math.log(EPS + (1 - EPS) * math.exp(-0.5 * 1.5 ** 2)), rel=1e-9)


def test_a_compass_reading_scores_the_heading_plus_the_particles_bias_across_the_wrap() -> None:
    model = CompassModel(sd_rad=math.radians(2.0), eps=EPS)
    residual = 3.1 - (-3.1 + 0.05) - 2 * math.pi
    assert model.log_likelihood(pose(0.0, 0.0, -3.1), np.array([0.05]), 3.1)[0] == pytest.approx(
        math.log(EPS + (1 - EPS) * math.exp(-0.5 * (residual / math.radians(2.0)) ** 2)), rel=1e-9)


def small_filter(**settings) -> FusedFilter:
    fused_map = FusedMap(extent=(0.0, 0.0, 10.0, 10.0), floor_tags={"G1-00": (2.0, 2.0)},
                         wall_tags={"8": WallTag("8", (5.0, 6.0), (0.0, -1.0))})
    return FusedFilter(FusedSettings(particles=200, **settings), fused_map, np.random.default_rng(3))


def test_a_round_without_evidence_costs_nothing_and_unknown_tags_are_named_not_used() -> None:
    fused = small_filter()
    fused.initialise_global()
    states, weights = fused.states.copy(), fused.weights.copy()
    update = fused.update(Evidence(floor_tag_ids=("NOT-A-TAG",), wall_tag_ids=((4, "99"),)))
    assert update.used == () and update.ignored_tag_ids == ("NOT-A-TAG", "99")
    assert np.array_equal(fused.states, states) and np.array_equal(fused.weights, weights)


def test_the_estimate_averages_headings_on_the_circle_and_its_covariance_spans_the_wrap() -> None:
    fused = small_filter()
    fused.states = np.array([[1.0, 1.0, 1.0, 1.0], [2.0, 2.0, 2.0, 2.0], [3.1, -3.1, 3.1, -3.1]])
    fused.weights = np.full(4, 0.25)
    estimate = fused.estimate()
    assert abs(abs(estimate.yaw) - math.pi) < 1e-9
    offset = 2 * math.pi - 6.2
    assert estimate.covariance[2, 2] == pytest.approx((offset / 2) ** 2, rel=1e-6)
    assert estimate.covariance[0, 0] == pytest.approx(0.0, abs=1e-18)


def test_a_filter_sure_of_the_wrong_place_is_redrawn_where_the_evidence_says_it_is() -> None:
    fused = small_filter()
    fused.initialise_at(8.0, 8.0, 0.0, np.diag([0.01, 0.01, 0.01]))
    for _ in range(5):                                   # well placed first: the averages learn what "good" is
        fused.predict(2.0, 0.0, 0.0)
        fused.predict(-2.0, 0.0, 0.0)
        fused.update(Evidence(wifi_fix=((8.0, 8.0), 1.0), compass_yaw_rad=0.0))
    injected = 0
    for _ in range(30):                                  # kidnapped to (2, 2): the fixes say so
        fused.predict(2.0, 0.0, 0.0)
        fused.predict(-2.0, 0.0, 0.0)
        injected += fused.update(Evidence(wifi_fix=((2.0, 2.0), 1.0), compass_yaw_rad=0.0)).injected
    estimate = fused.estimate()
    assert injected > 0
    assert math.hypot(estimate.x - 2.0, estimate.y - 2.0) < 1.0


def test_phase_readings_of_unknown_ceiling_tags_are_ignored_by_name() -> None:
    fused = small_filter(phase=PhaseDifferenceModel((0.0, 0.03, 0.3), (0.0, -0.03, 0.3)))
    fused.initialise_global()
    update = fused.update(Evidence(phase=(PhaseReading("C9", 0.3, 0.2, 915e6),)))
    assert update.used == () and update.ignored_tag_ids == ("C9",)
    assert wavelength_m(915e6) == pytest.approx(0.3276, abs=1e-4)


@pytest.mark.parametrize("kind", ["lattice", "tag_group", "ceiling_phase", "wall_tag", "compass", "all_kinds"])
def test_each_case_of_bench_fused_weighs_its_kind_of_evidence_and_the_estimate_stays_on_the_truth(kind: str) -> None:
    from rfidnav_experiments.bench.fused import CASES, PARAMETERS, fused_map
    from rfidnav_localization.fused.localizer import FusedLocalizer

    (x, y, yaw), evidence_at = CASES[kind]
    localizer = FusedLocalizer(PARAMETERS.settings(), fused_map(), np.random.default_rng(3))
    localizer.on_odometry((0.0, 0.0, 0.0))
    localizer.set_pose(x, y, yaw, np.diag(np.square(PARAMETERS.initial_sd)))
    for step in range(1, 9):
        localizer.on_odometry((0.012 * step, 0.0, 0.0))
        estimate = localizer.on_round(evidence_at(x + 0.012 * step, y, yaw))
        assert estimate is not None and not estimate.update.ignored_tag_ids
        assert set(estimate.update.used) >= ({"lattice", "ceiling_phase", "wall_tag", "compass"} if kind == "all_kinds"
                                             else {kind})
    assert math.hypot(estimate.pose.x - (x + 0.096), estimate.pose.y - y) < 0.15


SHIPPED_PAIRS = [("rfid_localizer_mixed.yaml", "reader_mixed.yaml"),
                 ("rfid_localizer_hf_floor.yaml", "reader_hf_floor.yaml"),
                 ("rfid_localizer_floor_lattice.yaml", "reader_floor_lattice.yaml"),
                 ("rfid_localizer_wall_side.yaml", "reader_wall_side.yaml"),
                 ("rfid_localizer_uhf_2ant.yaml", "reader_uhf_2ant.yaml")]


@pytest.mark.parametrize(("localizer_file", "reader_file"), SHIPPED_PAIRS)
def test_each_shipped_rfid_localizer_file_describes_its_robots_reader_as_the_reader_file_does(
        localizer_file: str, reader_file: str) -> None:
    from rfidnav_experiments.runners.shipped import file_parameters
    from rfidnav_localization.parameters import RfidLocalizerParameters
    from rfidnav_scenario.scenario import CONFIG_DIR
    from rfidnav_sim.parameters import SIDE_BEARINGS, ReaderParameters
    from rfidnav_sim.rfid_model import reach_m

    fused = file_parameters(RfidLocalizerParameters, CONFIG_DIR / "params" / localizer_file, "rfid_localizer",
                            map_file="(any)")
    reader = file_parameters(ReaderParameters, CONFIG_DIR / "params" / reader_file, "rfid_reader_sim",
                             world_file="unused")
    assert fused.antenna_positions == reader.antenna_positions
    assert fused.antenna_phase_offset_rad == reader.antenna_phase_offset_rad
    assert fused.phase_noise_rad_per_m == reader.phase_noise_rad_per_m
    facing = dict(enumerate(reader.antenna_facing, start=1))
    if fused.floor_antenna:
        assert facing[fused.floor_antenna] == "down"
        model = reader.reader_model()     # the reach along the floor, to the millimetre
        floor_reach = reach_m(model, model.antennas[fused.floor_antenna - 1], 0.0)
        assert fused.tag_group_read_range_m == pytest.approx(floor_reach, abs=0.001)
    else:
        assert "down" not in reader.antenna_facing
    assert all(facing[port] == "up" for port in fused.phase_antennas)
    if fused.wall_antenna:
        assert fused.wall_area_bearing_rad == SIDE_BEARINGS[facing[fused.wall_antenna]]
        assert fused.wall_area_width_m == reader.side_area_width_m
        assert fused.wall_area_depth_m == reader.antenna_max_range_m[fused.wall_antenna - 1]
    else:
        assert not any(side in reader.antenna_facing for side in SIDE_BEARINGS)


@pytest.mark.parametrize("steps", [1, 25, 400])
def test_the_fused_motion_noise_over_a_metre_is_the_same_however_finely_the_odometry_slices_it(steps: int) -> None:
    settings = FusedSettings(particles=20_000, odometry_noise_m=0.05, turn_noise_fraction=0.05, heading_noise_rad=0.02,
                             odometry_scale_sd=0.0, odometry_scale_walk=0.0)
    fused = FusedFilter(settings, FusedMap(extent=(0.0, 0.0, 10.0, 10.0)), np.random.default_rng(steps))
    fused.initialise_at(1.0, 5.0, 0.0, np.diag([1e-12, 1e-12, 1e-12]))
    for _ in range(steps):
        fused.predict(1.0 / steps, 0.0, 0.0)
    x, y, yaw = fused.states
    assert float(np.mean(x)) == pytest.approx(2.0, abs=0.002)
    assert float(np.std(yaw)) == pytest.approx(0.02, rel=0.05)
    assert float(np.std(x)) == pytest.approx(0.05, rel=0.05)
    # Across the way its own 5 cm; the heading's drift, swung over the metre, adds about 3 % in finer slices.
    assert float(np.std(y)) == pytest.approx(0.05, rel=0.06)


def test_the_fused_status_names_the_lattice_tags_read_and_their_range_so_the_partition_navigator_can_drive_on_it(
        ) -> None:
    from builtin_interfaces.msg import Time

    from rfidnav_experiments.bench.fused import CASES, GROUP_TAG_ID, LATTICE, PARAMETERS, fused_map
    from rfidnav_localization.conversions import fused_status_message
    from rfidnav_localization.fused.localizer import FusedLocalizer
    from rfidnav_planning.conversions import estimate_from_status

    (x, y, yaw), evidence_at = CASES["lattice"]
    localizer = FusedLocalizer(PARAMETERS.settings(), fused_map(), np.random.default_rng(3))
    localizer.on_odometry((0.0, 0.0, 0.0))
    localizer.set_pose(x, y, yaw, np.diag(np.square(PARAMETERS.initial_sd)))
    lattice_ids = list(evidence_at(x, y, yaw)["floor_tag_ids"])
    assert lattice_ids
    # A tag group's tag read with them is no lattice tag: not part of the partition.
    estimate = localizer.on_round(Evidence(floor_tag_ids=[*lattice_ids, GROUP_TAG_ID]))
    assert estimate is not None
    assert estimate.partition_tag_ids == tuple(lattice_ids) and estimate.read_range_m == LATTICE.read_range_m
    taken = estimate_from_status(fused_status_message(estimate, Time(), "map", 0), 1.0, None)
    assert taken.partition_tag_ids == tuple(lattice_ids) and taken.partition_changed and taken.lattice is not None
    assert taken.read_range_m == LATTICE.read_range_m and taken.position == (estimate.pose.x, estimate.pose.y)
    assert taken.yaw_std == pytest.approx(math.sqrt(estimate.pose.covariance[2, 2]))
    # A round with no lattice tag: no partition, but the lattice's range, once learnt, stays known.
    later = localizer.on_round(Evidence())
    assert later is not None and later.partition_tag_ids == () and later.read_range_m == LATTICE.read_range_m


def test_a_round_weighs_the_latest_reading_stamped_before_it_once_and_never_one_of_its_own_step() -> None:
    held: HeldReadings[float] = HeldReadings()
    assert held.take(1.0) is None                                  # none yet
    held.hold(0.1, 1.9)
    held.hold(0.2, 2.0)                                            # of the round's own step: it may come first
    assert held.take(2.0) == 0.1
    assert held.take(2.0) is None                                  # weighed once
    assert held.take(2.5) == 0.2                                   # the next round has it
    held.hold(0.3, 3.0)
    held.hold(0.4, 3.5)                                            # a newer reading replaces an unweighed one
    assert held.take(4.0) == 0.4 and held.take(5.0) is None


def test_readings_held_while_no_round_comes_are_bounded_to_the_latest_ones() -> None:
    held: HeldReadings[float] = HeldReadings()
    for index in range(10 * HELD_READINGS):                        # a reader gone quiet, the compass still going
        held.hold(float(index), 0.1 * index)
    assert len(held.readings) == HELD_READINGS
    assert held.take(1e6) == float(10 * HELD_READINGS - 1)         # the next round still weighs the latest


def test_the_status_names_the_shipped_kinds_of_evidence_in_the_order_they_are_registered() -> None:
    assert [kind for measurement in small_filter().measurements for kind in measurement.kinds] == \
        ["lattice", "tag_group", "ceiling_phase", "ceiling_range_rate", "wall_tag", "wifi", "compass"]


BEACON = (2.0, 3.0)
BEACON_SD_M = 0.3


class BeaconRange(Measurement[float]):
    """A kind of evidence the package does not have, defined here: the measured distance to a radio beacon at
    BEACON [m], a Gaussian of sd BEACON_SD_M with the settings' floor eps. Particles it cannot explain are
    redrawn on the circle of that radius about the beacon."""
    name = "beacon_range_m"
    kinds = ("beacon",)
    reset_memory = {"beacon": 1.0}
    proposal_rank = 3

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.eps = settings.eps

    def log_likelihoods(self, reading: float, particles: Particles) -> Likelihoods:
        distance = np.hypot(particles.states[0] - BEACON[0], particles.states[1] - BEACON[1])
        result = Likelihoods()
        result.add("beacon", robust_gaussian(distance - reading, BEACON_SD_M, self.eps))
        return result

    def poses(self, reading: float, yaw: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        angle = rng.uniform(-math.pi, math.pi, len(yaw))
        return np.vstack((BEACON[0] + reading * np.cos(angle), BEACON[1] + reading * np.sin(angle), yaw))


def test_a_new_kind_of_evidence_is_one_class_registered_after_the_shipped_ones_and_weighs_as_its_likelihood_says(
        ) -> None:
    # Never redrawn nor resampled: the weights are the likelihood's alone.
    settings = FusedSettings(particles=2000, reset_threshold=0.0, resample_threshold=1e-9)
    fused = FusedFilter(settings, FusedMap(extent=(0.0, 0.0, 10.0, 10.0)), np.random.default_rng(5),
                        (*MEASUREMENTS, BeaconRange))
    fused.initialise_at(4.0, 3.0, 0.0, np.diag([0.25, 0.25, 0.01]))        # 2 m east of the beacon, sd 0.5 m
    x, y, _ = fused.states.copy()
    update = fused.update(Evidence(beacon_range_m=2.4))
    assert update.used == ("beacon",) and update.injected == 0
    by_hand = EPS + (1 - EPS) * np.exp(-0.5 * np.square((np.hypot(x - 2.0, y - 3.0) - 2.4) / BEACON_SD_M))
    assert np.allclose(fused.weights, by_hand / by_hand.sum(), rtol=1e-9, atol=0.0)
    estimate = fused.estimate()
    assert estimate.x == pytest.approx(float(by_hand @ x / by_hand.sum()), rel=1e-9)
    assert estimate.x - 2.0 > 2.2                         # drawn out towards the 2.4 m the beacon measured
    # Reported after the shipped kinds, in the order registered.
    assert fused.update(Evidence(beacon_range_m=2.4, compass_yaw_rad=0.0)).used == ("compass", "beacon")


def test_particles_a_new_kind_of_evidence_cannot_explain_are_redrawn_where_it_proposes() -> None:
    fused = FusedFilter(FusedSettings(particles=500), FusedMap(extent=(0.0, 0.0, 10.0, 10.0)),
                        np.random.default_rng(6), (*MEASUREMENTS, BeaconRange))
    fused.initialise_global()                             # uniform over 100 m^2: few particles near a 1 m circle
    update = fused.update(Evidence(beacon_range_m=1.0, floor_tag_ids=("NOT-A-TAG",)))
    assert update.used == ("beacon",) and update.injected > 0
    distances = np.hypot(fused.states[0] - BEACON[0], fused.states[1] - BEACON[1])
    assert int(np.sum(np.isclose(distances, 1.0, rtol=0.0, atol=1e-9))) >= update.injected     # on the circle
    assert float(np.mean(np.abs(distances - 1.0) < 3 * BEACON_SD_M)) > 0.9     # and the rest resampled near it


def test_a_rider_given_some_kinds_of_evidence_gets_a_rounds_evidence_without_the_others_readings() -> None:
    from rfidnav_experiments.runners.fused import Rider
    from rfidnav_localization.fused.localizer import FusedLocalizer

    evidence = Evidence(floor_tag_ids=["G1-00"], phase=[PhaseReading("C1", 0.3, 0.2, 915e6)],
                        wall_tag_ids=[(4, "8")], wifi_fix=((1.0, 2.0), 1.5), compass_yaw_rad=0.2)
    localizer = FusedLocalizer(FusedSettings(particles=10), FusedMap(extent=(0.0, 0.0, 1.0, 1.0)),
                               np.random.default_rng(1))
    assert Rider(localizer, ("floor", "compass")).evidence(evidence) == \
        Evidence(floor_tag_ids=["G1-00"], compass_yaw_rad=0.2)
    assert Rider(localizer).evidence(evidence) == evidence
