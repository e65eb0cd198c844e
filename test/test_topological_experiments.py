"""In-process topological navigation (paper 004): rfidnav_bringup.topological_experiments."""

import math

import numpy as np
import pytest

from rfidnav_bringup.topological_experiments import (FIG5_MAP, centre_sonar, mounting_offsets, paper_run,
                                                     random_missions, start_pose_for)
from rfidnav_planning.topological_map import load_topological_map


def test_mounting_offsets_put_the_side_sonars_at_the_robot_edge():
    offsets = mounting_offsets()
    assert offsets["front"] == pytest.approx(0.175)
    assert offsets["left"] == pytest.approx(0.175)
    assert offsets["right"] == pytest.approx(0.175)
    assert offsets["front_left_45"] == pytest.approx((0.175 + 0.10) / math.sqrt(2.0))
    sonar = centre_sonar({"front": math.inf, "left": 0.625, "right": 0.625, "front_left_45": 1.0,
                          "front_right_45": 1.0, "left_60": 1.0, "right_60": 1.0}, offsets)
    assert sonar.left == pytest.approx(0.8) and sonar.front == math.inf


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


def test_paper_run_succeeds_whatever_the_sonar_noise():
    runs = [paper_run(np.random.default_rng(seed)) for seed in range(6)]
    assert all(run.success for run in runs), [run.message for run in runs]


def test_random_missions_without_misses_succeed_four_times_in_five():
    # Measured 4/5: mission 3 (tag 150 at E4 -> A2) misses no tag but finds no left opening at A3 (open issue).
    runs = random_missions(5, 0.0, seed=7)
    assert sum(run.success for run in runs) >= 4, [run.message for run in runs]


def test_random_missions_with_20_percent_misses_succeed_four_times_in_five():
    runs = random_missions(5, 0.2, seed=7)
    assert sum(run.success for run in runs) >= 4, [run.message for run in runs]
