"""reproduce flc: a (parameter set, scenario)'s runs summed up, what counts as a success (ground truth overrules the
follower), and the paired differences of flc_tuned less flc_paper."""

from __future__ import annotations

import statistics
from collections.abc import Iterable
from dataclasses import dataclass

from rfidnav_experiments.reproduce.flc.conditions import BASELINE, TUNED, scenario_named
from rfidnav_experiments.reproduce.tables import Interval, mean_or_none, paired_interval
from rfidnav_experiments.runners.tag_route import RouteRun
from rfidnav_scenario.metrics import wall_crossings


@dataclass(frozen=True)
class Summary:
    """Aggregate of the runs of one (parameter set, scenario)."""
    params: str
    scenario: str
    runs: int
    successes: int
    rmse: Interval                      # over successful runs: a failed run's e(t) covers only part of the route
    max_abs_mean_m: float | None
    first_tag_times_s: tuple[float, ...]   # runs that came within 1 cm of the first tag
    first_arrival: Interval             # when the follower declared arrival at the first tag [s]
    wall_crossings: int                 # of the runs' true tracks, in all
    approach: Interval = Interval(None, None, 0)   # entry into the first tag's read area (the stretch's start) [s]
    search: Interval = Interval(None, None, 0)     # time spent searching an unheard target per run [s]

    @property
    def success_pct(self) -> float:
        return 100.0 * self.successes / self.runs

    @property
    def within_1cm_pct(self) -> float:
        return 100.0 * len(self.first_tag_times_s) / self.runs

    @property
    def time_to_first_tag_mean_s(self) -> float | None:
        return statistics.fmean(self.first_tag_times_s) if self.first_tag_times_s else None


def crossings(run: RouteRun) -> int:
    """How often the run's true track crossed one of its world's walls (the hallway's; the others have none)."""
    return wall_crossings(run.trajectory.xy, scenario_named(run.scenario).world.wall_segments())


def succeeded(run: RouteRun) -> bool:
    """The run reached all its tags without crossing a wall (ground truth overrules the follower, as over DDS)."""
    return run.success and crossings(run) == 0


def summarise(params: str, scenario: str, runs: list[RouteRun]) -> Summary:
    ok = [run for run in runs if succeeded(run) and run.metrics.tracking_rmse_m is not None]
    return Summary(
        params=params, scenario=scenario, runs=len(runs), successes=sum(succeeded(run) for run in runs),
        rmse=Interval.of([run.metrics.tracking_rmse_m for run in ok]),
        max_abs_mean_m=mean_or_none([run.metrics.tracking_max_abs_m for run in ok]),
        first_tag_times_s=tuple(run.metrics.time_to_first_tag_s for run in runs
                                if run.metrics.time_to_first_tag_s is not None),
        first_arrival=Interval.of([run.arrival_times_s[0] for run in runs if run.arrival_times_s]),
        wall_crossings=sum(crossings(run) for run in runs),
        approach=Interval.of([run.metrics.approach_s for run in runs if run.metrics.approach_s is not None]),
        search=Interval.of([run.metrics.search_s for run in runs]))


def paired_difference(results: dict[tuple[str, str], list[RouteRun]], scenario: str,
                      figure: str = "rmse") -> Interval:
    """flc_tuned minus flc_paper on the seeds both completed: the tracking RMSE [m] or the first arrival [s]."""
    def value(run: RouteRun) -> float | None:
        if figure == "rmse":
            return run.metrics.tracking_rmse_m if succeeded(run) else None
        if figure == "approach":
            return run.metrics.approach_s
        return run.arrival_times_s[0] if run.arrival_times_s else None

    return paired_interval({run.seed: value(run) for run in results[(TUNED, scenario)]},
                           {run.seed: value(run) for run in results[(BASELINE, scenario)]})


def all_succeeded(runs: Iterable[RouteRun]) -> bool:
    return all(succeeded(run) for run in runs)
