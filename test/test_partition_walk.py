"""Issue 19's faster partition navigations: the tags near a straight drive are found once (StraightWalk), a step
that passes no read circle is one round, and the particle filter's round works in place; yet every navigation is
the one the step-by-step walk and the filter before made (kept as the reference in support.partition_walk), to the
last bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.seeding import rng_for
from rfidnav_common.tag_lattice import LAYOUTS, StraightWalk, make_deployment, partitions_along_segment
from rfidnav_experiments.reproduce.partitions import settings
from rfidnav_experiments.reproduce.partitions.jobs import NavigationJob, navigate, task_of
from rfidnav_localization.partition import ParticleFilter
from support import partition_walk

pytestmark = pytest.mark.tier("unit")

FIELD = (0.0, 0.0, 5.0, 5.0)


def walks(r: float, seed: int):
    """Seeded straight walks over the field and its edges, some along the lattice's rows and through its tags."""
    rng = np.random.default_rng(seed)
    deployment = make_deployment("triangular", r, FIELD)
    for index in range(12):
        origin = tuple(rng.uniform(-0.2, 5.2, 2))
        heading = rng.uniform(-math.pi, math.pi)
        if index % 4 == 0:     # on a row of tags, along it: tangencies and vertices at every step
            origin, heading = deployment.lattice.position((int(rng.integers(0, 20)), int(rng.integers(0, 20)))), 0.0
        yield deployment, origin, heading


@pytest.mark.parametrize("r", [0.02, 0.2, 0.5])
def test_each_step_of_a_straight_walk_gets_the_pieces_of_its_own_segment(r: float) -> None:
    spacing = min(r / 2.0, 0.02)
    quiet = 0
    for deployment, origin, heading in walks(r, 5):
        walk = StraightWalk(deployment, origin, heading, spacing, 40)
        point = origin
        for step in range(40):
            end = (point[0] + spacing * math.cos(heading), point[1] + spacing * math.sin(heading))
            pieces = partitions_along_segment(deployment, point, end)
            assert walk.pieces(point, end) == pieces
            if walk.quiet(step):
                quiet += 1
                assert len(pieces) == 1
                assert deployment.partition_at(*point) == deployment.partition_at(*end)
            point = end
    assert quiet > 0


@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_walk_with_no_tag_nearby_is_quiet_and_reads_nothing(layout: str) -> None:
    deployment = make_deployment(layout, 0.2, FIELD)
    walk = StraightWalk(deployment, (7.0, 7.0), 1.0, 0.02, 16)
    assert all(walk.quiet(step) for step in range(16))
    assert walk.pieces((7.0, 7.0), (7.01, 7.0)) == [partitions_along_segment(deployment, (7.0, 7.0), (7.01, 7.0))[0]]


def outcome(run) -> tuple:
    return (run.success, run.message, run.replans, run.partitions_entered, run.path_length_m, run.turned_rad,
            run.final_position, run.trajectory.tolist())


@pytest.mark.parametrize("method", settings.METHODS)
def test_the_faster_cores_navigate_exactly_as_the_step_by_step_walk_and_the_filter_before(method: str,
                                                                                         monkeypatch) -> None:
    jobs = [NavigationJob(method, r, level, index, settings.DEVELOPMENT_SEED)
            for r in settings.NAVIGATION_RANGES_M for level in (1, 4) for index in (0, 3)]
    for job in jobs:
        new = outcome(navigate(job))
        start, goal = task_of(job)
        with monkeypatch.context() as patched:   # the filter's old round arithmetic
            for name, function in partition_walk.FILTER_ROUND.items():
                patched.setattr(ParticleFilter, name, function)
            reference = partition_walk.run_navigation(
                settings.deployment(job.read_range_m), start, goal, settings.localizer_settings(method),
                settings.navigator_settings(method, job.level),
                rng_for(job.seed, f"run:{job.method}:{job.read_range_m}:{job.level}:{job.index}"),
                odometry_noise=settings.ODOMETRY_NOISE, speeds=settings.robot_speeds(method))
        assert new == outcome(reference), job
