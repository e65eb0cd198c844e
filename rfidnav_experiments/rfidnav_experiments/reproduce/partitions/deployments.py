"""reproduce partitions: what the tag deployment alone gives, without a navigation: the orientation after k
partitions crossed on a straight line (Fig. 11), the tags each layout needs (Figs. 15, 18) and its location and
orientation error (Figs. 16, 17, 19, 20)."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.seeding import rng_for
from rfidnav_common.tag_lattice import LAYOUTS, Deployment, make_deployment, partitions_along_segment
from rfidnav_experiments.reproduce.partitions.settings import (
    ACCURACY_RANGES_M,
    COUNT_AREAS_M,
    COUNT_RANGE_M,
    DEVELOPMENT_SEED,
    FIG11_PARTITIONS,
    FIG11_RANGE_M,
    FILTER,
    deployment,
    localizer_settings,
    robot_speeds,
)
from rfidnav_experiments.reproduce.tables import Interval
from rfidnav_localization.partition import PartitionLocalizer, orientation_bounds


@dataclass(frozen=True)
class OrientationErrors:
    paper_deg: dict[int, Interval]      # |error| after k partitions traversed
    filter_deg: dict[int, Interval]     # over the lines where the filter had a heading by then
    lines: int


def straight_traversal(field: Deployment, rng: np.random.Generator, partitions: int):
    """A random straight line from a random point long enough to cross ``partitions`` boundaries."""
    r = field.read_range_m
    while True:
        x, y = rng.uniform(1.0, 4.0, 2)
        heading = rng.uniform(-math.pi, math.pi)
        length = (partitions + 4) * r
        end = (x + length * math.cos(heading), y + length * math.sin(heading))
        pieces = partitions_along_segment(field, (x, y), end)
        if len(pieces) > partitions and all(p.tags for p in pieces):
            return (x, y), heading, length, pieces


def fig11_orientation(runs: int, seed: int = DEVELOPMENT_SEED) -> OrientationErrors:
    field = deployment(FIG11_RANGE_M)
    lattice = field.lattice
    most = max(FIG11_PARTITIONS)
    paper: dict[int, list[float]] = {k: [] for k in FIG11_PARTITIONS}
    filtered: dict[int, list[float]] = {k: [] for k in FIG11_PARTITIONS}
    speed = robot_speeds(FILTER).speed_mps
    for index in range(runs):
        rng = rng_for(seed, f"fig11:{index}")
        start, heading, length, pieces = straight_traversal(field, rng, most)
        partitions = [p.tags for p in pieces]
        for k in FIG11_PARTITIONS:
            bounds = orientation_bounds(lattice, field.read_range_m, partitions[:k + 1])
            paper[k].append(abs(math.degrees(wrap_angle(0.5 * (bounds[0] + bounds[1]) - heading))))
        # The filter on the paper's robot is fed the same traversal: a round on entering each partition and one in
        # its middle.
        localizer = PartitionLocalizer(localizer_settings(FILTER), rng)
        for k, piece in enumerate(pieces[:most + 1]):
            for t in (piece.t_start + 1e-9, 0.5 * (piece.t_start + piece.t_end)):
                distance = t * length
                odom = (distance, 0.0, 0.0)
                x, y = start[0] + distance * math.cos(heading), start[1] + distance * math.sin(heading)
                estimate = localizer.update(distance / speed, [lattice.tag_id(c) for c in field.partition_at(x, y)],
                                            odom)
            if k in filtered and estimate.yaw is not None:
                filtered[k].append(abs(math.degrees(wrap_angle(estimate.yaw - heading))))
    return OrientationErrors({k: Interval.of(v) for k, v in paper.items()},
                             {k: Interval.of(v) for k, v in filtered.items() if v}, runs)


def tag_counts() -> dict[int, dict[str, int]]:
    return {side: {layout: make_deployment(layout, COUNT_RANGE_M, (0.0, 0.0, side, side)).tag_count()
                   for layout in LAYOUTS} for side in COUNT_AREAS_M}


def saved_pct(counts: dict[int, dict[str, int]], layout: str) -> float:
    """Mean over the areas of the percentage of tags saved against the grid (negative: more tags)."""
    return statistics.fmean(100.0 * (1.0 - c[layout] / c["grid"]) for c in counts.values())


@dataclass(frozen=True)
class Accuracy:
    location_m: Interval        # distance from a random point to its partition's centre
    location_rel: Interval      # the same in units of r
    orientation_deg: Interval   # |heading error| after moving into the next partition


def deployment_accuracy(layout: str, r: float, samples: int, seed: int = DEVELOPMENT_SEED) -> Accuracy:
    """Paper 000 section 6.4.2, for one deployment and read range."""
    field = deployment(r, layout)
    rng = rng_for(seed, f"accuracy:{layout}:{r}")
    location = []
    for x, y in rng.uniform(1.0, 4.0, (samples, 2)):
        tags = field.partition_at(x, y)
        centre = field.lattice.positions(np.array(sorted(tags))).mean(axis=0)
        location.append(math.hypot(centre[0] - x, centre[1] - y))
    orientation = []
    for _ in range(samples):
        _, heading, _, pieces = straight_traversal(field, rng, 1)
        bounds = orientation_bounds(field.lattice, r, [pieces[0].tags, pieces[1].tags])
        orientation.append(abs(math.degrees(wrap_angle(0.5 * (bounds[0] + bounds[1]) - heading))))
    return Accuracy(Interval.of(location), Interval.of([d / r for d in location]), Interval.of(orientation))


def accuracy_table_data(samples: int, seed: int = DEVELOPMENT_SEED) -> dict[tuple[str, float], Accuracy]:
    return {(layout, r): deployment_accuracy(layout, r, samples, seed) for layout in LAYOUTS
            for r in ACCURACY_RANGES_M}
