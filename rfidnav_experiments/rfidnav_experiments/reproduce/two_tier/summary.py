"""reproduce two_tier: the runs' figures: a Fig. 10 point and its paired differences, medians with their
distribution-free intervals, Fig. 12's tag fixes, the wall crossings and a home's arrivals, errors, paths and bumps."""

from __future__ import annotations

import statistics
from collections.abc import Hashable, Sequence
from dataclasses import dataclass

from scipy import stats

from rfidnav_experiments.reproduce.tables import Interval, paired_interval
from rfidnav_experiments.reproduce.two_tier.conditions import OURS, PAPER, TARGET_FIX_ERROR_M
from rfidnav_experiments.reproduce.two_tier.navigations import HomeRun, Leg
from rfidnav_experiments.reproduce.two_tier.searches import Search


@dataclass(frozen=True)
class SpiralPoint:
    """Fig. 10 at one distance for one method."""
    found: Interval                       # percent of the placements where a tag was read
    length: Interval                      # [m] over the placements where one was


def variant_difference(variant: dict[str, dict[float, list[Search]]], main: dict[str, dict[float, list[Search]]],
                       method: str, distance: float) -> Interval:
    """A variant's search length less the main figure's [m], paired on the placements both found."""
    def lengths(spiral: dict[str, dict[float, list[Search]]]) -> dict[Hashable, float | None]:
        return {s.placement.index: s.length_m for s in spiral[method][distance]}

    return paired_interval(lengths(variant), lengths(main))


def spiral_point(searches: list[Search]) -> SpiralPoint:
    lengths = [s.length_m for s in searches if s.length_m is not None]
    return SpiralPoint(Interval.of_proportion(len(lengths), len(searches)), Interval.of(lengths))


def paired_difference(spiral: dict[str, dict[float, list[Search]]], distance: float) -> Interval:
    """Ours minus the paper's search length [m] on the placements both found."""
    def lengths(method: str) -> dict[Hashable, float | None]:
        return {s.placement.index: s.length_m for s in spiral[method][distance]}

    return paired_interval(lengths(OURS), lengths(PAPER))


@dataclass(frozen=True)
class Crossings:
    """The wall crossings of the navigations' true tracks (rfidnav_scenario.metrics.wall_crossings), in all."""
    navigations: int
    count: int


@dataclass(frozen=True)
class Median:
    """A median with its distribution-free 95 % interval (order statistics: the ranks a binomial(n, 1/2) puts
    2.5 % outside on each side; at least 95 % coverage; none below 6 values)."""
    value: float | None
    bounds: tuple[float, float] | None
    n: int

    @classmethod
    def of(cls, values: Sequence[float]) -> Median:
        ordered = sorted(values)
        n = len(ordered)
        if n == 0:
            return cls(None, None, 0)
        low_rank = int(stats.binom.ppf(0.025, n, 0.5))     # 1-based rank of the lower bound
        bounds = (ordered[low_rank - 1], ordered[n - low_rank]) if low_rank >= 1 else None
        return cls(float(statistics.median(ordered)), bounds, n)

    def text(self, scale: float = 100.0, digits: int = 1) -> str:
        if self.value is None:
            return "-"
        interval = "" if self.bounds is None else \
            f" [{self.bounds[0] * scale:.{digits}f}, {self.bounds[1] * scale:.{digits}f}]"
        return f"{self.value * scale:.{digits}f}{interval} (n={self.n})"


@dataclass(frozen=True)
class FixFigures:
    """Fig. 12's tag fixes: ours and the paper's way on the same polls."""
    at_turning_points: dict[str, Median]      # by method: the last fix of each leg
    all_fixes: dict[str, Median]              # by method: every fix of every leg
    paired_m: Interval                        # ours minus the paper's, the last fix of each leg
    failed_legs: int

    @property
    def target_met(self) -> bool | None:
        value = self.at_turning_points[OURS].value
        return None if value is None else value <= TARGET_FIX_ERROR_M


def fix_figures(legs: list[Leg]) -> FixFigures:
    done = [leg for leg in legs if leg.fix_m is not None and leg.tag_position_m is not None]
    ours: dict[Hashable, float | None] = {(leg.route, leg.run, leg.point): leg.fix_m for leg in legs}
    paper: dict[Hashable, float | None] = {(leg.route, leg.run, leg.point): leg.tag_position_m for leg in legs}
    return FixFigures(
        {OURS: Median.of([leg.fix_m for leg in done if leg.fix_m is not None]),
         PAPER: Median.of([leg.tag_position_m for leg in done if leg.tag_position_m is not None])},
        {OURS: Median.of([e for leg in legs for e in leg.all_fixes_m]),
         PAPER: Median.of([e for leg in legs for e in leg.all_tag_positions_m])},
        paired_interval(ours, paper), len(legs) - len(done))


def legs_at(legs: list[Leg], route: str, point: str) -> list[Leg]:
    return [leg for leg in legs if leg.route == route and leg.point == point]


@dataclass(frozen=True)
class HomeFigures:
    arrived: Interval                     # percent of the runs
    final_error: Median                   # [m] of the runs that arrived
    path_length: Median                   # [m] of every run
    bumps: int                            # in all the runs
    runs_without_bumps: int
    wall_crossings: int                   # in all the runs (ground truth)


def home_figures(results: list[HomeRun], home: str, legs: str) -> HomeFigures:
    here = [result for result in results if result.home == home and result.legs == legs]
    arrived = [result for result in here if result.success]
    return HomeFigures(Interval.of_proportion(len(arrived), len(here)),
                       Median.of([result.final_error_m for result in arrived]),
                       Median.of([result.path_length_m for result in here]), sum(result.bumps for result in here),
                       sum(result.bumps == 0 for result in here), sum(result.wall_crossings for result in here))


def done(errors: dict[int, float | None]) -> list[float]:
    return [error for error in errors.values() if error is not None]
