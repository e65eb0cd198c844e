"""Archimedean spiral search of paper 003 (Sec. 3.3): Lemma 1, the 2 pi d turn separation, which tag groups
the spiral is sure to cross, the motion primitive's commands, and Theorem 1 in its printed and Rayleigh forms.

Crossing guarantees are checked with :func:`simulate_crossing` (the spiral against the outline polylines, read
range 0), not with :func:`simulate_search` against tag points: at read range 0 a point tag is read only if the
path passes exactly over it, which has probability zero."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from rfidnav_common.polling import PollClock, Polling
from rfidnav_common.seeding import rng_for
from rfidnav_common.tag_groups import (
    HF_READ_RANGE_M,
    TagGroup,
    paper_size_for_separation,
)
from rfidnav_control.spiral import (
    GUARANTEE_DISTANCE_IN_D,
    SearchPolls,
    SpiralSearch,
    expected_search_length,
    length_to_radius,
    separation_for_group,
    simulate_crossing,
    simulate_search,
    spiral_curvature,
    spiral_length,
    spiral_point,
    theta_at_length,
)

pytestmark = pytest.mark.tier("unit")

D = 0.03
TRIALS = 200


def dense_spiral(theta_max: float, d: float, samples: int = 200_001) -> np.ndarray:
    return spiral_point(np.linspace(0.0, theta_max, samples), d)


@pytest.mark.parametrize("theta", [0.3, 2 * math.pi, 40.0])
def test_lemma_1_matches_the_arc_length_of_a_fine_polyline(theta: float) -> None:
    polyline = dense_spiral(theta, D)
    numerical = np.linalg.norm(np.diff(polyline, axis=0), axis=1).sum()
    assert spiral_length(theta, D) == pytest.approx(numerical, rel=1e-3)
    assert length_to_radius(D * theta, D) == pytest.approx(spiral_length(theta, D))


def test_theta_at_length_inverts_lemma_1() -> None:
    theta = np.array([0.0, 1e-9, 1e-3, 0.5, 7.0, 300.0])
    np.testing.assert_allclose(theta_at_length(spiral_length(theta, D), D), theta, rtol=1e-12, atol=1e-15)
    assert isinstance(theta_at_length(0.2, D), float)
    with pytest.raises(ValueError, match="length_m"):
        theta_at_length(-1.0, D)


@pytest.mark.parametrize("ray_angle", [0.1, 1.9, 4.0, 6.2])
def test_consecutive_intersections_of_a_ray_are_2_pi_d_apart(ray_angle: float) -> None:
    polyline = dense_spiral(12 * math.pi, D)
    direction = np.array([math.cos(ray_angle), math.sin(ray_angle)])
    normal = np.array([-direction[1], direction[0]])
    side = polyline @ normal
    along = polyline @ direction
    i = np.flatnonzero((side[:-1] < 0) & (side[1:] >= 0))  # CCW spiral crosses the ray from its right
    t = side[i] / (side[i] - side[i + 1])
    radii = along[i] + t * (along[i + 1] - along[i])
    assert len(radii) == 6
    assert radii[0] == pytest.approx(D * ray_angle, rel=1e-6)
    np.testing.assert_allclose(np.diff(radii), 2 * math.pi * D, rtol=1e-6)


def test_a_circle_of_diameter_2_pi_d_is_crossed_wherever_it_lies() -> None:
    rng = np.random.default_rng(3)
    diameter = 2 * math.pi * D
    assert separation_for_group("circle", diameter) == pytest.approx(D)
    for _ in range(TRIALS):
        distance, bearing = 0.6 * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
        group = TagGroup("C", "circle", (distance * math.cos(bearing), distance * math.sin(bearing)),
                         size_m=diameter, rotation_rad=rng.uniform(0, 2 * math.pi))
        found = simulate_crossing(group.outline_segments(), (0.0, 0.0), rng.uniform(-math.pi, math.pi), D,
                                  max_radius_m=distance + diameter)
        assert found is not None, group


def test_the_paper_cross_is_crossed_beyond_the_documented_distance_but_not_always_nearer() -> None:
    size = math.pi ** 2 * D
    assert separation_for_group("cross", size) == pytest.approx(D)
    rng = np.random.default_rng(4)
    near = GUARANTEE_DISTANCE_IN_D["cross"] * D
    for _ in range(TRIALS):
        distance, bearing = near + rng.uniform(0, 4 * math.pi * D), rng.uniform(0, 2 * math.pi)
        group = TagGroup("X", "cross", (distance * math.cos(bearing), distance * math.sin(bearing)),
                         size_m=size, rotation_rad=rng.uniform(0, 2 * math.pi))
        assert simulate_crossing(group.outline_segments(), (0.0, 0.0), 0.0, D, distance + size) is not None, group
    # A placement at 6.32 d that nests between two turns (found by the search behind GUARANTEE_DISTANCE_IN_D).
    distance, bearing = 6.32 * D, 4.284
    hidden = TagGroup("X", "cross", (distance * math.cos(bearing), distance * math.sin(bearing)), size_m=size,
                      rotation_rad=0.1847)
    assert simulate_crossing(hidden.outline_segments(), (0.0, 0.0), 0.0, D, distance + size) is None


def test_a_reader_range_widens_the_group_by_twice_the_range() -> None:
    assert separation_for_group("cross", 0.29, 0.05) == pytest.approx((0.29 + 2 * math.sqrt(2) * 0.05) / math.pi ** 2)
    assert separation_for_group("circle", 0.2, 0.05) == pytest.approx(separation_for_group("circle", 0.3))
    with pytest.raises(ValueError, match="read_range_m"):
        separation_for_group("cross", 0.29, -0.01)


def test_the_paper_square_can_hide_between_turns_far_out_but_the_wider_square_cannot() -> None:
    # Centred between the turns crossing the +x axis at 20 pi d and 22 pi d, sides radial and tangential.
    centre = (21 * math.pi * D, 0.0)
    paper = TagGroup("S", "square", centre, size_m=paper_size_for_separation("square", 2 * math.pi * D))
    assert simulate_crossing(paper.outline_segments(), (0.0, 0.0), 0.0, D, 25 * math.pi * D) is None
    wider = TagGroup("S", "square", centre, size_m=D / separation_for_group("square", 1.0))
    assert wider.size_m > 2 * math.pi * D
    assert simulate_crossing(wider.outline_segments(), (0.0, 0.0), 0.0, D, 25 * math.pi * D) is not None


def test_hf_tags_are_read_no_later_than_the_outline_is_crossed() -> None:
    rng = np.random.default_rng(5)
    step = 0.005
    for _ in range(50):
        distance, bearing = rng.uniform(0.1, 0.6), rng.uniform(0, 2 * math.pi)
        group = TagGroup("C", "circle", (distance * math.cos(bearing), distance * math.sin(bearing)),
                         size_m=2 * math.pi * D, rotation_rad=rng.uniform(0, 2 * math.pi))
        heading = rng.uniform(-math.pi, math.pi)
        crossed = simulate_crossing(group.outline_segments(), (0.0, 0.0), heading, D, distance + 0.2, step)
        read = simulate_search(group.tag_positions(), (0.0, 0.0), heading, D, HF_READ_RANGE_M, distance + 0.2,
                               step)
        assert crossed is not None and read is not None and read <= crossed + step


def test_simulate_search_starts_in_the_spiral_frame_and_gives_up_at_max_radius() -> None:
    assert simulate_search(np.array([[1.0, 2.0]]), (1.0, 2.0), 0.3, D, 0.01, 0.5) == 0.0
    assert simulate_search(np.array([[3.0, 0.0]]), (0.0, 0.0), 0.0, D, HF_READ_RANGE_M, 0.5) is None
    # A tag on the start heading, three turns out: read about where the spiral angle reaches 6 pi.
    heading = 1.1
    tag = np.array([[1.0, 2.0]]) + 6 * math.pi * D * np.array([math.cos(heading), math.sin(heading)])
    read = simulate_search(tag, (1.0, 2.0), heading, D, 0.01, 0.7, step_m=0.001)
    assert read == pytest.approx(spiral_length(6 * math.pi, D), abs=0.015)


def polls(seed: int, speed_m_s: float = 0.2, failure: float = 0.1) -> SearchPolls:
    return SearchPolls(speed_m_s, PollClock(Polling(0.5, 0.1, failure), rng_for(seed, "polls")))


def test_a_polled_reader_reads_no_sooner_than_a_continuous_one_and_misses_passes_of_the_group() -> None:
    """Polls 0.5-0.6 s apart at 0.2 m/s: the robot reads only every 10-12 cm of the spiral, so it sees the cross
    later than a reader that reads all the way, and a pass over it between two polls not at all."""
    rng = np.random.default_rng(11)
    later = continuous_found = polled_found = 0
    for trial in range(TRIALS):
        distance, bearing, rotation, heading = 0.4, *rng.uniform(-math.pi, math.pi, 3)
        group = TagGroup("C", "cross", (distance * math.cos(bearing), distance * math.sin(bearing)), 0.29, rotation)
        continuous = simulate_search(group.tag_positions(), (0.0, 0.0), heading, D, HF_READ_RANGE_M, 0.9)
        polled = simulate_search(group.tag_positions(), (0.0, 0.0), heading, D, HF_READ_RANGE_M, 0.9,
                                 polls=polls(trial))
        continuous_found += continuous is not None
        polled_found += polled is not None
        if continuous is not None and polled is not None:
            assert polled >= continuous - 0.005            # the continuous reader's sampling step
            later += polled > continuous + 0.05
    assert continuous_found == TRIALS and polled_found < TRIALS
    assert later > TRIALS // 2


def test_the_same_poll_seed_gives_the_same_polled_search_and_polls_fall_where_the_robot_is() -> None:
    tags = TagGroup("C", "cross", (0.25, 0.1), 0.29, 0.2).tag_positions()
    first = simulate_search(tags, (0.0, 0.0), 0.4, D, HF_READ_RANGE_M, 0.8, polls=polls(4))
    again = simulate_search(tags, (0.0, 0.0), 0.4, D, HF_READ_RANGE_M, 0.8, polls=polls(4))
    assert first is not None and first == again
    assert np.any(np.isclose(np.concatenate(list(polls(4).lengths(5.0))), first))    # a poll that read
    every = np.concatenate(list(polls(4, failure=0.0).lengths(5.0)))
    assert np.all(np.diff(every) >= 0.2 * 0.5 - 1e-12) and np.all(np.diff(every) <= 0.2 * 0.6 + 1e-12)


def test_command_follows_the_curvature_of_the_path() -> None:
    search = SpiralSearch(d=D, speed_m_s=0.2, max_radius_m=0.6, origin=(0.5, -1.0), start_heading=2.0)
    step = 0.001
    path = search.path(step)
    assert np.allclose(path[0], search.origin)
    segments = np.diff(path, axis=0)
    # The first chord already turns by about half the spiral angle at its end, step / d.
    assert math.atan2(segments[0, 1], segments[0, 0]) == pytest.approx(search.start_heading, abs=step / D)
    turning = np.diff(np.unwrap(np.arctan2(segments[:, 1], segments[:, 0])))
    for index in (5, 100, 1000, len(turning) // 2, len(turning) - 5):
        v, omega = search.command(index * step + step)  # the vertex between segments index and index + 1
        assert v == 0.2
        assert omega / v == pytest.approx(turning[index] / step, rel=1e-3)
    assert search.command(0.0) == (0.2, pytest.approx(0.2 * 2 / D))


def test_command_stops_beyond_max_radius_and_can_be_clipped() -> None:
    search = SpiralSearch(d=D, speed_m_s=0.2, max_radius_m=0.6)
    end = search.max_length_m
    assert end == pytest.approx(spiral_length(0.6 / D, D))
    assert search.command(end * (1 - 1e-9)) is not None
    assert search.command(end * (1 + 1e-9)) is None
    clipped = SpiralSearch(d=D, speed_m_s=0.2, max_radius_m=0.6, max_angular_speed=2.0)
    assert clipped.command(0.0) == (0.2, 2.0)
    late = 0.5 * end  # curvature below 10 / m there: unclipped
    assert spiral_curvature(theta_at_length(late, D), D) < 10.0
    assert clipped.command(late) == search.command(late)


@pytest.mark.parametrize(("changes", "field"), [({"d": 0.0}, "d"), ({"speed_m_s": -1.0}, "speed_m_s"),
                                                ({"max_radius_m": math.nan}, "max_radius_m"),
                                                ({"max_angular_speed": 0.0}, "max_angular_speed")])
def test_spiral_search_rejects_bad_parameters_naming_them(changes: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        SpiralSearch(**({"d": D, "speed_m_s": 0.2, "max_radius_m": 0.6} | changes))


def test_theorem_1_as_printed_is_half_the_half_normal_expectation() -> None:
    sigma = 0.5
    half_normal = stats.halfnorm.expect(lambda e: length_to_radius(e, D), scale=sigma)
    assert expected_search_length(sigma, D, as_printed=True) == pytest.approx(half_normal / 2, rel=1e-6)


def test_theorem_1_with_a_rayleigh_distance_matches_monte_carlo() -> None:
    sigma = 0.5
    distances = stats.rayleigh.rvs(scale=sigma, size=10_000, random_state=np.random.default_rng(6))
    monte_carlo = np.mean(length_to_radius(distances, D))
    rayleigh = expected_search_length(sigma, D, as_printed=False)
    assert rayleigh == pytest.approx(monte_carlo, rel=0.03)
    assert rayleigh == pytest.approx(sigma ** 2 / D, rel=0.05)
