"""WiFi fingerprint matching of paper 003's location server: pure-module tests with numbers.

Known answers come from small maps worked by hand, and from a 1 m grid whose RSS is a hand-made function of
the distance to five access points, checked against a plain-Python k-nearest-neighbour reference.
"""

from __future__ import annotations

import math

import pytest

from rfidnav_localization.errors import LocateError
from rfidnav_localization.fingerprint import Fingerprint, LocateSettings, RadioMap

pytestmark = pytest.mark.tier("unit")

ACCESS_POINTS = {"ap:00": (0.0, 0.0), "ap:90": (9.0, 0.0), "ap:04": (0.0, 4.0), "ap:94": (9.0, 4.0),
                 "ap:mid": (4.5, 2.3)}


def rss_at(x: float, y: float) -> dict[str, float]:
    """-40 dBm at an AP, 6 dB weaker per metre: distinct at every grid point, and no AP is ever out of range."""
    return {bssid: -40.0 - 6.0 * math.hypot(x - ax, y - ay) for bssid, (ax, ay) in ACCESS_POINTS.items()}


def grid_map() -> RadioMap:
    return RadioMap(Fingerprint((float(x), float(y)), rss_at(x, y), "grid") for x in range(10) for y in range(5))


def reference_locate(scan: dict[str, float], fingerprints: tuple[Fingerprint, ...], k: int,
                     weighting: str) -> tuple[float, float]:
    """Every fingerprint hears every AP here, so the signal distance is a plain Euclidean one."""
    ranked = sorted(fingerprints, key=lambda f: math.dist([scan[b] for b, _ in f.rss], [v for _, v in f.rss]))
    weights, points = [], []
    for fingerprint in ranked[:k]:
        distance = math.dist([scan[b] for b, _ in fingerprint.rss], [v for _, v in fingerprint.rss])
        weights.append(1.0 / (distance + 1e-6) if weighting == "inverse_distance" else 1.0)
        points.append(fingerprint.position)
    total = sum(weights)
    return (sum(w * p[0] for w, p in zip(weights, points)) / total,
            sum(w * p[1] for w, p in zip(weights, points)) / total)


def three_point_map() -> RadioMap:
    return RadioMap([Fingerprint((0.0, 0.0), {"a": -50.0}), Fingerprint((1.0, 0.0), {"a": -60.0}),
                     Fingerprint((0.0, 1.0), {"a": -70.0})])


@pytest.mark.parametrize("point", [(0, 0), (3, 2), (9, 4), (5, 1)])
def test_a_scan_at_a_grid_point_locates_to_it_with_k1(point):
    result = grid_map().locate(rss_at(*point), LocateSettings(k=1))
    assert result.position == pytest.approx(point, abs=1e-12)
    assert result.neighbours == (point,)
    assert result.signal_distance_db == pytest.approx(0.0, abs=1e-9)
    assert result.known_aps == 5 and result.ignored_bssids == ()
    assert result.uncertainty_m == pytest.approx(0.5)    # floor: half the 1 m spacing


def test_an_exact_match_dominates_the_inverse_distance_mix():
    result = grid_map().locate(rss_at(3, 2), LocateSettings(k=3))
    assert len(result.neighbours) == 3 and result.neighbours[0] == (3.0, 2.0)
    assert result.position == pytest.approx((3.0, 2.0), abs=1e-5)


@pytest.mark.parametrize("weighting", ["inverse_distance", "uniform"])
@pytest.mark.parametrize("k", [1, 3, 4])
@pytest.mark.parametrize("point", [(3.4, 2.0), (0.2, 0.7), (7.5, 3.5), (4.5, 2.3)])
def test_grid_matches_the_plain_python_reference(point, k, weighting):
    radio_map = grid_map()
    result = radio_map.locate(rss_at(*point), LocateSettings(k=k, weighting=weighting))
    assert result.position == pytest.approx(reference_locate(rss_at(*point), radio_map.fingerprints, k, weighting),
                                            abs=1e-9)
    assert math.dist(result.position, point) < 1.0


