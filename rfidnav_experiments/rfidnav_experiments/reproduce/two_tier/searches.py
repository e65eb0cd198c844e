"""reproduce two_tier: Fig. 10's spiral searches (its placements, the main figure's and its sensitivity's, as
engine tasks) and Theorem 1's simulated searches."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from rfidnav_common.polling import PollClock
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_common.tag_groups import TagGroup
from rfidnav_control.spiral import SearchPolls, expected_search_length, simulate_search
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.two_tier.conditions import (
    CENTRE,
    FIG10_BEYOND_M,
    FIG10_DISTANCES_M,
    FIG10_SIZE_M,
    LATENCY,
    METHODS,
    OURS,
    PERIOD,
    SENSITIVITY_VARIANTS,
    THEOREM_SIGMAS_M,
    Variant,
    floor_range_m,
    latency_polling,
    spiral_methods,
)
from rfidnav_experiments.runners.two_tier import FLOOR_READER


@dataclass(frozen=True)
class Placement:
    """One random placement of Fig. 10: where the group lies, how it is turned, where the spiral leaves; and the
    seed of the reader's polls. A function of (seed, distance, index) alone, so both methods search the same."""
    distance_m: float
    index: int
    bearing_rad: float
    rotation_rad: float
    heading_rad: float
    reader_seed: int

    def group(self, distance_to: str = CENTRE) -> TagGroup:
        """The group, its centre or (``NEAREST``) its nearest tag ``distance_m`` from the start, along the same
        bearing and turned alike."""
        along = self.distance_m if distance_to == CENTRE else \
            centre_for_nearest_tag(self.distance_m, self.bearing_rad, self.rotation_rad)
        centre = (along * math.cos(self.bearing_rad), along * math.sin(self.bearing_rad))
        return TagGroup("G", "cross", centre, FIG10_SIZE_M, self.rotation_rad)


def centre_for_nearest_tag(distance_m: float, bearing_rad: float, rotation_rad: float) -> float:
    """How far along ``bearing_rad`` the centre of the Fig. 10 cross (turned by ``rotation_rad``) lies when its
    nearest tag is ``distance_m`` from the start (bisection; the cross has a tag at its centre, so 0 at 0)."""
    offsets = TagGroup("G", "cross", (0.0, 0.0), FIG10_SIZE_M, rotation_rad).tag_positions()
    direction = np.array([math.cos(bearing_rad), math.sin(bearing_rad)])

    def nearest(along: float) -> float:
        return float(np.min(np.linalg.norm(offsets + along * direction, axis=1)))

    low, high = 0.0, distance_m + FIG10_SIZE_M            # nearest(low) <= distance_m < nearest(high)
    if nearest(low) >= distance_m:
        return 0.0
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if nearest(middle) < distance_m else (low, middle)
    return 0.5 * (low + high)


def fig10_placement(seed: int, distance_m: float, index: int) -> Placement:
    stream = f"fig10:{distance_m:g}:{index}"
    bearing, rotation, heading = rng_for(seed, stream).uniform(-math.pi, math.pi, 3)
    return Placement(distance_m, index, float(bearing), float(rotation), float(heading),
                     derive_seed(seed, f"{stream}:reader"))


@dataclass(frozen=True)
class Search:
    method: str
    placement: Placement
    length_m: float | None                # None: no poll read a tag before the spiral passed the group
    distance_to: str = CENTRE             # a key of DISTANCES_TO: what the placement's distance is measured to
    delay: str = PERIOD                   # a key of DELAYS: the reader's 500-600 ms as its period or its latency


