"""Partition navigation (paper 000 section 5.2): the navigator core's decisions, and seeded in-process
navigations with the localizer, planner and navigator cores against ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.tag_lattice import make_deployment
from rfidnav_experiments.runners.partitions import random_task, run_navigation
from rfidnav_localization.partition import LocalizationEstimate, LocalizerSettings
from rfidnav_planning.partition_navigation import (
    FOLLOWING,
    FORWARD,
    LOCALIZING,
    REPLANNING,
    ROTATE,
    GoalRejected,
    NavigatorSettings,
    PartitionNavigator,
    TurnOnTheSpot,
    TurnSettings,
)

pytestmark = pytest.mark.tier("unit")

FIELD = (0.0, 0.0, 5.0, 5.0)


def estimate(deployment, x: float, y: float, yaw: float | None, traversed: int, changed: bool = True,
             stamp: float = 0.0) -> LocalizationEstimate:
    """What a localizer would report at (x, y): the true partition, its centre, the given heading."""
    partition = deployment.partition_at(x, y)
    centre = tuple(deployment.lattice.positions(np.array(sorted(partition))).mean(axis=0)) if partition else None
    return LocalizationEstimate(
        stamp_s=stamp, method="paper", partition=partition,
        partition_tag_ids=tuple(sorted(deployment.lattice.tag_id(c) for c in partition)), partition_changed=changed,
        partitions_traversed=traversed, position=centre, position_covariance=(0.0, 0.0, 0.0), yaw=yaw,
        yaw_bounds=None if yaw is None else (yaw - 0.1, yaw + 0.1), yaw_std=None if yaw is None else 0.05,
        read_range_m=deployment.read_range_m, lattice=deployment.lattice, rejected_tag_ids=(), rogue_count=0,
        undecodable_count=0)


@pytest.fixture
def field():
    return make_deployment("triangular", 0.2, FIELD)


@pytest.mark.parametrize("goal", [(5.5, 1.0), (1.0, -0.01), (math.nan, 1.0)])
def test_a_goal_off_the_deployment_is_rejected_with_the_reason(goal) -> None:
    navigator = PartitionNavigator(NavigatorSettings(), FIELD)
    with pytest.raises(GoalRejected, match="outside the deployment|not a finite"):
        navigator.start(goal)


def test_localizing_then_turning_towards_the_goal(field) -> None:
    navigator = PartitionNavigator(NavigatorSettings(approximation_level=3), FIELD)
    assert navigator.start((4.0, 4.0)).motion.kind == FORWARD
    for traversed in range(3):
        decision = navigator.on_estimate(estimate(field, 1.0, 1.0, 0.0 if traversed else None, traversed), 0.1)
        assert decision.phase == LOCALIZING and decision.motion.kind == FORWARD
    decision = navigator.on_estimate(estimate(field, 1.0, 1.0, 0.0, 3), 0.3)
    assert decision.motion.kind == ROTATE and decision.new_plan is not None
    centre = navigator.state.plan.start
    assert decision.motion.rotate_by_rad == pytest.approx(math.atan2(4.0 - centre[1], 4.0 - centre[0]))
    assert navigator.rotation_done().phase == FOLLOWING


def test_an_unexpected_partition_replans_and_the_goal_partition_ends_it(field) -> None:
    navigator = PartitionNavigator(NavigatorSettings(approximation_level=1), FIELD)
    navigator.start((4.0, 1.0))
    navigator.on_estimate(estimate(field, 1.0, 1.0, 0.0, 1), 0.0)
    navigator.rotation_done()
    plan = navigator.state.plan
    on_plan = plan.partitions[len(plan.partitions) // 2]
    x, y = field.lattice.positions(np.array(sorted(on_plan))).mean(axis=0)
    assert navigator.on_estimate(estimate(field, x, y, 0.0, 2), 1.0).motion.kind == FORWARD
    # Far from the planned segment (y = 1): a deviation.
    decision = navigator.on_estimate(estimate(field, 2.5, 2.5, 0.3, 3), 2.0)
    assert decision.phase == REPLANNING and decision.motion.kind == ROTATE
    assert navigator.state.replans == 1
    navigator.rotation_done()
    decision = navigator.on_estimate(estimate(field, 4.0, 1.0, 0.0, 1), 3.0)
    assert decision.finished and decision.success and "goal's partition" in decision.message


def test_driving_off_the_tagged_floor_while_localizing_turns_back(field) -> None:
    navigator = PartitionNavigator(NavigatorSettings(approximation_level=4), FIELD)
    navigator.start((2.5, 2.5))
    navigator.on_estimate(estimate(field, 4.9, 2.5, None, 0), 0.0)
    empty = estimate(field, 6.0, 2.5, None, 0, changed=False)
    decision = navigator.on_estimate(LocalizationEstimate(**{**empty.__dict__, "position": (4.9, 2.5)}), 0.3)
    assert decision.motion.kind == ROTATE and decision.motion.rotate_by_rad == pytest.approx(math.pi)
    assert navigator.rotation_done().phase == LOCALIZING
    # A long stretch without tags is given up on, with a message that says so.
    decision = navigator.on_estimate(LocalizationEstimate(**{**empty.__dict__, "position": (4.9, 2.5)}), 1.5)
    assert decision.finished and not decision.success and "lost" in decision.message


@pytest.mark.tier("slow")
@pytest.mark.parametrize("method", ["paper", "filter"])
@pytest.mark.parametrize("r", [0.02, 0.2, 0.5])
def test_navigations_end_in_the_goal_partition(method: str, r: float) -> None:
    field = make_deployment("triangular", r, FIELD)
    costs = []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        start, goal = random_task(field, 1.0 + seed % 3, rng)
        run = run_navigation(field, start, goal, LocalizerSettings(method=method),
                             NavigatorSettings(approximation_level=4), rng)
        assert run.success, run.message
        # Ground truth: it stopped where the goal's tags are read, and it drove at least close to |SD|.
        assert field.partition_at(*run.final_position) == field.partition_at(*goal)
        assert run.final_error_m <= 2.0 * r
        assert run.path_length_m >= run.straight_distance_m - 2.0 * r
        costs.append(run.extra_cost_pct)
    if r == 0.02:
        # Paper 000 Fig. 12: at r = 2 cm the extra cost stays within a few percent.
        assert np.mean(costs) < 8.0


def test_runs_repeat_exactly_for_a_seed() -> None:
    field = make_deployment("triangular", 0.2, FIELD)
    runs = []
    for _ in range(2):
        rng = np.random.default_rng(42)
        start, goal = random_task(field, 3.0, rng)
        runs.append(run_navigation(field, start, goal, LocalizerSettings(method="filter"), NavigatorSettings(), rng))
    assert runs[0].path_length_m == runs[1].path_length_m and runs[0].replans == runs[1].replans


def test_a_grid_deployment_ends_the_goal_with_the_planners_reason() -> None:
    """Algorithm 1 needs a triangular lattice: on a grid the goal fails with that message, nothing raises."""
    grid = make_deployment("grid", 0.2, FIELD)
    navigator = PartitionNavigator(NavigatorSettings(approximation_level=1), FIELD)
    navigator.start((4.0, 4.0))
    decision = navigator.on_estimate(estimate(grid, 1.0, 1.0, 0.0, 1), 0.2)
    assert decision.finished and not decision.success
    assert "cannot plan" in decision.message and "triangular" in decision.message


@pytest.mark.tier("slow")
def test_a_floor_too_small_for_the_localization_phase_ends_the_goal() -> None:
    """At r = 50 cm a 5 x 5 m floor may never give 8 partitions in one straight line: each edge turns the robot
    back and restarts its stretch. The goal then fails with that reason instead of running for ever."""
    field = make_deployment("triangular", 0.5, FIELD)
    outcomes = []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        start, goal = random_task(field, 3.0, rng)
        run = run_navigation(field, start, goal, LocalizerSettings(), NavigatorSettings(approximation_level=8), rng)
        outcomes.append(run)
        assert run.success or "could not localize" in run.message or "gave up" in run.message, run.message
        assert run.path_length_m < 10.0 + 5.0 * 2 * 5.0 * 1.5
    assert any(not run.success and "could not localize" in run.message for run in outcomes)


TURN = TurnSettings(max_rate_radps=0.8, gain_per_s=3.0, tolerance_rad=0.005)


def test_a_turn_on_the_spot_is_capped_then_proportional_and_done_within_the_tolerance() -> None:
    turn = TurnOnTheSpot(TURN)
    turn.start(math.pi / 2.0, 0.0)
    assert turn.yaw_rate(0.0) == pytest.approx(0.8)                  # far from the target: the cap
    assert turn.yaw_rate(math.pi / 2.0 - 0.1) == pytest.approx(0.3)  # near it: 3 /s x 0.1 rad
    assert turn.turning
    assert turn.yaw_rate(math.pi / 2.0 - 0.004) is None               # within 5 mrad: done
    assert not turn.turning


def test_a_turn_across_the_heading_wrap_takes_the_short_way() -> None:
    turn = TurnOnTheSpot(TURN)
    turn.start(-0.2, -math.pi + 0.1)                                 # clockwise past -pi
    assert turn.target_yaw == pytest.approx(math.pi - 0.1)
    assert turn.yaw_rate(-math.pi + 0.05) == pytest.approx(-0.45)    # 0.15 rad to go, clockwise


def test_a_turn_asked_for_before_any_heading_starts_from_the_first_one() -> None:
    turn = TurnOnTheSpot(TURN)
    turn.start(-1.0, None)
    assert turn.turning and turn.target_yaw is None
    assert turn.yaw_rate(2.0) == pytest.approx(-0.8)
    assert turn.target_yaw == pytest.approx(1.0)
