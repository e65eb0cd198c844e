"""WiFi RSS model (paper 003): channel frequencies, Friis reference loss, log-distance slope, wall counting,
the spatially correlated shadowing field, scan noise, sensitivity, validation.

Pure-module tests: no ROS. Expected losses are worked out by hand in the comments.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_sim.wifi_model import (
    AccessPoint,
    PropagationSettings,
    RssReading,
    WifiModel,
    free_space_loss_db,
    walls_crossed,
)

pytestmark = pytest.mark.tier("unit")

QUIET = PropagationSettings(shadowing_sd_db=0.0, scan_noise_sd_db=0.0)
FREQ_CH6_LOSS_1M_DB = 40.18            # 20 log10(4 pi * 2.437e9 / 299792458) = 20 log10(102.15)


def ap(bssid: str = "aa:bb:cc:dd:ee:01", position: tuple[float, float] = (0.0, 0.0), channel: int = 6,
       tx_power_dbm: float = 20.0) -> AccessPoint:
    return AccessPoint(bssid=bssid, ssid="lab", position=position, tx_power_dbm=tx_power_dbm, channel=channel)


def no_walls() -> np.ndarray:
    return np.empty((0, 4))


@pytest.mark.parametrize(("channel", "frequency_hz"), [(1, 2412e6), (6, 2437e6), (13, 2472e6), (14, 2484e6),
                                                       (36, 5180e6), (165, 5825e6)])
def test_channel_frequencies(channel: int, frequency_hz: float) -> None:
    assert ap(channel=channel).frequency_hz == frequency_hz


@pytest.mark.parametrize("channel", [0, 15, 35, 166])
def test_unknown_channel_is_rejected(channel: int) -> None:
    with pytest.raises(ValueError, match="^channel:"):
        ap(channel=channel)


def test_free_space_reference_loss() -> None:
    assert free_space_loss_db(1.0, 2.437e9) == pytest.approx(FREQ_CH6_LOSS_1M_DB, abs=0.01)
    assert free_space_loss_db(1.0, 5.18e9) == pytest.approx(46.73, abs=0.01)     # 20 log10(217.13)
    assert free_space_loss_db(10.0, 2.437e9) == pytest.approx(FREQ_CH6_LOSS_1M_DB + 20.0, abs=0.01)


def test_rss_at_one_metre_is_tx_power_minus_reference_loss() -> None:
    model = WifiModel([ap(tx_power_dbm=20.0)], no_walls(), QUIET, world_seed=1)
    assert model.mean_rss_dbm(np.array([[1.0, 0.0]]))[0, 0] == pytest.approx(20.0 - FREQ_CH6_LOSS_1M_DB, abs=0.01)
    fixed = WifiModel([ap(tx_power_dbm=20.0)], no_walls(), PropagationSettings(reference_loss_db=30.0,
                                                                               shadowing_sd_db=0.0), world_seed=1)
    assert fixed.mean_rss_dbm(np.array([[0.0, 1.0]]))[0, 0] == pytest.approx(-10.0)


@pytest.mark.parametrize("exponent", [2.0, 3.0, 3.5])
def test_path_loss_falls_10n_db_per_decade(exponent: float) -> None:
    settings = PropagationSettings(path_loss_exponent=exponent, shadowing_sd_db=0.0)
    model = WifiModel([ap(position=(2.0, -1.0))], no_walls(), settings, world_seed=1)
    rss = model.mean_rss_dbm(np.array([[3.0, -1.0], [2.0, 9.0], [-98.0, -1.0]]))[:, 0]    # 1, 10, 100 m
    assert np.diff(rss) == pytest.approx([-10.0 * exponent, -10.0 * exponent])


def test_distance_is_clamped_near_the_access_point() -> None:
    model = WifiModel([ap()], no_walls(), QUIET, world_seed=1)
    rss = model.mean_rss_dbm(np.array([[0.0, 0.0], [0.2, 0.0], [0.5, 0.0], [1.0, 0.0]]))[:, 0]
    assert rss[0] == rss[1] == rss[2] == pytest.approx(rss[3] + 20.0 * math.log10(2.0))


def test_each_wall_between_ap_and_point_costs_wall_loss() -> None:
    walls = np.array([[5.0, -10.0, 5.0, 10.0], [8.0, -10.0, 8.0, 10.0]])
    points = np.array([[3.0, 0.0], [6.0, 0.0], [10.0, 0.0], [10.0, 3.0]])
    walled = WifiModel([ap()], walls, QUIET, world_seed=1).mean_rss_dbm(points)[:, 0]
    open_space = WifiModel([ap()], no_walls(), QUIET, world_seed=1).mean_rss_dbm(points)[:, 0]
    assert open_space - walled == pytest.approx([0.0, 5.0, 10.0, 10.0], abs=1e-9)
    assert walled[2] == pytest.approx(20.0 - FREQ_CH6_LOSS_1M_DB - 20.0 - 10.0, abs=0.01)     # 10 m, 2 walls


def test_mean_rss_adds_wall_loss_and_shadowing_to_path_loss() -> None:
    walls = np.array([[5.0, -100.0, 5.0, 100.0]])
    points = np.random.default_rng(8).uniform(6.0, 20.0, (50, 2))                  # all behind the wall
    settings = PropagationSettings(wall_loss_db=7.0)
    shadowed = WifiModel([ap()], walls, settings, world_seed=3)
    open_space = WifiModel([ap()], no_walls(), settings, world_seed=3).mean_rss_dbm(points)
    unshadowed = WifiModel([ap()], walls, PropagationSettings(wall_loss_db=7.0, shadowing_sd_db=0.0), world_seed=3)
    field = shadowed.shadowing_db(points)
    assert np.abs(field).max() > 1.0
    assert open_space - shadowed.mean_rss_dbm(points) == pytest.approx(np.full((50, 1), 7.0), abs=1e-9)
    assert shadowed.mean_rss_dbm(points) - unshadowed.mean_rss_dbm(points) == pytest.approx(field, abs=1e-9)


def test_walls_crossed_hand_built_geometry() -> None:
    walls = np.array([[2.0, -1.0, 2.0, 1.0], [4.0, -1.0, 4.0, 1.0]])
    points = np.array([[1.0, 0.0], [3.0, 0.0], [5.0, 0.0], [3.0, 0.5], [5.0, 5.0], [-3.0, 0.0], [2.0, 0.0]])
    # behind none, one, two; a slanted ray through the first; a ray passing above both; behind the source;
    # a point standing on a wall is not behind it
    assert walls_crossed(points, (0.0, 0.0), walls).tolist() == [0, 1, 2, 1, 0, 0, 0]


def test_walls_crossed_parallel_and_collinear_walls() -> None:
    above = np.array([[0.0, 1.0, 10.0, 1.0]])
    assert walls_crossed(np.array([[10.0, 0.0], [5.0, 2.0]]), (0.0, 0.0), above).tolist() == [0, 1]
    along = np.array([[1.0, 0.0, 3.0, 0.0]])
    assert walls_crossed(np.array([[5.0, 0.0], [2.0, 0.0]]), (0.0, 0.0), along).tolist() == [0, 0]


@pytest.mark.parametrize("lower", [[2.0, -1.0, 2.0, 1.0], [2.0, 1.0, 2.0, -1.0]])
@pytest.mark.parametrize("upper", [[2.0, 1.0, 2.0, 3.0], [2.0, 3.0, 2.0, 1.0]])
def test_ray_through_a_wall_end(lower: list[float], upper: list[float]) -> None:
    point = np.array([[4.0, 2.0]])                     # the ray y = x / 2 passes through (2, 1)
    each = [int(walls_crossed(point, (0.0, 0.0), np.array([w]))[0]) for w in (lower, upper)]
    assert all(count in (0, 1) for count in each)
    # the two halves of the wall x = 2, y in [-1, 3] joined at (2, 1): crossed once, whatever their direction
    assert walls_crossed(point, (0.0, 0.0), np.array([lower, upper]))[0] == 1


def test_walls_crossed_agrees_with_solving_each_intersection() -> None:
    rng = np.random.default_rng(5)
    walls = rng.uniform(0.0, 20.0, (12, 4))
    points = rng.uniform(0.0, 20.0, (150, 2))
    source = np.array([7.3, 11.1])
    expected = np.zeros(len(points), dtype=int)
    for m, point in enumerate(points):
        for x1, y1, x2, y2 in walls:
            # source + t (point - source) = (x1, y1) + u (x2 - x1, y2 - y1), both strictly inside (0, 1)
            t, u = np.linalg.solve(np.array([[point[0] - source[0], x1 - x2], [point[1] - source[1], y1 - y2]]),
                                   np.array([x1 - source[0], y1 - source[1]]))
            expected[m] += 0.0 < t < 1.0 and 0.0 < u < 1.0
    assert walls_crossed(points, tuple(source), walls).tolist() == expected.tolist()
    assert expected.max() >= 2                          # the geometry exercises multiple crossings


def test_shadowing_is_fixed_by_world_seed_and_bssid() -> None:
    points = np.random.default_rng(0).uniform(0.0, 30.0, (200, 2))
    first = WifiModel([ap("aa:bb:cc:dd:ee:01"), ap("aa:bb:cc:dd:ee:02")], no_walls(), PropagationSettings(), 11)
    again = WifiModel([ap("aa:bb:cc:dd:ee:01"), ap("aa:bb:cc:dd:ee:02")], no_walls(), PropagationSettings(), 11)
    other_world = WifiModel([ap("aa:bb:cc:dd:ee:01")], no_walls(), PropagationSettings(), 12)
    alone = WifiModel([ap("aa:bb:cc:dd:ee:02")], no_walls(), PropagationSettings(), 11)
    field = first.shadowing_db(points)
    np.testing.assert_array_equal(field, again.shadowing_db(points))
    np.testing.assert_array_equal(field[:, 1], alone.shadowing_db(points)[:, 0])      # other APs do not matter
    assert np.abs(field[:, 0] - field[:, 1]).max() > 1.0                                 # another bssid
    assert np.abs(field[:, 0] - other_world.shadowing_db(points)[:, 0]).max() > 1.0      # another world


@pytest.mark.parametrize(("sd_db", "correlation_m", "seed"), [(4.0, 2.0, 1), (8.0, 1.0, 2), (3.0, 5.0, 3)])
def test_shadowing_spread_and_spatial_correlation(sd_db: float, correlation_m: float, seed: int) -> None:
    settings = PropagationSettings(shadowing_sd_db=sd_db, shadowing_correlation_m=correlation_m)
    model = WifiModel([ap()], no_walls(), settings, world_seed=seed)
    rng = np.random.default_rng(seed)
    points = rng.uniform(-500.0 * correlation_m, 500.0 * correlation_m, (4000, 2))
    values = model.shadowing_db(points)[:, 0]
    assert abs(values.std() / sd_db - 1.0) < 0.15
    assert abs(values.mean()) < 0.15 * sd_db
    directions = rng.uniform(0.0, 2.0 * math.pi, len(points))
    unit = np.column_stack((np.cos(directions), np.sin(directions)))
    near = model.shadowing_db(points + 0.1 * correlation_m * unit)[:, 0]
    at_length = model.shadowing_db(points + correlation_m * unit)[:, 0]
    far = model.shadowing_db(points + 5.0 * correlation_m * unit)[:, 0]
    assert np.corrcoef(values, near)[0, 1] > 0.9                  # kernel: exp(-0.1^2 / 2) = 0.995
    assert np.corrcoef(values, at_length)[0, 1] == pytest.approx(math.exp(-0.5), abs=0.1)     # 0.61
    assert abs(np.corrcoef(values, far)[0, 1]) < 0.2              # kernel: exp(-5^2 / 2) = 4e-6


def test_scan_noise_spread_and_independence() -> None:
    settings = PropagationSettings(shadowing_sd_db=0.0, scan_noise_sd_db=2.0)
    model = WifiModel([ap("aa:bb:cc:dd:ee:01"), ap("aa:bb:cc:dd:ee:02", position=(6.0, 0.0))], no_walls(),
                      settings, world_seed=1)
    rng = np.random.default_rng(9)
    scans = np.array([[r.rssi_dbm for r in model.scan(3.0, 4.0, rng)] for _ in range(2000)])
    assert scans.shape == (2000, 2)                               # both APs 5 m away, about -34 dBm
    assert scans.mean(axis=0) == pytest.approx(model.mean_rss_dbm(np.array([[3.0, 4.0]]))[0], abs=0.2)
    assert scans.std(axis=0) == pytest.approx([2.0, 2.0], rel=0.1)
    assert abs(np.corrcoef(scans.T)[0, 1]) < 0.1


def test_scan_reports_the_access_point_and_repeats_with_the_seed() -> None:
    model = WifiModel([ap("aa:bb:cc:dd:ee:07", channel=36)], no_walls(), PropagationSettings(), world_seed=4)
    first = model.scan(1.0, 2.0, np.random.default_rng(3))
    assert first == model.scan(1.0, 2.0, np.random.default_rng(3))
    assert [(r.bssid, r.ssid, r.channel, r.frequency_hz) for r in first] == [("aa:bb:cc:dd:ee:07", "lab", 36, 5180e6)]
    assert isinstance(first[0], RssReading)


def test_sensitivity_drops_far_access_points() -> None:
    near, far = ap("aa:bb:cc:dd:ee:01"), ap("aa:bb:cc:dd:ee:02", position=(500.0, 0.0))
    deaf = PropagationSettings(path_loss_exponent=3.0, shadowing_sd_db=0.0, scan_noise_sd_db=0.0)
    # at (5, 0): near 20 - 40.18 - 30 log10(5) = -41.15 dBm; far 20 - 40.18 - 30 log10(495) = -101.02 dBm
    heard = WifiModel([near, far], no_walls(), deaf, world_seed=1).scan(5.0, 0.0, np.random.default_rng(0))
    assert [r.bssid for r in heard] == ["aa:bb:cc:dd:ee:01"]
    assert heard[0].rssi_dbm == pytest.approx(-41.15, abs=0.01)
    keen = PropagationSettings(path_loss_exponent=3.0, shadowing_sd_db=0.0, scan_noise_sd_db=0.0,
                               sensitivity_dbm=-110.0)
    heard = WifiModel([near, far], no_walls(), keen, world_seed=1).scan(5.0, 0.0, np.random.default_rng(0))
    assert [r.rssi_dbm for r in heard] == pytest.approx([-41.15, -101.02], abs=0.01)


def test_no_access_points_gives_empty_scans() -> None:
    model = WifiModel([], np.array([[0.0, 0.0, 1.0, 1.0]]), PropagationSettings(), world_seed=1)
    assert model.mean_rss_dbm(np.zeros((5, 2))).shape == (5, 0)
    assert model.scan(0.0, 0.0, np.random.default_rng(0)) == []


@pytest.mark.parametrize(("field", "value"), [
    ("path_loss_exponent", 0.0), ("path_loss_exponent", math.nan), ("reference_loss_db", math.inf),
    ("wall_loss_db", -1.0), ("shadowing_sd_db", -0.5), ("shadowing_correlation_m", 0.0),
    ("scan_noise_sd_db", -0.1), ("sensitivity_dbm", math.nan), ("min_distance_m", 0.0)])
def test_bad_settings_name_the_field(field: str, value: float) -> None:
    settings = PropagationSettings(**{field: value})
    with pytest.raises(ValueError, match=f"^{field}:"):
        settings.validate()
    with pytest.raises(ValueError, match=f"^{field}:"):
        WifiModel([ap()], no_walls(), settings, world_seed=1)


def test_default_settings_are_valid() -> None:
    PropagationSettings().validate()


@pytest.mark.parametrize(("kwargs", "field"), [({"bssid": "aa:bb:cc:dd:ee"}, "bssid"),
                                               ({"bssid": "aa:bb:cc:dd:ee:fg"}, "bssid"),
                                               ({"position": (0.0, math.nan)}, "position"),
                                               ({"tx_power_dbm": math.inf}, "tx_power_dbm"),
                                               ({"channel": 20}, "channel")])
def test_bad_access_point_names_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        ap(**kwargs)


@pytest.mark.parametrize("second", ["aa:bb:cc:dd:ee:ff", "AA:BB:CC:DD:EE:FF"])
def test_duplicate_bssid_is_rejected(second: str) -> None:
    with pytest.raises(ValueError, match="^bssid: .* twice"):
        WifiModel([ap("aa:bb:cc:dd:ee:ff"), ap(second, position=(5.0, 5.0))], no_walls(), PropagationSettings(), 1)


def test_walls_must_be_rows_of_four() -> None:
    with pytest.raises(ValueError, match="^walls:"):
        WifiModel([ap()], np.zeros((3, 3)), PropagationSettings(), world_seed=1)