def spiral_search(method: str, placement: Placement, distance_to: str = CENTRE, delay: str = PERIOD) -> Search:
    """One search of Fig. 10 with the floor reader's polls and failures: read where the poll's reply comes
    (``PERIOD``), or polled at the base rate and told of a read 500-600 ms after its poll (``LATENCY``: the length
    driven until the robot knows)."""
    spiral = spiral_methods()[method]
    group = placement.group(distance_to)
    polling = FLOOR_READER.polling() if delay == PERIOD else latency_polling()
    polls = SearchPolls(spiral.speed_mps, PollClock(polling, rng_for(placement.reader_seed, "polls")))
    reach = placement.distance_m if distance_to == CENTRE else math.hypot(*group.centre)
    length = simulate_search(group.tag_positions(), (0.0, 0.0), placement.heading_rad, spiral.d_m,
                             floor_range_m(), reach + FIG10_BEYOND_M, polls=polls)
    if length is not None and delay == LATENCY:
        reader = FLOOR_READER.polling()
        late_s = float(rng_for(placement.reader_seed, "latency").uniform(reader.interval_s, reader.max_interval_s))
        length += spiral.speed_mps * late_s
    return Search(method, placement, length, distance_to, delay)


def fig10_search(job: tuple[str, Placement]) -> Search:
    """One search of Fig. 10 (a task of the engine): the distance to the group's centre, read at each poll's
    reply."""
    method, placement = job
    return spiral_search(method, placement)


def sensitivity_search(job: tuple[str, Placement, str, str]) -> Search:
    """One search of Fig. 10's sensitivity (a task of the engine): (method, placement, distance_to, delay)."""
    return spiral_search(*job)


def fig10(runs: int, seed: int) -> dict[str, dict[float, list[Search]]]:
    """Every search, by method and distance, sorted by placement index."""
    placements = [fig10_placement(seed, distance, index) for distance in FIG10_DISTANCES_M for index in range(runs)]
    searches = run_tasks(fig10_search, [(method, placement) for placement in placements for method in METHODS],
                        "reproduce two_tier: Fig. 10")
    by_method: dict[str, dict[float, list[Search]]] = {method: {d: [] for d in FIG10_DISTANCES_M} for method in METHODS}
    for search in sorted(searches, key=lambda s: s.placement.index):
        by_method[search.method][search.placement.distance_m].append(search)
    return by_method


def fig10_sensitivity(runs: int, seed: int) -> dict[Variant, dict[str, dict[float, list[Search]]]]:
    """Every search of the sensitivity's variants (not the main figure's), on Fig. 10's placements: by variant,
    method and distance, sorted by placement index."""
    placements = [fig10_placement(seed, distance, index) for distance in FIG10_DISTANCES_M for index in range(runs)]
    jobs = [(method, placement, *variant) for variant in SENSITIVITY_VARIANTS for placement in placements
            for method in METHODS]
    searches = run_tasks(sensitivity_search, jobs, "reproduce two_tier: Fig. 10 sensitivity")
    out: dict[Variant, dict[str, dict[float, list[Search]]]] = {
        variant: {method: {d: [] for d in FIG10_DISTANCES_M} for method in METHODS} for variant in SENSITIVITY_VARIANTS}
    for search in sorted(searches, key=lambda s: s.placement.index):
        out[(search.distance_to, search.delay)][search.method][search.placement.distance_m].append(search)
    return out


def theorem1(runs: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(sigma, Theorem 1 as printed, Rayleigh form, simulated) [m] for our spiral around a cross group, read
    continuously as the theorem assumes."""
    rng = rng_for(seed, "theorem1")
    d = spiral_methods()[OURS].d_m
    rows = []
    for sigma in THEOREM_SIGMAS_M:
        lengths = []
        for _ in range(runs):
            offset = rng.normal(0.0, sigma, 2)
            group = TagGroup("G", "cross", (float(offset[0]), float(offset[1])), FIG10_SIZE_M,
                             float(rng.uniform(-math.pi, math.pi)))
            length = simulate_search(group.tag_positions(), (0.0, 0.0), float(rng.uniform(-math.pi, math.pi)), d,
                                     floor_range_m(), 10.0 * sigma)
            lengths.append(math.inf if length is None else length)
        rows.append((sigma, expected_search_length(sigma, d, as_printed=True),
                     expected_search_length(sigma, d, as_printed=False), statistics.fmean(lengths)))
    return rows
