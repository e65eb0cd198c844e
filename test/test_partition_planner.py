"""Algorithm 1 of paper 000 (the partition path planner) against the exact geometry of the tag discs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.tag_lattice import (
    Deployment,
    make_deployment,
    partition_centre,
    partitions_along_segment,
)
from rfidnav_experiments.bench.planner import planning_benchmark
from rfidnav_planning.errors import PlanningError
from rfidnav_planning.partition_planner import PartitionPlan, plan_partition_path

pytestmark = pytest.mark.tier("unit")

# A 5 x 5 m field straddling the origin, so negative lattice coordinates are exercised too.
FIELD = (-1.0, -2.0, 4.0, 3.0)
SEGMENTS_PER_CASE = 500


def random_segments(count: int, seed: int, area: tuple[float, float, float, float] = FIELD):
    rng = np.random.default_rng(seed)
    low, high = (area[0], area[1]), (area[2], area[3])
    for start, goal in zip(rng.uniform(low, high, size=(count, 2)), rng.uniform(low, high, size=(count, 2))):
        yield (float(start[0]), float(start[1])), (float(goal[0]), float(goal[1]))


def geometric_walk(deployment: Deployment, start, goal) -> tuple[frozenset, ...]:
    return tuple(piece.tags for piece in partitions_along_segment(deployment, start, goal))


def sampled_read_sets(deployment: Deployment, start, goal) -> list[frozenset]:
    """Read sets along the segment, independently of both planners: the read set (Deployment.partition_at)
    at the middle of every stretch between consecutive disc-boundary crossings, found by projection."""
    a, b = np.array(start), np.array(goal)
    direction = b - a
    length_sq = float(direction @ direction)
    r = deployment.read_range_m
    centres = deployment.lattice.positions(deployment.candidates_near_segment(start, goal, r))
    foot = ((centres - a) @ direction) / length_sq
    offset_sq = np.sum((a + foot[:, None] * direction - centres) ** 2, axis=1)
    half = np.sqrt(np.maximum(r * r - offset_sq, 0.0) / length_sq)
    crossings = np.concatenate(([0.0, 1.0], foot - half, foot + half))
    breaks = np.unique(crossings[(crossings >= 0.0) & (crossings <= 1.0)])
    read_sets: list[frozenset] = []
    for t in (breaks[:-1] + breaks[1:]) / 2.0:
        tags = deployment.partition_at(*(a + t * direction))
        if not read_sets or read_sets[-1] != tags:
            read_sets.append(tags)
    return read_sets


@pytest.mark.tier("slow")
@pytest.mark.parametrize("layout", ["triangular", "compressed"])
@pytest.mark.parametrize("read_range_m", [0.02, 0.2, 0.5])
def test_algorithm_1_equals_the_geometric_walk(layout: str, read_range_m: float) -> None:
    deployment = make_deployment(layout, read_range_m, FIELD)
    mismatches = [(start, goal) for start, goal in random_segments(SEGMENTS_PER_CASE, seed=7)
                  if plan_partition_path(deployment, start, goal).partitions != geometric_walk(deployment, start, goal)]
    assert mismatches == []


@pytest.mark.parametrize("layout", ["triangular", "compressed"])
def test_plan_is_the_sequence_of_read_sets_along_the_segment(layout: str) -> None:
    deployment = make_deployment(layout, 0.2, FIELD)
    for start, goal in random_segments(40, seed=11):
        partitions = plan_partition_path(deployment, start, goal).partitions
        assert list(partitions) == sampled_read_sets(deployment, start, goal)


@pytest.mark.parametrize("layout", ["triangular", "compressed"])
def test_every_partition_is_read_somewhere_on_the_segment(layout: str) -> None:
    deployment = make_deployment(layout, 0.5, FIELD)
    for start, goal in random_segments(40, seed=12):
        read_sets = set(sampled_read_sets(deployment, start, goal))
        partitions = plan_partition_path(deployment, start, goal).partitions
        assert all(partition in read_sets for partition in partitions)


@pytest.mark.parametrize("layout", ["triangular", "compressed"])
def test_consecutive_partitions_differ_and_none_is_empty(layout: str) -> None:
    deployment = make_deployment(layout, 0.2, FIELD)
    for start, goal in random_segments(100, seed=3):
        partitions = plan_partition_path(deployment, start, goal).partitions
        assert all(before != after for before, after in zip(partitions, partitions[1:]))
        assert all(partitions)


@pytest.mark.parametrize("layout", ["triangular", "compressed"])
@pytest.mark.parametrize("goal_tag", [(-1, 2), (0, 2), (1, 2)])   # straight up, along a lattice line, slanted
def test_fig_9_start_and_goal_on_tags_two_rows_apart(layout: str, goal_tag: tuple[int, int]) -> None:
    deployment = make_deployment(layout, 0.2, FIELD)
    start_tag = (0, 0)
    start, goal = deployment.lattice.position(start_tag), deployment.lattice.position(goal_tag)
    partitions = plan_partition_path(deployment, start, goal).partitions
    # Neighbours are farther than r, so on a tag only that tag reads.
    assert partitions[0] == frozenset({start_tag})
    assert partitions[-1] == frozenset({goal_tag})
    assert len(partitions) > 2
    assert partitions == geometric_walk(deployment, start, goal)


def test_start_equal_to_goal_gives_the_partition_there() -> None:
    deployment = make_deployment("triangular", 0.2, FIELD)
    plan = plan_partition_path(deployment, (1.23, 0.45), (1.23, 0.45))
    assert plan.partitions == (deployment.partition_at(1.23, 0.45),)
    assert len(plan.partitions[0]) >= 1


def test_segment_within_one_triangle() -> None:
    deployment = make_deployment("triangular", 0.5, FIELD)
    start, goal = (0.30, 0.20), (0.31, 0.25)
    assert plan_partition_path(deployment, start, goal).partitions == geometric_walk(deployment, start, goal)


def test_long_diagonal_of_a_large_field() -> None:
    deployment = make_deployment("triangular", 0.02, (0.0, 0.0, 30.0, 30.0))
    start, goal = (0.01, 0.013), (29.99, 29.98)
    partitions = plan_partition_path(deployment, start, goal).partitions
    assert len(partitions) > 2000
    assert partitions[0] == deployment.partition_at(*start)
    assert partitions[-1] == deployment.partition_at(*goal)
    assert partitions == geometric_walk(deployment, start, goal)


def test_index_of_and_centres() -> None:
    deployment = make_deployment("compressed", 0.2, FIELD)
    plan = plan_partition_path(deployment, (-0.7, -1.5), (3.6, 2.2))
    for position, partition in enumerate(plan.partitions):
        first = plan.index_of(partition)
        assert first == plan.partitions.index(partition)
        assert first <= position
    assert plan.index_of(frozenset({(10_000, 10_000)})) is None
    centres = plan.centres(deployment.lattice)
    assert len(centres) == len(plan.partitions)
    assert centres[5] == partition_centre(deployment.lattice, plan.partitions[5])
    # Partition centres lie within r of the segment's line (each partition is read on the segment).
    (ax, ay), (bx, by) = plan.start, plan.goal
    for cx, cy in centres:
        assert abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax)) / math.hypot(bx - ax, by - ay) < 0.2


def test_grid_deployment_is_refused() -> None:
    deployment = make_deployment("grid", 0.2, FIELD)
    with pytest.raises(PlanningError, match="triangular lattice.*'grid'"):
        plan_partition_path(deployment, (0.0, 0.0), (1.0, 1.0))


@pytest.mark.parametrize("start, goal, named", [((-1.5, 0.0), (1.0, 1.0), "start"),
                                                ((0.0, 0.0), (1.0, 3.01), "goal"),
                                                ((0.0, math.nan), (1.0, 1.0), "start")])
def test_start_or_goal_outside_the_area_is_refused(start, goal, named: str) -> None:
    deployment = make_deployment("triangular", 0.2, FIELD)
    with pytest.raises(PlanningError, match=rf"^{named} .* outside the deployment area"):
        plan_partition_path(deployment, start, goal)


def test_plan_is_frozen_and_compares_by_value() -> None:
    deployment = make_deployment("triangular", 0.2, FIELD)
    plan = plan_partition_path(deployment, (0.0, 0.0), (2.0, 1.0))
    assert plan == PartitionPlan(plan.start, plan.goal, plan.partitions)
    with pytest.raises(AttributeError):
        plan.partitions = ()   # type: ignore[misc]


def test_benchmark_reports_figures_with_units() -> None:
    figures = planning_benchmark(plans=3, seed=2)
    assert set(figures) == {"field_m", "read_range_m", "tags", "plans", "mean_ms", "p50_ms", "p99_ms",
                            "max_ms", "mean_partitions"}
    assert figures["plans"] == 3 and figures["field_m"] == 30.0 and figures["read_range_m"] == 0.02
    assert 860_000 < figures["tags"] < 880_000
    assert 0.0 < figures["p50_ms"] <= figures["max_ms"] and figures["mean_ms"] <= figures["max_ms"]
    assert figures["mean_partitions"] > 100
