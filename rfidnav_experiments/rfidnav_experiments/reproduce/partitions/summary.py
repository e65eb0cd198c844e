"""reproduce partitions: the navigations of a (method, r, level) summed up, the paired differences between methods,
the oracle's time cost, and issue 14's targets judged."""

from __future__ import annotations

import statistics
from collections.abc import Hashable, Iterable
from dataclasses import dataclass

from rfidnav_experiments.reproduce.partitions.jobs import NavigationResult, oracle_time_cost_pct
from rfidnav_experiments.reproduce.partitions.settings import DISTANCES_M, PAPER, TARGET_2CM_PCT, TARGET_FRACTION
from rfidnav_experiments.reproduce.tables import Interval, mean_or_none, paired_interval

Key = tuple[str, float, int]          # (method, r, level)


def group(results: Iterable[NavigationResult]) -> dict[Key, list[NavigationResult]]:
    """The results by (method, r, level), each list in run order (the task index)."""
    groups: dict[Key, list[NavigationResult]] = {}
    for result in results:
        groups.setdefault((result.job.method, result.job.read_range_m, result.job.level), []).append(result)
    return {key: sorted(runs, key=lambda result: result.job.index) for key, runs in groups.items()}


# The two costs reported side by side: the result's field and the summary's.
COSTS = (("extra_cost_pct", "cost"), ("extra_time_cost_pct", "time_cost"))


@dataclass(frozen=True)
class CostSummary:
    """The runs of one (method, r, level); every cost over its successful runs."""
    method: str
    read_range_m: float
    level: int
    runs: int
    successes: int
    success: Interval                          # percent, Wilson interval
    cost: Interval                             # (l - |SD|) / |SD| [%]
    time_cost: Interval                        # turns charged [%]
    to_goal: Interval                          # had it gone on to the goal point [%]
    cost_by_distance: dict[float, Interval]
    time_cost_by_distance: dict[float, Interval]
    median_pct: float | None
    final_error_mean_m: float | None
    mean_replans: float


def summarise(key: Key, group_runs: list[NavigationResult]) -> CostSummary:
    ok = [result for result in group_runs if result.success]

    def by_distance(figure: str) -> dict[float, Interval]:
        return {d: Interval.of([getattr(result, figure) for result in ok if result.job.distance_m == d])
                for d in DISTANCES_M}

    costs = [result.extra_cost_pct for result in ok]
    return CostSummary(
        *key, runs=len(group_runs), successes=len(ok), success=Interval.of_proportion(len(ok), len(group_runs)),
        cost=Interval.of(costs), time_cost=Interval.of([result.extra_time_cost_pct for result in ok]),
        to_goal=Interval.of([result.extra_cost_to_goal_pct for result in ok]),
        cost_by_distance=by_distance("extra_cost_pct"), time_cost_by_distance=by_distance("extra_time_cost_pct"),
        median_pct=statistics.median(costs) if costs else None,
        final_error_mean_m=mean_or_none([result.final_error_m for result in ok]),
        mean_replans=statistics.fmean(result.replans for result in group_runs))


def paired_difference(groups: dict[Key, list[NavigationResult]], ours: str, baseline: str, r: float, level: int,
                      figure: str) -> Interval:
    """``ours`` minus ``baseline`` on the tasks both completed (same r, level and task index)."""
    def values(method: str) -> dict[Hashable, float | None]:
        return {result.job.index: getattr(result, figure) if result.success else None
                for result in groups[(method, r, level)]}

    return paired_interval(values(ours), values(baseline))


def oracle_interval(groups: dict[Key, list[NavigationResult]], r: float, level: int) -> Interval:
    return Interval.of([oracle_time_cost_pct(result.job) for result in groups[(PAPER, r, level)]])


def target_pct(r: float, paper_mean: float | None) -> float | None:
    if r == 0.02:
        return TARGET_2CM_PCT
    return None if paper_mean is None else TARGET_FRACTION * paper_mean


def met(value: Interval, target: float | None) -> str:
    if value.mean is None or target is None:
        return "-"
    return "met" if value.mean <= target else "not met"
