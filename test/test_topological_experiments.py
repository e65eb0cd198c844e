"""In-process topological navigation (paper 004): rfidnav_experiments.runners.topological."""

import math

import numpy as np
import pytest

from rfidnav_common.topological_map import load_topological_map
from rfidnav_experiments.runners.topological import (
    FIG5_MAP,
    FIG5_WORLD,
    centre_sonar,
    follower_offsets,
    paper_run,
    random_missions,
    run_mission,
    start_pose_for,
)
from rfidnav_sim.sonar_model import centre_offsets
from rfidnav_sim.world import load_world

pytestmark = pytest.mark.tier("unit")


def test_mounting_offsets_put_the_side_sonars_at_the_robot_edge():
    offsets = centre_offsets()
    assert offsets["front"] == pytest.approx(0.175)
    assert offsets["left"] == pytest.approx(0.175)
    assert offsets["right"] == pytest.approx(0.175)
    assert offsets["front_left_45"] == pytest.approx((0.175 + 0.10) / math.sqrt(2.0))
    sonar = centre_sonar({"front": math.inf, "left": 0.625, "right": 0.625, "front_left_45": 1.0,
                          "front_right_45": 1.0, "left_60": 1.0, "right_60": 1.0}, offsets)
    assert sonar.left == pytest.approx(0.8) and sonar.front == math.inf


def test_the_shipped_follower_offsets_are_the_layouts_to_a_tenth_of_a_millimetre():
    # The runner feeds its follower with the wall_follower node's offsets, so they must be the layout's.
    layout = centre_offsets()
    for name, offset in follower_offsets().items():
        assert offset == pytest.approx(layout[name], abs=1e-4), name


def test_start_pose_before_tag_23_heads_east_towards_h():
    x, y, yaw = start_pose_for(load_topological_map(FIG5_MAP), "23")
    assert (x, y) == pytest.approx((13.0, 8.0))
    assert yaw == pytest.approx(0.0, abs=1e-9)


def test_paper_run_turns_right_at_h_and_reaches_g():
    run = paper_run(np.random.default_rng(1))
    assert run.success, run.message
    assert run.turns == (("h", "right"),)
    assert run.nodes_visited == ("h", "g")
    assert run.tags_missed == 0 and run.replans == 0
    # After reading tag 19 the robot drives on to g's junction centre: measured ~0.2 m from g, ~11 m driven.
    assert abs(run.path_length_m - run.shortest_path_m) <= 0.15 * run.shortest_path_m
    assert math.dist(run.final_position, (16.0, 0.0)) <= 0.5


@pytest.mark.tier("slow")
def test_paper_run_succeeds_whatever_the_sonar_noise():
    runs = [paper_run(np.random.default_rng(seed)) for seed in range(6)]
    assert all(run.success for run in runs), [run.message for run in runs]


@pytest.mark.tier("slow")
def test_random_missions_without_misses_all_succeed_near_the_shortest_path():
    runs = random_missions(6, 0.0, seed=7)
    assert all(run.success for run in runs), [run.message for run in runs]
    ratios = [run.path_length_m / run.shortest_path_m for run in runs]
    assert all(run.tags_missed == 0 for run in runs) and all(0.9 < ratio < 1.15 for ratio in ratios), ratios
    assert np.mean(ratios) < 1.1


@pytest.mark.tier("slow")
def test_random_missions_with_30_percent_misses_all_succeed_by_the_routes_expectation():
    runs = random_missions(6, 0.3, seed=7)
    assert all(run.success for run in runs), [run.message for run in runs]
    assert sum(run.tags_missed for run in runs) >= 2             # the misses happened and were carried


def test_a_question_mark_hallway_is_explored_and_learned_on_the_way_to_its_far_end(tmp_path):
    # The robot's map does not know the hallway h - f (both ends "?"): f is reached only by exploring it.
    text = FIG5_MAP.read_text()
    for known, unknown in (("E: {node: f, tags: [24]}", 'E: {node: "?", tags: [24]}'),
                           ("W: {node: h, tags: [17]}", 'W: {node: "?", tags: [17]}')):
        assert known in text
        text = text.replace(known, unknown)
    partial = tmp_path / "fig5_without_h_f.yaml"
    partial.write_text(text)
    topological_map = load_topological_map(partial)
    run = run_mission(load_world(FIG5_WORLD), topological_map, start_pose_for(topological_map, "23"), "f",
                      np.random.default_rng(1))
    assert run.success, run.message
    assert run.nodes_visited == ("h", "f") and run.turns == (("h", "straight"),)
