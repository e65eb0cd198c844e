"""reproduce two_tier: the JSON rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (DESIGN.md; what the
results file keeps), the conditions first; "paper" is null where the paper gives no number."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments.reproduce.tables import Condition, condition_json_rows, paired_interval
from rfidnav_experiments.reproduce.two_tier.conditions import (
    EXPERIMENT,
    FIG10_DISTANCES_M,
    HOMES,
    LEGS,
    MAIN_VARIANT,
    METHODS,
    OURS,
    PAPER,
    PAPER_FIG10_M,
    ROUTES,
    TARGET_FIX_ERROR_M,
    Variant,
)
from rfidnav_experiments.reproduce.two_tier.navigations import HomeRun, Leg
from rfidnav_experiments.reproduce.two_tier.searches import Search
from rfidnav_experiments.reproduce.two_tier.summary import (
    Crossings,
    FixFigures,
    Median,
    done,
    home_figures,
    legs_at,
    paired_difference,
    spiral_point,
    variant_difference,
)


def row(experiment: str, setting: dict[str, Any], metric: str, ours: Any, paper: Any = None) -> dict[str, Any]:
    return {"experiment": experiment, "setting": setting, "metric": metric, "ours": ours, "paper": paper}


def median_rows(experiment: str, setting: dict[str, Any], metric: str, median: Median) -> list[dict[str, Any]]:
    """A median and the bounds of its 95 % interval (``METRIC_low``, ``METRIC_high``; null below 6 values)."""
    low, high = median.bounds or (None, None)
    return [row(experiment, setting, metric, median.value), row(experiment, setting, f"{metric}_low", low),
            row(experiment, setting, f"{metric}_high", high)]


def json_rows(condition_rows: list[Condition], spiral, theorem, moving, legs: list[Leg], fixes: FixFigures,
              radio, crossings: Crossings, seed: int) -> list[dict[str, Any]]:
    rows = condition_json_rows(EXPERIMENT, condition_rows)
    for method in METHODS:
        for distance in FIG10_DISTANCES_M:
            searched = spiral_point(spiral[method][distance])
            setting = {"method": method, "distance_m": distance, "seed": seed, "placements": searched.found.n,
                       "found": searched.length.n}
            rows += [row("fig10_spiral", setting, "search_length_m", searched.length.mean,
                         PAPER_FIG10_M.get(distance)),
                     row("fig10_spiral", setting, "search_length_ci95_m", searched.length.half_width),
                     row("fig10_spiral", setting, "found_pct", searched.found.mean)]
    for distance in FIG10_DISTANCES_M:
        difference = paired_difference(spiral, distance)
        setting = {"method": f"{OURS}-{PAPER}", "distance_m": distance, "seed": seed, "pairs": difference.n}
        rows += [row("fig10_spiral", setting, "paired_difference_m", difference.mean),
                 row("fig10_spiral", setting, "paired_difference_ci95_m", difference.half_width)]
    for sigma, printed, rayleigh, simulated in theorem:
        rows += [row("theorem1", {"sigma_m": sigma, "seed": seed}, "search_length_m", simulated, printed),
                 row("theorem1", {"sigma_m": sigma, "seed": seed}, "rayleigh_expectation_m", rayleigh)]
    for kind, errors in moving.items():
        median = Median.of(done(errors))
        rows += median_rows("fig11_moving", {"moving": kind, "seed": seed, "n": median.n}, "median_error_m", median)
    moved = paired_interval(moving["indirect"], moving["direct"])
    setting = {"moving": "indirect-direct", "seed": seed, "pairs": moved.n}
    rows += [row("fig11_moving", setting, "paired_difference_m", moved.mean),
             row("fig11_moving", setting, "paired_difference_ci95_m", moved.half_width)]
    everywhere = Median.of([leg.fingerprint_m for leg in legs])
    rows += median_rows("fig12_turning_points", {"route": "all", "point": "all", "method": "fingerprinting",
                                                 "seed": seed, "n": everywhere.n}, "median_error_m", everywhere)
    for route, (_, points) in ROUTES.items():
        for point in points:
            here = legs_at(legs, route, point)
            for method, values in (("fingerprinting", [leg.fingerprint_m for leg in here]),
                                   (f"two_tier_{OURS}", [leg.fix_m for leg in here if leg.fix_m is not None]),
                                   (f"two_tier_{PAPER}", [leg.tag_position_m for leg in here
                                                          if leg.tag_position_m is not None])):
                median = Median.of(values)
                rows.append(row("fig12_turning_points", {"route": route.replace(" ", "_"), "point": point,
                                                         "method": method, "seed": seed, "n": median.n},
                                "median_error_m", median.value))
    for method in METHODS:
        median = fixes.at_turning_points[method]
        # the paper claims centimetres, no number
        rows += [*median_rows("tag_fix", {"method": method, "fixes": "turning_points", "seed": seed, "n": median.n},
                              "median_error_m", median),
                 row("tag_fix", {"method": method, "fixes": "turning_points", "seed": seed, "n": median.n},
                     "median_error_ci95_m", None if median.bounds is None else list(median.bounds)),
                 *median_rows("tag_fix", {"method": method, "fixes": "all", "seed": seed,
                                          "n": fixes.all_fixes[method].n}, "median_error_m", fixes.all_fixes[method])]
    paired = {"method": f"{OURS}-{PAPER}", "fixes": "turning_points", "seed": seed, "pairs": fixes.paired_m.n}
    rows += [row("tag_fix", paired, "paired_difference_m", fixes.paired_m.mean),
             row("tag_fix", paired, "paired_difference_ci95_m", fixes.paired_m.half_width),
             row("tag_fix", {"method": OURS, "seed": seed, "target_m": TARGET_FIX_ERROR_M}, "target_met",
                 fixes.target_met)]
    for kind, errors in radio.items():
        rows += median_rows("radio_map", {"map": kind, "seed": seed, "n": len(errors)}, "median_error_m",
                            Median.of(errors))
    rows.append(row("navigations", {"figures": "11,12", "seed": seed, "n": crossings.navigations}, "wall_crossings",
                    crossings.count))
    return rows


def sensitivity_json_rows(sensitivity: dict[Variant, dict[str, dict[float, list[Search]]]],
                          main: dict[str, dict[float, list[Search]]], seed: int) -> list[dict[str, Any]]:
    """Fig. 10's sensitivity: each variant's search length (metrics ``sensitivity_*``: the main figure's are
    fig10_spiral's), and its difference from the main figure on the same placements."""
    rows = []
    for (distance_to, delay), spiral in sensitivity.items():
        for method in METHODS:
            for distance in FIG10_DISTANCES_M:
                searched = spiral_point(spiral[method][distance])
                setting = {"method": method, "distance_m": distance, "distance_to": distance_to, "delay": delay,
                           "seed": seed, "placements": searched.found.n, "found": searched.length.n}
                difference = variant_difference(spiral, main, method, distance)
                against = {**setting, "against": "_".join(MAIN_VARIANT), "pairs": difference.n}
                rows += [row("fig10_sensitivity", setting, "sensitivity_search_length_m", searched.length.mean,
                             PAPER_FIG10_M.get(distance)),
                         row("fig10_sensitivity", setting, "sensitivity_search_length_ci95_m",
                             searched.length.half_width),
                         row("fig10_sensitivity", setting, "sensitivity_found_pct", searched.found.mean),
                         row("fig10_sensitivity", against, "sensitivity_difference_m", difference.mean),
                         row("fig10_sensitivity", against, "sensitivity_difference_ci95_m", difference.half_width)]
    return rows


def home_json_rows(results: list[HomeRun], seed: int) -> list[dict[str, Any]]:
    rows = []
    for home in HOMES:
        for legs in LEGS:
            figures = home_figures(results, home, legs)
            setting = {"home": home, "legs": legs, "seed": seed, "runs": figures.arrived.n}
            low, high = figures.arrived.bounds or (None, None)
            rows += [row("homes", setting, "arrived_pct", figures.arrived.mean),
                     row("homes", setting, "arrived_pct_low", low), row("homes", setting, "arrived_pct_high", high),
                     row("homes", {**setting, "n": figures.final_error.n}, "final_error_median_m",
                         figures.final_error.value),
                     row("homes", setting, "path_length_median_m", figures.path_length.value),
                     row("homes", setting, "bumps", figures.bumps),
                     row("homes", setting, "runs_without_bumps", figures.runs_without_bumps),
                     row("homes", setting, "wall_crossings", figures.wall_crossings)]
    return rows
