"""Ultrasonic rangefinder model (paper 004 section 4): ray casting against walls, the beam cone's nearest echo,
range limits (sensor_msgs/Range conventions), noise, and the seven-sonar layout in a hallway.

Pure-module tests: no ROS. Expected distances are worked out by hand in the comments.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_sim.sonar_model import PAPER_LAYOUT, Rangefinder, SonarModel, cast_rays
from support.reference_cores import cast_rays as reference_cast
from support.reference_cores import sonar_ranges

pytestmark = pytest.mark.tier("unit")

SQRT_HALF = math.sqrt(0.5)


def one_ray(origin: tuple[float, float], direction: tuple[float, float], walls: list[list[float]]) -> float:
    return float(cast_rays(np.array([origin]), np.array([direction]), np.array(walls))[0])


def boresight_sonar(name: str = "front", bearing_deg: float = 0.0, **kwargs) -> Rangefinder:
    """A sonar at base_link's origin, so readings are distances from the robot's centre."""
    return Rangefinder(name, (0.0, 0.0), math.radians(bearing_deg), **kwargs)


def quiet(rangefinders, walls, rays_per_beam: int = 5) -> SonarModel:
    return SonarModel(rangefinders, np.array(walls, dtype=float), noise_sd_m=0.0, noise_fraction=0.0,
                      rays_per_beam=rays_per_beam)


RNG = np.random.default_rng(0)     # noise-free models never draw a non-zero value from it

# --------------------------------------------------------------------------------------------------- cast_rays


def test_ray_straight_into_a_wall_2_m_away() -> None:
    assert one_ray((0.0, 0.0), (1.0, 0.0), [[2.0, -1.0, 2.0, 1.0]]) == pytest.approx(2.0)


def test_ray_at_45_degrees_travels_2_sqrt_2() -> None:
    # From the origin at 45 deg, the wall x = 2 is met at (2, 2): sqrt(2^2 + 2^2).
    assert one_ray((0.0, 0.0), (SQRT_HALF, SQRT_HALF), [[2.0, -5.0, 2.0, 5.0]]) == pytest.approx(2.0 * math.sqrt(2.0))


def test_parallel_rays_miss_even_inside_a_collinear_wall() -> None:
    assert one_ray((0.0, 0.0), (1.0, 0.0), [[0.0, 1.0, 5.0, 1.0]]) == math.inf
    assert one_ray((0.0, 0.0), (1.0, 0.0), [[1.0, 0.0, 5.0, 0.0]]) == math.inf


def test_nearest_of_two_walls_whatever_their_order() -> None:
    walls = [[3.0, -1.0, 3.0, 1.0], [2.0, -1.0, 2.0, 1.0]]
    assert one_ray((0.0, 0.0), (1.0, 0.0), walls) == pytest.approx(2.0)
    assert one_ray((0.0, 0.0), (1.0, 0.0), walls[::-1]) == pytest.approx(2.0)


def test_walls_behind_or_beside_the_ray_are_missed_and_ends_are_hit() -> None:
    assert one_ray((0.0, 0.0), (-1.0, 0.0), [[2.0, -1.0, 2.0, 1.0]]) == math.inf       # behind
    assert one_ray((0.0, 0.0), (1.0, 0.0), [[2.0, 0.5, 2.0, 1.0]]) == math.inf         # passes below its end
    assert one_ray((0.0, 0.0), (1.0, 0.0), [[2.0, 0.0, 2.0, 1.0]]) == pytest.approx(2.0)   # through its end


def test_a_ray_starting_on_a_wall_hits_it_at_zero_either_way() -> None:
    wall = [[0.0, -1.0, 0.0, 1.0]]
    assert one_ray((0.0, 0.5), (1.0, 0.0), wall) == 0.0
    assert one_ray((0.0, 0.5), (-1.0, 0.0), wall) == 0.0


def test_cast_rays_is_vectorized_over_rays_and_empty_walls_give_inf() -> None:
    walls = np.array([[2.0, -5.0, 2.0, 5.0], [-5.0, 3.0, 5.0, 3.0]])     # x = 2 and y = 3
    origins = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    directions = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [SQRT_HALF, SQRT_HALF]])
    expected = [2.0, 3.0, math.inf, 2.0 * math.sqrt(2.0)]      # the 45 deg ray meets x = 2 at (2, 2) before y = 3
    np.testing.assert_allclose(cast_rays(origins, directions, walls), expected)
    assert cast_rays(origins, directions, np.empty((0, 4))).tolist() == [math.inf] * 4

# ------------------------------------------------------------------------------------------------- SonarModel


def test_reading_is_the_distance_from_the_transducer_and_follows_the_pose() -> None:
    sonar = Rangefinder("front", (0.175, 0.0), 0.0)
    walls = [[-10.0, 3.0, 10.0, 3.0]]                    # y = 3
    # At (1, 1) facing +y the transducer is at (1, 1.175): 3 - 1.175 = 1.825 to the wall.
    assert quiet([sonar], walls).ranges(1.0, 1.0, math.pi / 2.0, RNG) == {"front": pytest.approx(1.825)}


def test_beyond_max_range_reads_inf_and_closer_than_min_reads_min() -> None:
    far = quiet([boresight_sonar()], [[6.0, -5.0, 6.0, 5.0]])
    assert far.ranges(0.0, 0.0, 0.0, RNG) == {"front": math.inf}
    assert quiet([boresight_sonar()], []).ranges(0.0, 0.0, 0.0, RNG) == {"front": math.inf}
    near = quiet([boresight_sonar()], [[0.1, -5.0, 0.1, 5.0]])
    assert near.ranges(0.0, 0.0, 0.0, RNG) == {"front": 0.15}
    at_max = quiet([boresight_sonar(beam_half_angle_rad=0.0)], [[5.0, -5.0, 5.0, 5.0]])
    assert at_max.ranges(0.0, 0.0, 0.0, RNG) == {"front": pytest.approx(5.0)}


def test_the_cone_reports_the_nearest_echo_even_one_only_its_edge_sees() -> None:
    # A far wall at x = 4 across the cone, and a short wall at x = 2 between bearings 10 and 15 deg: of the five
    # rays at 0, +-6.25, +-12.5 deg only the 12.5 deg edge ray meets it, after 2 / cos(12.5 deg) = 2.0486 m.
    short = [2.0, 2.0 * math.tan(math.radians(10.0)), 2.0, 2.0 * math.tan(math.radians(15.0))]
    walls = [[4.0, -5.0, 4.0, 5.0], short]
    assert quiet([boresight_sonar()], walls).ranges(0.0, 0.0, 0.0, RNG)["front"] == pytest.approx(
        2.0 / math.cos(math.radians(12.5)))
    assert quiet([boresight_sonar()], walls, rays_per_beam=1).ranges(0.0, 0.0, 0.0, RNG)["front"] == pytest.approx(4.0)


def test_noise_sd_is_the_floor_plus_the_fraction_of_the_range() -> None:
    # A wall 1 m ahead and another 4 m behind: sd = 0.02 + 0.05 * 1 = 0.07 and 0.02 + 0.05 * 4 = 0.22.
    sonars = [boresight_sonar("ahead"), boresight_sonar("behind", 180.0)]
    walls = np.array([[1.0, -5.0, 1.0, 5.0], [-4.0, -5.0, -4.0, 5.0]])
    model = SonarModel(sonars, walls, noise_sd_m=0.02, noise_fraction=0.05, rays_per_beam=1)
    rng = np.random.default_rng(7)
    readings = [model.ranges(0.0, 0.0, 0.0, rng) for _ in range(4000)]
    ahead = np.array([r["ahead"] for r in readings])
    behind = np.array([r["behind"] for r in readings])
    assert ahead.mean() == pytest.approx(1.0, abs=0.005)
    assert ahead.std() == pytest.approx(0.07, rel=0.05)
    assert behind.mean() == pytest.approx(4.0, abs=0.02)
    assert behind.std() == pytest.approx(0.22, rel=0.05)


def test_noisy_readings_stay_within_min_and_max() -> None:
    walls = np.array([[4.9, -5.0, 4.9, 5.0], [-0.2, -5.0, -0.2, 5.0]])
    model = SonarModel([boresight_sonar("ahead"), boresight_sonar("behind", 180.0)], walls, noise_sd_m=0.5,
                       rays_per_beam=1)
    rng = np.random.default_rng(3)
    readings = np.array([list(model.ranges(0.0, 0.0, 0.0, rng).values()) for _ in range(500)])
    assert readings.min() == 0.15 and readings.max() == 5.0
    assert np.all((readings >= 0.15) & (readings <= 5.0))


def test_paper_layout_in_a_hallway_following_the_left_wall_at_0_8_m() -> None:
    # Robot centre at the origin facing +x, left wall y = 0.8, right wall y = -1.2, end wall x = 2.5.
    walls = [[-10.0, 0.8, 2.5, 0.8], [-10.0, -1.2, 2.5, -1.2], [2.5, -1.2, 2.5, 0.8]]
    readings = quiet(PAPER_LAYOUT, walls).ranges(0.0, 0.0, 0.0, RNG)
    assert list(readings) == ["front", "front_left_45", "front_right_45", "left_60", "right_60", "left", "right"]
    assert readings["left"] == pytest.approx(0.8 - 0.175)          # mounted 0.175 m left of the centre
    assert readings["right"] == pytest.approx(1.2 - 0.175)
    assert readings["front"] == pytest.approx(2.5 - 0.175)         # mounted 0.175 m ahead of the centre
    # The angled sonars' nearest echo comes along their cone's edge nearest the perpendicular to the left wall:
    # left_60 at (0.16, 0.16) along 72.5 deg, front_left_45 at (0.175, 0.10) along 57.5 deg.
    assert readings["left_60"] == pytest.approx(0.64 / math.sin(math.radians(72.5)))
    assert readings["front_left_45"] == pytest.approx(0.70 / math.sin(math.radians(57.5)))
    # With the end wall farther than 3.7 m, the front cone's 12.5 deg edge meets the left wall first, at
    # 0.8 / sin(12.5 deg) = 3.70 m: a real sonar's front reading in a long hallway is the side wall's, too.
    long_hall = [[-10.0, 0.8, 10.0, 0.8], [-10.0, -1.2, 10.0, -1.2], [6.0, -1.2, 6.0, 0.8]]
    assert quiet(PAPER_LAYOUT, long_hall).ranges(0.0, 0.0, 0.0, RNG)["front"] == pytest.approx(
        0.8 / math.sin(math.radians(12.5)))


def test_layout_has_seven_uniquely_named_sonars_within_a_35_cm_robot() -> None:
    assert len(PAPER_LAYOUT) == 7 and len({r.name for r in PAPER_LAYOUT}) == 7
    assert all(abs(v) <= 0.175 for r in PAPER_LAYOUT for v in r.position)
    assert all(r.max_range_m == 5.0 for r in PAPER_LAYOUT)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"name": "left wall"}, "name"),
    ({"beam_half_angle_rad": math.pi / 2.0}, "beam_half_angle_rad"),
    ({"min_range_m": 6.0}, "ranges"),
    ({"position": (math.nan, 0.0)}, "position"),
])
def test_bad_rangefinders_name_the_field(kwargs: dict, field: str) -> None:
    settings = {"name": "front", "position": (0.0, 0.0), "bearing_rad": 0.0} | kwargs
    with pytest.raises(ValueError, match=field):
        Rangefinder(**settings)


def test_bad_models_name_the_field() -> None:
    with pytest.raises(ValueError, match="unique"):
        SonarModel([boresight_sonar(), boresight_sonar()], np.empty((0, 4)))
    with pytest.raises(ValueError, match="^walls:"):
        SonarModel([boresight_sonar()], np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^noise_fraction:"):
        SonarModel([boresight_sonar()], np.empty((0, 4)), noise_fraction=-0.1)
    with pytest.raises(ValueError, match="^rays_per_beam:"):
        SonarModel([boresight_sonar()], np.empty((0, 4)), rays_per_beam=0)


# ------------------------------------------------------------------------------------------ specular loss

def test_a_ray_beyond_the_specular_angle_gets_no_echo_and_does_not_pass_through_to_a_farther_wall() -> None:
    walls = np.array([[2.0, -5.0, 2.0, 5.0], [4.0, -9.0, 4.0, 9.0]])
    directions = np.array([[1.0, 0.0], [SQRT_HALF, SQRT_HALF], [math.cos(math.radians(30.0)),
                                                                 math.sin(math.radians(30.0))]])
    origins = np.zeros((3, 2))
    ranges = cast_rays(origins, directions, walls, specular_angle_rad=math.radians(40.0))
    assert ranges[0] == pytest.approx(2.0)                       # normal incidence
    assert ranges[1] == math.inf                                  # 45 degrees off the normal: reflected away
    assert ranges[2] == pytest.approx(2.0 / math.cos(math.radians(30.0)))   # 30 degrees: still an echo
    assert cast_rays(origins, directions, walls)[1] == pytest.approx(2.0 * math.sqrt(2.0))   # no loss at 90


def test_a_beam_keeps_the_echo_of_its_rays_near_the_normal_and_loses_a_wall_seen_only_obliquely() -> None:
    wall_to_the_left = [[-5.0, 1.0, 5.0, 1.0]]          # a corridor wall 1 m to the left, parallel to the robot
    left_45 = boresight_sonar("left_45", 45.0)
    seen = SonarModel([left_45], np.array(wall_to_the_left), 0.0, 0.0, 5, math.radians(40.0))
    # The cone spans 32.5-57.5 degrees off the wall's normal: the 32.5-degree edge ray still echoes.
    assert seen.ranges(0.0, 0.0, 0.0, RNG)["left_45"] == pytest.approx(1.0 / math.cos(math.radians(32.5)))
    lost = SonarModel([left_45], np.array(wall_to_the_left), 0.0, 0.0, 5, math.radians(30.0))
    assert lost.ranges(0.0, 0.0, 0.0, RNG)["left_45"] == math.inf
    with pytest.raises(ValueError, match="specular_angle_rad"):
        SonarModel([left_45], np.array(wall_to_the_left), specular_angle_rad=0.0)


# ---------------------------------------------------------------------------------------------- the wall grid

@pytest.mark.parametrize("floor", ["building_large", "building_fig5", "building_eval", "building_ring"])
def test_readings_equal_those_of_the_model_before_the_grid_cast_at_every_wall(floor: str) -> None:
    # The reference is the model as it was before the wall grid and the walls worked out once (commit 249c210):
    # numpy arrays cast at every wall. Poses all over the floor and beyond it, the same noise streams; equal to
    # the last bit.
    from rfidnav_scenario.scenario import CONFIG_DIR
    from rfidnav_sim.world import load_world

    walls = load_world(CONFIG_DIR / "worlds" / f"{floor}.yaml").wall_segments()
    model = SonarModel(PAPER_LAYOUT, walls, specular_angle_rad=math.radians(40.0))
    rng = np.random.default_rng(7)
    low, high = walls[:, :2].min(axis=0) - 3.0, walls[:, :2].max(axis=0) + 3.0
    for _ in range(1000):
        x, y, yaw = rng.uniform(low[0], high[0]), rng.uniform(low[1], high[1]), rng.uniform(-math.pi, math.pi)
        seed = int(rng.integers(2**31))
        assert model.ranges(x, y, yaw, np.random.default_rng(seed)) == sonar_ranges(model, x, y, yaw,
                                                                                   np.random.default_rng(seed))
    assert max(len(cell) for cell in model.nearby.sets) < len(walls)       # the grid does leave walls out


def test_rays_cast_along_a_floors_walls_and_through_their_ends_equal_the_reference_cast() -> None:
    # Rays that run parallel to walls, start on them, pass through their joints or stop short of them: the
    # cases the casting formula treats apart, each equal to the bit to the cast of commit 249c210.
    walls = np.array([[0.0, 0.0, 4.0, 0.0], [4.0, 0.0, 4.0, 3.0], [4.0, 3.0, 0.0, 3.0], [1.0, 1.0, 2.0, 2.0]])
    origins = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 1.5], [0.5, 0.5], [3.0, 1.0], [4.0, 3.0], [-1.0, 0.0]])
    angles = np.linspace(-math.pi, math.pi, 73)
    directions = np.column_stack((np.cos(angles), np.sin(angles)))
    exact = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [SQRT_HALF, SQRT_HALF]])
    for origin in origins:
        for rays in (directions, exact):
            starts = np.repeat(origin[None, :], len(rays), axis=0)
            for specular in (math.pi / 2.0, math.radians(40.0)):
                assert cast_rays(starts, rays, walls, specular).tolist() == \
                    reference_cast(starts, rays, walls, specular).tolist()


def test_a_grid_over_no_walls_gives_no_walls_anywhere() -> None:
    model = SonarModel(PAPER_LAYOUT, np.empty((0, 4)))
    assert len(model.nearby.near(3.0, -2.0)) == 0
    assert all(math.isinf(value) for value in model.ranges(0.0, 0.0, 0.0, np.random.default_rng(1)).values())
