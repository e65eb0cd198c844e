"""reproduce topological: a (floor, method, miss rate)'s missions summed up, the paired differences, and the one
cause of each failed mission."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from rfidnav_experiments.reproduce.tables import Interval, paired_interval
from rfidnav_experiments.reproduce.topological.conditions import (
    PATH_TARGET,
    POOLED,
    RADII_M,
    TARGET_RATE,
    TARGET_SUCCESS_PCT,
)
from rfidnav_experiments.runners.topological import METHODS, MissionRun
from rfidnav_scenario.metrics import GOAL_RADIUS_M


@dataclass(frozen=True)
class RateSummary:
    floor: str                          # a floor, or POOLED
    method: str
    miss_rate: float
    success: Interval                   # percent, Wilson
    path_ratio: Interval                # path / shortest over the successful missions
    duration_s: Interval                # over the successful missions
    mean_tags_missed: float             # by the executor's count (the paper's loop counts none)
    mean_replans: float
    bumps: int                          # bumper presses over all missions
    wall_crossings: int                 # of the missions' true tracks, over all missions
    arrived: Interval                   # percent: the executor's success wherever the robot stopped
    stop_distance_m: float | None       # median distance from the goal node where the arrived missions stopped
    within: tuple[Interval, ...] = ()   # success within each of RADII_M (percent, Wilson)
    mean_passages_missed: float = 0.0   # ground truth: tag passages with no read

    @property
    def missions(self) -> int:
        return self.success.n


def within(run: MissionRun, radius_m: float) -> bool:
    """Success against ``radius_m``: the executor arrived, within the radius of the goal node, no wall crossed
    (at GOAL_RADIUS_M, ``run.success``)."""
    return run.arrived and run.goal_distance_m <= radius_m and run.wall_crossings == 0


def summarise(floor: str, method: str, rate: float, runs: list[MissionRun]) -> RateSummary:
    ok = [run for run in runs if run.success]
    return RateSummary(floor, method, rate, Interval.of_proportion(len(ok), len(runs)),
                       Interval.of([run.path_length_m / run.shortest_path_m for run in ok]),
                       Interval.of([run.duration_s for run in ok]),
                       float(np.mean([run.tags_missed for run in runs])), float(np.mean([run.replans for run in runs])),
                       sum(run.bumps for run in runs), sum(run.wall_crossings for run in runs),
                       Interval.of_proportion(sum(run.arrived for run in runs), len(runs)),
                       float(np.median([run.goal_distance_m for run in runs if run.arrived]))
                       if any(run.arrived for run in runs) else None,
                       tuple(Interval.of_proportion(sum(within(run, radius) for run in runs), len(runs))
                             for radius in RADII_M),
                       float(np.mean([run.passages_missed for run in runs])))


def paired(results: dict[tuple[str, str, float], list[MissionRun]], floor: str, rate: float,
           figure: str) -> Interval:
    """Ours minus the paper's loop, mission by mission: success (percentage points) or time [s, both succeeded]."""
    def values(method: str) -> dict[int, float | None]:
        runs = results[(floor, method, rate)]
        if figure == "success":
            return {index: 100.0 * run.success for index, run in enumerate(runs)}
        return {index: run.duration_s if run.success else None for index, run in enumerate(runs)}
    return paired_interval(values("ours"), values("paper"))


# ------------------------------------------------------------------------------------- failure causes

# The causes, by the code the rows carry (a quoted figure selects a row by it), and what each means.
WRONG_JUNCTION, NEAR_GOAL, FAR_FROM_GOAL, GAVE_UP = "wrong_junction", "near_goal", "far_from_goal", "gave_up"
HELD_AT_WALL, STANDING, LOST, DRIVING, CROSSED_WALL = "held_at_wall", "standing", "lost", "driving", "crossed_wall"
CAUSE_TEXT = {
    WRONG_JUNCTION: "arrived by its account at the wrong junction",
    NEAR_GOAL: f"arrived, stopped {GOAL_RADIUS_M:g}-{max(RADII_M):g} m from the goal node",
    FAR_FROM_GOAL: f"arrived, stopped beyond {max(RADII_M):g} m of the goal node, nearest to it",
    GAVE_UP: "stopped, the executor giving up (no mapped route)",
    HELD_AT_WALL: "timed out, held at a wall (bumper pressed at the end)",
    STANDING: "timed out, standing still (no bumper)",
    LOST: "timed out, driving on, lost (believed elsewhere than the nearest node)",
    DRIVING: "timed out, driving on",
    CROSSED_WALL: "crossed a wall (ground truth)",
}
CAUSES = tuple(CAUSE_TEXT)
STANDING_S = 60.0                       # a timed-out robot within STILL_M of its end for this long stood still


def failure_cause(run: MissionRun) -> str | None:
    """The one class of a failed mission (None for a success), from what the run recorded, first match: a wall
    crossed; arrived by the executor's account (at a junction other than the goal's, or too far from the goal's
    node); stopped without arriving; not stopped within the time (held at a wall, standing still, lost, or driving
    on)."""
    if run.success:
        return None
    if run.wall_crossings:
        return CROSSED_WALL
    if run.arrived:
        if run.nearest_node != run.goal_node:
            return WRONG_JUNCTION
        return NEAR_GOAL if run.goal_distance_m <= max(RADII_M) else FAR_FROM_GOAL
    if run.stopped:
        return GAVE_UP
    if run.bumped_at_end:
        return HELD_AT_WALL
    if run.still_s >= STANDING_S:
        return STANDING
    return LOST if run.believed_node != run.nearest_node else DRIVING


def failure_counts(results: dict[tuple[str, str, float], list[MissionRun]], floors: tuple[str, ...]) \
        -> dict[str, dict[str, tuple[int, int]]]:
    """Per method, per cause: (failures, of them with a tag passage missed: ground truth, whether the executor
    noticed or not), over every mission of ``floors`` at every rate; every cause listed (zeros too)."""
    counts: dict[str, dict[str, tuple[int, int]]] = {}
    for method in METHODS:
        runs = [run for (floor, name, _), runs in results.items() if floor in floors and name == method
                for run in runs]
        causes = Counter(failure_cause(run) for run in runs)
        missed = Counter(failure_cause(run) for run in runs if run.passages_missed)
        counts[method] = {cause: (causes[cause], missed[cause]) for cause in CAUSES}
    return counts


def pooled_ours(summaries: list[RateSummary]) -> RateSummary:
    return next(s for s in summaries if (s.floor, s.method, s.miss_rate) == (POOLED, "ours", TARGET_RATE))


def target_met(summaries: list[RateSummary]) -> bool:
    ours = pooled_ours(summaries)
    return (ours.success.mean is not None and ours.success.mean >= TARGET_SUCCESS_PCT
            and ours.path_ratio.mean is not None and ours.path_ratio.mean <= PATH_TARGET)