def test_k3_inverse_distance_mix_worked_by_hand():
    # Signal distances 8, 2, 12 dB: weights 3:12:2 (of 24), so the estimate is (12/17, 2/17).
    result = three_point_map().locate({"a": -58.0}, LocateSettings(k=3))
    assert result.position == pytest.approx((12 / 17, 2 / 17), rel=1e-5)
    assert result.neighbours == ((1.0, 0.0), (0.0, 0.0), (0.0, 1.0))
    assert result.signal_distance_db == pytest.approx(2.0)
    # Weighted squared offsets (3*148 + 12*29 + 2*369) / 289 over the weight 17: above the 0.5 m floor.
    assert result.uncertainty_m == pytest.approx(math.sqrt(1530 / 4913), rel=1e-5)


def test_uniform_weighting_gives_the_centroid():
    result = three_point_map().locate({"a": -58.0}, LocateSettings(k=3, weighting="uniform"))
    assert result.position == pytest.approx((1 / 3, 1 / 3))


def test_unknown_bssids_are_ignored_and_reported():
    radio_map = three_point_map()
    plain = radio_map.locate({"a": -58.0})
    noisy = radio_map.locate({"a": -58.0, "zz:new": -40.0, "yy:phone": -30.0})
    assert noisy.position == plain.position and noisy.signal_distance_db == plain.signal_distance_db
    assert noisy.ignored_bssids == ("yy:phone", "zz:new") and noisy.known_aps == 1


@pytest.mark.parametrize("missing, nearest_db", [(-100.0, 50.0), (-90.0, math.sqrt(30.0 ** 2 + 20.0 ** 2))])
def test_an_ap_heard_on_one_side_counts_as_missing_rss(missing, nearest_db):
    # Scan hears a and c; the nearest fingerprint hears a and b. b: -60 vs missing, c: missing vs -70, a: equal.
    radio_map = RadioMap([Fingerprint((0.0, 0.0), {"a": -50.0, "b": -60.0}), Fingerprint((5.0, 0.0), {"c": -30.0})])
    result = radio_map.locate({"a": -50.0, "c": -70.0}, LocateSettings(k=1, missing_rss_dbm=missing))
    assert result.position == (0.0, 0.0)
    assert result.signal_distance_db == pytest.approx(nearest_db)


def test_an_ap_heard_by_neither_side_adds_nothing():
    base = [Fingerprint((0.0, 0.0), {"a": -50.0})]
    alone = RadioMap(base).locate({"a": -55.0}, LocateSettings(k=1))
    with_far_ap = RadioMap(base + [Fingerprint((9.0, 9.0), {"far": -40.0})]).locate({"a": -55.0},
                                                                                     LocateSettings(k=1))
    assert alone.signal_distance_db == with_far_ap.signal_distance_db == pytest.approx(5.0)


def test_equal_signal_distances_go_to_the_fingerprint_added_first():
    radio_map = RadioMap([Fingerprint((2.0, 0.0), {"a": -50.0}), Fingerprint((0.0, 0.0), {"a": -50.0})])
    assert radio_map.locate({"a": -50.0}, LocateSettings(k=1)).position == (2.0, 0.0)


def test_adding_fingerprints_rebuilds_the_matrix():
    radio_map = three_point_map()
    assert radio_map.locate({"a": -40.0, "b": -45.0}, LocateSettings(k=1)).position == (0.0, 0.0)
    radio_map.add(Fingerprint((4.0, 4.0), {"a": -40.0, "b": -45.0}, "robot"))
    result = radio_map.locate({"a": -40.0, "b": -45.0}, LocateSettings(k=1))
    assert result.position == (4.0, 4.0) and result.known_aps == 2
    assert radio_map.bssids == ("a", "b") and len(radio_map) == 4


