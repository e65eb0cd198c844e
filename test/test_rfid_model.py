"""UHF reader model (paper 001 sec. IV-A, V): phase formula, left/right sign of the phase difference, wrapping,
distance-proportional noise, read range and beam cone, reach from the link budget, read misses, channel hopping,
seeding.

Pure-module tests: no ROS. Distances and phases are computed here from the geometry, independently of the model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.config import parameters_from_mapping
from rfidnav_common.errors import ConfigError
from rfidnav_common.geometry import wrap_angle, wrap_angles
from rfidnav_common.rf import (
    SPEED_OF_LIGHT_MPS,
    range_change_m,
    round_trip_phase,
    wavelength_m,
)
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.rfid_model import Antenna, ReaderModel, ReaderSimulator, budget_range_m, link_rssi_dbm, reach_m

pytestmark = pytest.mark.tier("unit")

TWO_PI = 2.0 * math.pi
FREQUENCY_HZ = 915.25e6
BASELINE_M = 0.06
ANTENNA_HEIGHT_M = 0.30
CEILING_M = 3.0


def up_antenna(port: int, y: float, *, z: float = ANTENNA_HEIGHT_M, offset: float = 0.0,
               max_range_m: float = 12.0) -> Antenna:
    return Antenna(port=port, position=(0.0, y, z), facing_up=True, max_range_m=max_range_m,
                   half_angle_rad=math.radians(85.0), phase_offset_rad=offset)


def two_antenna_model(noise: float = 0.0, **kwargs) -> ReaderModel:
    """Antenna 1 on the left (+y in base_link), antenna 2 on the right (-y), 6 cm apart, facing up."""
    return ReaderModel(antennas=(up_antenna(1, BASELINE_M / 2), up_antenna(2, -BASELINE_M / 2)),
                       channels_hz=(FREQUENCY_HZ,), phase_noise_rad_per_m=noise, **kwargs)


def simulator(model: ReaderModel, tags: dict[str, tuple[float, float, float]], seed: int = 0,
              tag_offsets: list[float] | None = None) -> ReaderSimulator:
    offsets = np.zeros(len(tags)) if tag_offsets is None else np.asarray(tag_offsets, dtype=float)
    return ReaderSimulator(model, list(tags), np.array(list(tags.values()), dtype=float), offsets,
                           np.random.default_rng(seed))


def by_antenna(reads, tag_id: str) -> dict[int, object]:
    return {read.antenna: read for read in reads if read.tag_id == tag_id}


def circular_difference(a, b):
    """a - b wrapped to (-pi, pi], computed without the code under test."""
    return np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))


def antenna_world(x: float, y: float, yaw: float, local: tuple[float, float, float]) -> np.ndarray:
    ax, ay, az = local
    return np.array([x + math.cos(yaw) * ax - math.sin(yaw) * ay, y + math.sin(yaw) * ax + math.cos(yaw) * ay, az])


# ----------------------------------------------------------------------------------------------- phase formula

@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (-1.3, 0.7, 1.1), (2.5, -4.0, -2.6), (0.4, 3.9, math.pi)])
@pytest.mark.parametrize("tag_offset, antenna_offset", [(0.0, 0.0), (1.7, 0.0), (0.4, 2.9), (5.5, 6.0)])
def test_noise_free_phase_is_the_round_trip_formula(pose, tag_offset, antenna_offset):
    x, y, yaw = pose
    tag = (0.6, 1.2, CEILING_M)
    left = up_antenna(1, BASELINE_M / 2, offset=antenna_offset)
    model = ReaderModel(antennas=(left,), channels_hz=(FREQUENCY_HZ,), phase_noise_rad_per_m=0.0)
    reads = simulator(model, {"C1": tag}, tag_offsets=[tag_offset]).inventory(x, y, yaw, 0.0)
    assert len(reads) == 1
    read = reads[0]

    distance = float(np.linalg.norm(np.array(tag) - antenna_world(x, y, yaw, left.position)))
    wavelength = SPEED_OF_LIGHT_MPS / FREQUENCY_HZ
    expected = math.fmod(4.0 * math.pi * distance / wavelength + tag_offset + antenna_offset, TWO_PI)
    assert 0.0 <= read.phase_rad < TWO_PI
    assert abs(circular_difference(read.phase_rad, expected)) < 1e-9
    assert read.frequency_hz == FREQUENCY_HZ
    # I/Q carry the same phase and the RSSI as amplitude.
    assert math.atan2(read.q, read.i) % TWO_PI == pytest.approx(read.phase_rad, abs=1e-9)
    assert math.hypot(read.i, read.q) == pytest.approx(10.0 ** (read.rssi_dbm / 20.0), rel=1e-12)


def test_rssi_falls_40_db_per_decade_on_boresight():
    model = ReaderModel(antennas=(up_antenna(1, 0.0, z=0.0),), channels_hz=(FREQUENCY_HZ,))
    near = simulator(model, {"T": (0.0, 0.0, 1.0)}).inventory(0.0, 0.0, 0.0, 0.0)[0]
    far = simulator(model, {"T": (0.0, 0.0, 10.0)}).inventory(0.0, 0.0, 0.0, 0.0)[0]
    assert near.rssi_dbm == pytest.approx(model.rssi_at_1m_dbm)
    assert near.rssi_dbm - far.rssi_dbm == pytest.approx(40.0)


def test_rf_helpers_agree_with_each_other():
    wavelength = wavelength_m(FREQUENCY_HZ)
    assert wavelength == pytest.approx(0.32755, abs=1e-4)
    # A range change of lambda/2 is a full round-trip phase turn.
    assert float(round_trip_phase(wavelength / 2.0, FREQUENCY_HZ)) == pytest.approx(0.0, abs=1e-9)
    assert float(round_trip_phase(wavelength / 8.0, FREQUENCY_HZ)) == pytest.approx(math.pi / 2.0)
    assert range_change_m(math.pi / 2.0, FREQUENCY_HZ) == pytest.approx(wavelength / 8.0)
    assert range_change_m(-1.0, FREQUENCY_HZ) < 0.0


# ------------------------------------------------------------------- phase difference: which side is the tag on

HEADINGS_DEG = [0.0, 37.0, 90.0, 180.0, -120.0]


@pytest.mark.parametrize("heading_deg", HEADINGS_DEG)
@pytest.mark.parametrize("forward_offset_m", [-1.5, 0.0, 2.0])
def test_phase_difference_sign_tells_left_from_right(heading_deg, forward_offset_m):
    """Sweep the robot sideways under a ceiling tag: dphi = phi1 - phi2 < 0 while the tag is on the left,
    > 0 on the right, one sign change as it passes, and always |dphi| < pi (baseline < lambda/4)."""
    assert BASELINE_M < wavelength_m(FREQUENCY_HZ) / 4.0
    yaw = math.radians(heading_deg)
    tag = np.array([1.0, -2.0])
    sim = simulator(two_antenna_model(), {"C1": (tag[0], tag[1], CEILING_M)})
    forward = np.array([math.cos(yaw), math.sin(yaw)])
    left = np.array([-math.sin(yaw), math.cos(yaw)])
    # Tag lateral offset in the robot frame, positive = tag on the robot's left; zero excluded.
    lateral_offsets = np.concatenate((np.linspace(-4.0, -0.005, 40), np.linspace(0.005, 4.0, 40)))
    differences = []
    for lateral in lateral_offsets:
        robot = tag - lateral * left - forward_offset_m * forward
        reads = by_antenna(sim.inventory(robot[0], robot[1], yaw, 0.0), "C1")
        assert set(reads) == {1, 2}
        differences.append(wrap_angle(reads[1].phase_rad - reads[2].phase_rad))
    differences = np.array(differences)

    assert np.all(differences[lateral_offsets > 0] < 0.0), "tag on the left must give dphi < 0"
    assert np.all(differences[lateral_offsets < 0] > 0.0), "tag on the right must give dphi > 0"
    assert np.count_nonzero(np.diff(np.sign(differences))) == 1
    assert np.all(np.abs(differences) < math.pi)
    # Going from the tag on the right to the tag on the left, dphi only falls (no wrap-around).
    assert np.all(np.diff(differences) < 0.0)


@pytest.mark.parametrize("heading_deg", HEADINGS_DEG)
def test_phase_difference_is_near_zero_with_the_tag_straight_ahead_or_behind(heading_deg):
    yaw = math.radians(heading_deg)
    sim = simulator(two_antenna_model(), {"C1": (0.0, 0.0, CEILING_M)})
    for along in (-3.0, -0.5, 0.5, 3.0):
        reads = by_antenna(sim.inventory(-along * math.cos(yaw), -along * math.sin(yaw), yaw, 0.0), "C1")
        assert abs(wrap_angle(reads[1].phase_rad - reads[2].phase_rad)) < 1e-9


def test_phase_difference_matches_the_path_difference():
    """dphi = 4*pi*(d1 - d2)/lambda for a tag to the side, checked against distances computed here."""
    sim = simulator(two_antenna_model(), {"C1": (0.0, 0.8, CEILING_M)})
    reads = by_antenna(sim.inventory(0.0, 0.0, 0.0, 0.0), "C1")
    d1 = math.dist((0.0, BASELINE_M / 2, ANTENNA_HEIGHT_M), (0.0, 0.8, CEILING_M))
    d2 = math.dist((0.0, -BASELINE_M / 2, ANTENNA_HEIGHT_M), (0.0, 0.8, CEILING_M))
    expected = 4.0 * math.pi * (d1 - d2) / wavelength_m(FREQUENCY_HZ)
    assert expected < 0.0
    assert wrap_angle(reads[1].phase_rad - reads[2].phase_rad) == pytest.approx(expected, abs=1e-9)


def test_default_reader_parameters_put_port_1_on_the_left():
    model = ReaderParameters(world_file="w.yaml").reader_model()
    ports = {antenna.port: antenna for antenna in model.antennas}
    assert ports[1].position[1] > 0.0 > ports[2].position[1]
    assert ports[1].facing_up and ports[2].facing_up and not ports[3].facing_up
    baseline = math.dist(ports[1].position, ports[2].position)
    assert baseline < wavelength_m(model.channels_hz[0]) / 4.0


# ---------------------------------------------------------------------------------------------------- wrapping

WRAP_CASES = [
    (0.0, 0.0),
    (math.pi, math.pi),
    (-math.pi, math.pi),
    (3.0 * math.pi, math.pi),
    (-3.0 * math.pi, math.pi),
    (2.0 * math.pi, 0.0),
    (-2.0 * math.pi, 0.0),
    (0.5, 0.5),
    (-0.5, -0.5),
    (math.pi + 0.25, -math.pi + 0.25),
    (-math.pi - 0.25, math.pi - 0.25),
    (1000.0 * math.pi + 0.3, 0.3),
    (-1000.0 * math.pi - 0.3, -0.3),
    (1e4 * TWO_PI + 1.0, 1.0),
]


def assert_wrapped(value: float, expected: float) -> None:
    assert -math.pi < value <= math.pi
    # Same direction as the expected angle; near +/-pi the floating error of large inputs may land either side.
    assert abs(circular_difference(value, expected)) < 1e-9
    if abs(expected) < math.pi - 1e-6:
        assert value == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("angle, expected", WRAP_CASES)
def test_wrap_angle(angle, expected):
    assert_wrapped(wrap_angle(angle), expected)


def test_wrap_angle_maps_exactly_pi_and_minus_pi_to_pi():
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert np.all(wrap_angles(np.array([math.pi, -math.pi])) == math.pi)


def test_wrap_angles_matches_wrap_angle_elementwise():
    angles = np.array([angle for angle, _ in WRAP_CASES])
    wrapped = wrap_angles(angles)
    assert wrapped.shape == angles.shape
    for value, (_, expected) in zip(wrapped, WRAP_CASES):
        assert_wrapped(float(value), expected)
    random = np.random.default_rng(3).uniform(-50.0, 50.0, 2000)
    vector = wrap_angles(random)
    assert np.all((vector > -math.pi) & (vector <= math.pi))
    assert np.allclose(vector, [wrap_angle(a) for a in random], atol=1e-9)
    assert np.allclose(np.exp(1j * vector), np.exp(1j * random), atol=1e-9)


# -------------------------------------------------------------------------------------------------------- noise

@pytest.mark.parametrize("noise_rad_per_m", [0.02, 0.05])
def test_phase_noise_std_is_proportional_to_distance(noise_rad_per_m):
    rounds = 4000
    stds = {}
    for distance in (2.0, 8.0):
        tag = (0.0, 0.0, distance)   # straight above an antenna at the floor
        model = ReaderModel(antennas=(up_antenna(1, 0.0, z=0.0),), channels_hz=(FREQUENCY_HZ,),
                            phase_noise_rad_per_m=noise_rad_per_m)
        sim = simulator(model, {"T": tag}, seed=11)
        truth = float(round_trip_phase(distance, FREQUENCY_HZ))
        errors = np.array([circular_difference(sim.inventory(0.0, 0.0, 0.0, 0.0)[0].phase_rad, truth)
                           for _ in range(rounds)])
        assert abs(errors.mean()) < 4.0 * noise_rad_per_m * distance / math.sqrt(rounds)  # zero-mean
        stds[distance] = errors.std(ddof=1)
        # Sample std of N Gaussian draws: relative standard error ~ 1/sqrt(2N) = 1.1 %; allow 5 %.
        assert stds[distance] == pytest.approx(noise_rad_per_m * distance, rel=0.05)
    assert stds[8.0] / stds[2.0] == pytest.approx(4.0, rel=0.08)


# ------------------------------------------------------------------------------------------- read range and cone

def floor_reader_model(miss_probability: float = 0.0) -> ReaderModel:
    return ReaderParameters(world_file="w.yaml", miss_probability=miss_probability).reader_model()


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5])
def test_floor_antenna_reads_a_floor_tag_right_below_only(yaw):
    sim = simulator(floor_reader_model(), {"F1": (2.0, 1.0, 0.0)})
    below = by_antenna(sim.inventory(2.0, 1.0, yaw, 0.0), "F1")
    assert set(below) == {3}   # the downward antenna only; the upward ones never see a floor tag
    for dx, dy in ((0.20, 0.0), (0.0, -0.20), (0.15, 0.15)):
        assert sim.inventory(2.0 + dx, 1.0 + dy, yaw, 0.0) == []


def test_upward_antenna_does_not_read_a_floor_tag_and_downward_not_a_ceiling_tag():
    model = ReaderModel(antennas=(up_antenna(1, 0.0, max_range_m=50.0),
                                  Antenna(2, (0.0, 0.0, 0.05), facing_up=False, max_range_m=50.0,
                                          half_angle_rad=math.radians(85.0))),
                        channels_hz=(FREQUENCY_HZ,), phase_noise_rad_per_m=0.0)
    sim = simulator(model, {"floor": (0.0, 0.0, 0.0), "ceiling": (0.0, 0.0, CEILING_M)})
    seen = {(read.tag_id, read.antenna) for read in sim.inventory(0.0, 0.0, 0.0, 0.0)}
    assert seen == {("ceiling", 1), ("floor", 2)}


def test_ceiling_tag_outside_the_cone_or_range_is_not_read():
    sim = simulator(two_antenna_model(), {"C1": (0.0, 0.0, CEILING_M)})
    assert len(sim.inventory(0.0, -5.0, 0.0, 0.0)) == 2        # 61 deg off boresight, 5.7 m: inside
    assert sim.inventory(0.0, -11.5, 0.0, 0.0) == []            # 11.8 m, but 87 deg off boresight
    short = ReaderModel(antennas=(up_antenna(1, 0.0, max_range_m=4.0),), channels_hz=(FREQUENCY_HZ,))
    short_sim = simulator(short, {"C1": (0.0, 0.0, CEILING_M)})
    assert len(short_sim.inventory(0.0, -2.0, 0.0, 0.0)) == 1   # 3.4 m
    assert short_sim.inventory(0.0, -3.0, 0.0, 0.0) == []       # 4.0 m: beyond range


def test_miss_probability_drops_about_that_fraction_of_reads():
    rounds = 2000
    sim = simulator(two_antenna_model(miss_probability=0.5), {"C1": (0.0, 0.0, CEILING_M)}, seed=5)
    reads = sum(len(sim.inventory(0.0, 0.0, 0.0, 0.0)) for _ in range(rounds))
    possible = 2 * rounds
    # Binomial(4000, 0.5): std 32 reads; 5 sigma is 158.
    assert abs(reads - possible / 2) < 5.0 * math.sqrt(possible * 0.25)
    none_missed = simulator(two_antenna_model(), {"C1": (0.0, 0.0, CEILING_M)}, seed=5)
    assert sum(len(none_missed.inventory(0.0, 0.0, 0.0, 0.0)) for _ in range(200)) == 400


# ------------------------------------------------------------------------------------------- channel hopping

CHANNELS_HZ = (902.75e6, 915.25e6, 927.25e6)


def hopping_simulator(dwell_s: float = 0.2) -> ReaderSimulator:
    model = ReaderModel(antennas=(up_antenna(1, 0.0),), channels_hz=CHANNELS_HZ, hop_dwell_s=dwell_s,
                        phase_noise_rad_per_m=0.0)
    return simulator(model, {"C1": (0.4, 0.3, CEILING_M)})


@pytest.mark.parametrize("dwell_s", [0.2, 0.05])
def test_channel_at_cycles_with_the_dwell_time(dwell_s):
    sim = hopping_simulator(dwell_s)
    # Mid-dwell times, so the test does not depend on how a float lands on a boundary.
    for slot in range(10):
        for fraction in (0.1, 0.5, 0.9):
            assert sim.channel_at((slot + fraction) * dwell_s) == CHANNELS_HZ[slot % len(CHANNELS_HZ)]


def test_single_channel_never_hops():
    sim = simulator(two_antenna_model(), {"C1": (0.0, 0.0, CEILING_M)})
    assert {sim.channel_at(t) for t in np.linspace(0.0, 30.0, 301)} == {FREQUENCY_HZ}


def test_phase_depends_on_the_hopped_frequency():
    sim = hopping_simulator()
    distance = math.dist((0.4, 0.3, CEILING_M), (0.0, 0.0, ANTENNA_HEIGHT_M))
    phases = {}
    for slot, channel in enumerate(CHANNELS_HZ):
        read = sim.inventory(0.0, 0.0, 0.0, (slot + 0.5) * 0.2)[0]
        assert read.frequency_hz == channel
        expected = math.fmod(4.0 * math.pi * distance * channel / SPEED_OF_LIGHT_MPS, TWO_PI)
        assert abs(circular_difference(read.phase_rad, expected)) < 1e-9
        phases[channel] = read.phase_rad
    # 12.5 MHz apart at ~2.7 m: the round-trip phase moves by 4*pi*d*df/c ~ 1.4 rad.
    assert abs(circular_difference(phases[CHANNELS_HZ[1]], phases[CHANNELS_HZ[0]])) > 0.5
    assert abs(circular_difference(phases[CHANNELS_HZ[2]], phases[CHANNELS_HZ[1]])) > 0.5


# ------------------------------------------------------------------------------------------------------ seeding

def noisy_rounds(seed: int, rounds: int = 20):
    sim = simulator(two_antenna_model(noise=0.05, miss_probability=0.2), {"C1": (0.0, 0.0, CEILING_M),
                                                                          "C2": (0.0, 5.0, CEILING_M)}, seed=seed)
    return [sim.inventory(0.1 * k, -1.0, 1.2, 0.04 * k) for k in range(rounds)]


def test_same_seed_gives_identical_reads():
    assert noisy_rounds(7) == noisy_rounds(7)


def test_different_seed_gives_different_noise():
    first, second = noisy_rounds(7), noisy_rounds(8)
    assert first != second
    phases = lambda rounds: {(k, r.tag_id, r.antenna): r.phase_rad for k, rs in enumerate(rounds) for r in rs}
    a, b = phases(first), phases(second)
    common = set(a) & set(b)
    assert len(common) > 10
    assert all(a[key] != b[key] for key in common)


def test_no_tags_no_reads():
    model = two_antenna_model()
    sim = ReaderSimulator(model, [], np.empty((0, 3)), np.empty(0), np.random.default_rng(0))
    assert sim.inventory(0.0, 0.0, 0.0, 0.0) == []


def test_a_side_antenna_reads_the_wall_tags_in_its_induction_area_and_nothing_else() -> None:
    from rfidnav_common.wall_tags import WallTag

    left = Antenna(1, (0.0, 0.0, 0.5), False, 1.0, math.radians(90.0), side_bearing_rad=math.pi / 2)
    model = ReaderModel(antennas=(left,
                                  Antenna(2, (0.0, 0.0, 0.3), True, 12.0, math.radians(85.0))),
                        channels_hz=(2.45e9,), side_area_width_m=0.4)
    wall = (WallTag("8", (0.1, 0.8), (0.0, -1.0)), WallTag("9", (0.5, 0.8), (0.0, -1.0)),
            WallTag("10", (0.0, -0.8), (0.0, 1.0)))
    sim = ReaderSimulator(model, ["C1"], np.array([[0.0, 0.0, 3.0]]), np.zeros(1), np.random.default_rng(1),
                          wall_tags=wall)
    reads = sim.inventory(0.0, 0.0, 0.0, 0.0)          # heading +x: the left antenna looks at +y
    by_antenna = {(r.tag_id, r.antenna) for r in reads}
    assert ("8", 1) in by_antenna                       # 0.8 m to the left, inside the 40 cm band
    assert ("9", 1) not in by_antenna                   # 0.5 m ahead: outside the band
    assert ("10", 1) not in by_antenna                  # on the right wall
    assert ("C1", 2) in by_antenna and ("C1", 1) not in by_antenna   # ceiling tags: the up antenna only
    read = next(r for r in reads if r.tag_id == "8")
    assert read.rssi_dbm == pytest.approx(-40.0 - 40.0 * math.log10(math.hypot(0.1, 0.8)))


# ------------------------------------------------------------------------------------------------------- reach

def shipped_model() -> ReaderModel:
    return ReaderParameters(world_file="unused").reader_model()


@pytest.mark.parametrize("tag_z, expected_m", [(3.0, 9.09), (2.5, 8.58)])
def test_the_reach_of_a_ceiling_tag_is_what_the_shipped_link_budget_gives_by_hand(tag_z, expected_m) -> None:
    """-40 + 20 log10(h) - 60 log10(d) >= -90 with h the tag's height above the 30 cm antennas: d = 9.49 m for
    h = 2.7 m, so r = sqrt(d^2 - h^2) = 9.09 m; 8.58 m for h = 2.2 m."""
    model = shipped_model()
    height = tag_z - ANTENNA_HEIGHT_M
    slant = 10.0 ** ((-40.0 + 90.0 + 20.0 * math.log10(height)) / 60.0)
    assert math.sqrt(slant ** 2 - height ** 2) == pytest.approx(expected_m, abs=0.005)
    for antenna in model.antennas[:2]:
        assert reach_m(model, antenna, tag_z) == pytest.approx(expected_m, abs=0.005)


def test_the_simulator_hears_a_ceiling_tag_just_inside_its_reach_and_not_just_beyond() -> None:
    model = two_antenna_model()
    reach = reach_m(model, model.antennas[0], CEILING_M)
    for distance, heard in ((reach - 0.01, True), (reach + 0.01, False)):
        reads = simulator(model, {"C": (distance, 0.0, CEILING_M)}).inventory(0.0, 0.0, 0.0, 0.0)
        assert bool(reads) is heard, distance


def test_the_cone_and_the_range_cap_bound_the_reach_where_they_bind_before_the_budget() -> None:
    narrow = ReaderModel(antennas=(Antenna(1, (0.0, 0.0, 0.3), True, 12.0, math.radians(30.0)),),
                         channels_hz=(FREQUENCY_HZ,))
    assert reach_m(narrow, narrow.antennas[0], 3.3) == pytest.approx(3.0 * math.tan(math.radians(30.0)))
    capped = ReaderModel(antennas=(up_antenna(1, 0.0, max_range_m=4.0),), channels_hz=(FREQUENCY_HZ,))
    assert reach_m(capped, capped.antennas[0], 3.3) == pytest.approx(math.sqrt(16.0 - 9.0))
    assert reach_m(capped, capped.antennas[0], 0.0) == 0.0          # below an upward antenna: never


def test_a_reader_file_cannot_claim_a_range_beyond_the_link_budget() -> None:
    assert budget_range_m(shipped_model()) == pytest.approx(10.0 ** 1.25)          # 17.78 m on boresight
    source, prefix = "reader_uhf_2ant.yaml", "rfid_reader_sim.ros__parameters"
    data = {"world_file": "w.yaml", "antenna_max_range_m": [12.0, 20.0, 0.10]}
    with pytest.raises(ConfigError) as refused:
        parameters_from_mapping(ReaderParameters, data, source, prefix)
    assert refused.value.source == source and refused.value.field == f"{prefix}.antenna_max_range_m[1]"
    assert "more than the link budget reaches: 17.78 m on boresight" in refused.value.problem
    # A weaker budget makes the shipped 12 m a claim too far; side antennas (an induction depth) are not bound.
    with pytest.raises(ConfigError, match="link budget"):
        parameters_from_mapping(ReaderParameters, {"world_file": "w.yaml", "sensitivity_dbm": -80.0}, source, prefix)
    parameters_from_mapping(ReaderParameters, {"world_file": "w.yaml", "antenna_positions": [0.0, 0.2, 0.1],
                                               "antenna_facing": ["left"], "antenna_max_range_m": [30.0],
                                               "antenna_half_angle_deg": [85.0], "antenna_phase_offset_rad": [0.0]},
                            source, prefix)


# ------------------------------------------------------------------------------------ listed tags by k-d tree

def reads_of_every_tag(sim: ReaderSimulator, antenna_world: np.ndarray, frequency: float) -> list:
    """The listed-tag round before the k-d tree, as the reference: every antenna against every tag."""
    model = sim.model
    offsets = sim.tag_positions[None, :, :] - antenna_world[:, None, :]
    distance = np.maximum(np.linalg.norm(offsets, axis=2), 1e-3)
    facing = np.array([1.0 if a.facing_up else -1.0 for a in model.antennas])[:, None]
    cos_off_axis = facing * offsets[:, :, 2] / distance
    max_range = np.array([a.max_range_m for a in model.antennas])[:, None]
    min_cos = np.cos(np.array([a.half_angle_rad for a in model.antennas]))[:, None]
    rssi = link_rssi_dbm(model, distance, cos_off_axis)
    listing = np.array([a.side_bearing_rad is None for a in model.antennas])[:, None]
    readable = listing & (distance <= max_range) & (cos_off_axis >= min_cos) & (rssi >= model.sensitivity_dbm)
    antenna_index, tag_index = np.nonzero(readable)
    if antenna_index.size == 0:
        return []
    phase_offsets = (sim.tag_phase_offsets[tag_index]
                     + np.array([model.antennas[a].phase_offset_rad for a in antenna_index]))
    return sim.reads_of([sim.tag_ids[t] for t in tag_index], antenna_index, distance[antenna_index, tag_index],
                        phase_offsets, rssi[antenna_index, tag_index], frequency)


@pytest.mark.parametrize(("count", "half_side_m"), [(50, 0.5), (2000, 20.0)])   # every tag taken; in the tree
@pytest.mark.parametrize("params", ["reader_uhf_2ant", "reader_hf_floor", "reader_floor_lattice"])
def test_a_round_over_the_tags_the_tree_finds_equals_the_round_over_every_tag(params: str, count: int,
                                                                              half_side_m: float) -> None:
    # Ceiling and floor tags over a square, random poses on it and off it; the same noise streams.
    from rfidnav_experiments.runners.shipped import file_parameters
    from rfidnav_scenario.scenario import CONFIG_DIR

    model = file_parameters(ReaderParameters, CONFIG_DIR / "params" / f"{params}.yaml", "rfid_reader_sim",
                            world_file="w.yaml").reader_model()
    layout = np.random.default_rng(3)
    positions = np.column_stack((layout.uniform(-half_side_m, half_side_m, (count, 2)),
                                 layout.choice([0.0, 2.5, 3.0], count)))
    offsets = layout.uniform(-math.pi, math.pi, count)
    ids = [f"T{index}" for index in range(count)]
    edge = 1.25 * half_side_m
    poses = layout.uniform((-edge, -edge, -math.pi), (edge, edge, math.pi), (300, 3))
    tree, every = (ReaderSimulator(model, ids, positions, offsets, np.random.default_rng(9)) for _ in range(2))
    heard = 0
    for x, y, yaw in poses:
        antennas = tree.antenna_positions(x, y, yaw)
        reads = tree.listed_tag_reads(antennas, 915.25e6)
        assert reads == reads_of_every_tag(every, antennas, 915.25e6)
        heard += len(reads)
    assert heard > 0
