"""reproduce fused: the figures of a localizer's track in one run, a run's figures, and a world's over its runs
(means with 95 % intervals, paired differences less the fused localizer, recoveries and arrivals)."""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass

from scipy import stats

from rfidnav_experiments.reproduce.fused.conditions import DRIVING_WORLDS, NEES_BAND, PARTITIONS, localizers_of
from rfidnav_experiments.reproduce.tables import Interval, paired_interval
from rfidnav_experiments.reproduce.two_tier import HOMES
from rfidnav_experiments.runners.fused import Track


@dataclass(frozen=True)
class TrackFigures:
    position_rmse_m: float | None
    heading_rmse_deg: float | None
    fix_rate: float
    consistent: float | None          # share of rounds with an estimate whose NEES is in its 95 % band
    heading_rmse_paper_rounds_deg: float | None   # heading RMSE over the rounds the paper's localizer had a heading

    @classmethod
    def of(cls, track: Track, paper_heading_times_s: Collection[float] = ()) -> TrackFigures:
        bands = {dof: stats.chi2.ppf(((1 - NEES_BAND) / 2, (1 + NEES_BAND) / 2), dof) for dof in set(track.nees_dofs)}
        inside = [bool(bands[dof][0] <= value <= bands[dof][1]) for value, dof in zip(track.nees, track.nees_dofs,
                                                                                      strict=True)]
        return cls(_rms(track.position_errors_m), _rms_deg(track.heading_errors_rad), track.fix_rate,
                   sum(inside) / len(inside) if inside else None,
                   _rms_deg(track.heading_errors_at(frozenset(paper_heading_times_s))))


@dataclass(frozen=True)
class FusedRun:
    world: str
    run: int
    success: bool                     # the paper's mission arrived
    figures: dict[str, TrackFigures]  # per localizer of localizers_of(world)
    global_s: float | None            # the fused localizer's global localization from the start [s]; None: never
    late_global_s: float | None       # the same, for one started at LATE_START_S (mid-mission) [s]
    kidnap_recovery_s: float | None   # [s] from the kidnap; None: not found again (or the run ended first)
    duration_s: float
    final_error_m: float | None = None   # ARRIVING_WORLDS: the true distance from the target at the end


def _rms(values: list[float]) -> float | None:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else None


def _rms_deg(radians: list[float]) -> float | None:
    return _rms([math.degrees(e) for e in radians])


METRICS = {"position_rmse_m": ("position RMSE [m]", 1.0, 3),
           "heading_rmse_deg": ("heading RMSE [deg]", 1.0, 2),
           "fix_rate": ("fix rate [%]", 100.0, 1),
           "consistent": ("NEES in its 95 % band [%]", 100.0, 1),
           "heading_rmse_paper_rounds_deg": ("heading RMSE where the paper has one [deg]", 1.0, 2)}


def figures(results: list[FusedRun], world: str) -> dict[str, dict[str, Interval]]:
    """Per metric: each localizer's mean over the runs and the paired difference of each other one less fused."""
    mine = [r for r in results if r.world == world]
    out: dict[str, dict[str, Interval]] = {}
    for metric in METRICS:
        values = {name: {r.run: getattr(r.figures[name], metric) for r in mine} for name in localizers_of(world)}
        out[metric] = {name: Interval.of([v for v in values[name].values() if v is not None])
                       for name in localizers_of(world)}
        for name in localizers_of(world)[1:]:
            out[metric][f"{name} - fused"] = paired_interval(values[name], values["fused"])
    return out


def recovery_keys(world: str) -> tuple[str, ...]:
    """The FusedRun fields of a world's recovery figures (the fused pose that drives is neither started late nor
    kidnapped: the robot would drive off with it)."""
    return ("global_s",) if world in DRIVING_WORLDS else ("global_s", "late_global_s", "kidnap_recovery_s")


def recovery_figures(results: list[FusedRun], world: str) -> dict[str, tuple[Interval, int]]:
    """Global localization and kidnap recovery [s]: the mean over the runs where it happened, and how many did."""
    mine = [r for r in results if r.world == world]
    out = {}
    for key in recovery_keys(world):
        found = [getattr(r, key) for r in mine if getattr(r, key) is not None]
        out[key] = (Interval.of(found), len(found))
    return out


@dataclass(frozen=True)
class Arrival:
    """How a world's missions ended: arrivals, and the true distance from the target at the end."""
    driver: str                        # the localizer the navigator drove on
    arrived: int
    runs: int
    rate: Interval                     # [%]
    final_error_m: Interval

    @classmethod
    def of(cls, results: list[FusedRun], world: str) -> Arrival:
        mine = [r for r in results if r.world == world]
        arrived = sum(r.success for r in mine)
        return cls("paper" if world in (*HOMES, PARTITIONS) else "fused", arrived, len(mine),
                   Interval.of_proportion(arrived, len(mine)),
                   Interval.of([r.final_error_m for r in mine if r.final_error_m is not None]))