@pytest.mark.parametrize("radio_map, scan, settings, reason", [
    (three_point_map(), {}, LocateSettings(), "the scan is empty"),
    (RadioMap(), {"a": -50.0}, LocateSettings(), "the radio map is empty"),
    (three_point_map(), {"x": -50.0, "y": -60.0}, LocateSettings(),
     "none of the scan's 2 access points is in the radio map (x, y)"),
    (RadioMap([Fingerprint((0.0, 0.0), {"a": -50.0}), Fingerprint((1.0, 0.0), {"b": -50.0})]),
     {"a": -50.0, "b": -50.0}, LocateSettings(min_common_aps=2),
     "no fingerprint shares 2 access points with the scan (the best shares 1 of its 2 known ones)"),
    (three_point_map(), {"a": -50.0, "b:ad": math.nan}, LocateSettings(), "access point b:ad: RSS: nan is not finite"),
    (three_point_map(), {"a": -50.0, "b:ad": math.inf}, LocateSettings(), "access point b:ad: RSS: inf is not finite"),
    (three_point_map(), {"b:ad": "strong"}, LocateSettings(),
     "access point b:ad: RSS: expected a number, got 'strong'"),
    (three_point_map(), {"a": -50.0, "b:ad": 1e308}, LocateSettings(), "access point b:ad: RSS: 1e+308 dBm is outside"),
])
def test_unlocatable_scans_raise_locate_error_with_the_reason(radio_map, scan, settings, reason):
    with pytest.raises(LocateError) as raised:
        radio_map.locate(scan, settings)
    assert reason in str(raised.value)


def test_k_larger_than_the_candidates_uses_them_all():
    result = three_point_map().locate({"a": -58.0}, LocateSettings(k=10, weighting="uniform"))
    assert len(result.neighbours) == 3 and result.position == pytest.approx((1 / 3, 1 / 3))


@pytest.mark.parametrize("settings, field", [
    (LocateSettings(k=0), "k"), (LocateSettings(k=2.5), "k"), (LocateSettings(k=True), "k"),
    (LocateSettings(missing_rss_dbm=math.nan), "missing_rss_dbm"),
    (LocateSettings(min_common_aps=0), "min_common_aps"), (LocateSettings(weighting="gaussian"), "weighting"),
])
def test_settings_validation_names_the_field(settings, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        settings.validate()


def test_fingerprint_rss_is_normalised_and_hashable():
    as_mapping = Fingerprint((1, 2), {"b": -60, "a": -50.0}, "robot")
    as_pairs = Fingerprint((1.0, 2.0), (("a", -50.0), ("b", -60.0)), "robot")
    assert as_mapping == as_pairs and hash(as_mapping) == hash(as_pairs)
    assert as_mapping.rss == (("a", -50.0), ("b", -60.0)) and as_mapping.position == (1.0, 2.0)


@pytest.mark.parametrize("position, rss, source, field", [
    ((0.0, math.nan), {"a": -50.0}, "grid", r"position\.y"), ((1e308, 0.0), {"a": -50.0}, "grid", r"position\.x"),
    ((0.0, 0.0), {"a": -1e308}, "grid", r"rss\[a\]"), ((0.0, 0.0), {}, "grid", "rss"),
    ((0.0, 0.0), {"a": math.inf}, "grid", r"rss\[a\]"), ((0.0, 0.0), (("a", -1.0), ("a", -2.0)), "grid", r"rss\[a\]"),
    ((0.0, 0.0), {"": -50.0}, "grid", "rss"), ((0.0, 0.0), {"a": -50.0}, "guess", "source"),
])
def test_fingerprint_validation_names_the_field(position, rss, source, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        Fingerprint(position, rss, source)


def test_spacing_ignores_repeated_positions():
    radio_map = RadioMap([Fingerprint((0.0, 0.0), {"a": -50.0}), Fingerprint((0.0, 0.0), {"a": -52.0}),
                          Fingerprint((2.0, 0.0), {"a": -60.0}), Fingerprint((2.0, 3.0), {"a": -70.0})])
    assert radio_map.spacing_m == pytest.approx(2.0)   # nearest-other distances 2, 2, 3: median 2
    assert RadioMap([Fingerprint((0.0, 0.0), {"a": -50.0})]).spacing_m == 0.0
