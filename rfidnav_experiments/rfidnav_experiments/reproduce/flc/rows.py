"""reproduce flc: the JSON rows (what ``flc_rows.json`` and the results file keep): the conditions, each parameter
set's figures per scenario beside the paper's, the random routes, and the calibration's uncertainty and sweep."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments.calibrate.flc import CALIBRATION_SEEDS
from rfidnav_experiments.reproduce.flc.conditions import (
    BASELINE,
    EXPERIMENT,
    PAPER,
    PAPER_TIME_TO_FIRST_TAG_S,
    PARAM_SETS,
    RANDOM,
    SCENARIOS,
    TIME_SCENARIO,
    TUNED,
    PaperFigures,
    role,
)
from rfidnav_experiments.reproduce.flc.provenance import calibration_record
from rfidnav_experiments.reproduce.flc.summary import Summary, paired_difference
from rfidnav_experiments.reproduce.tables import Condition, condition_json_rows
from rfidnav_experiments.runners.tag_route import RouteRun


def calibration_rows(record: dict[str, Any]) -> list[dict[str, Any]]:
    """The calibration's uncertainty: the held-out RMSE's spread over the near-best grid points (calibration
    seeds), and whether its best point is inside the grid."""
    held = record.get("held_out", {})
    rows = []
    for scenario, spread in held.get("spread", {}).items():
        setting = {"scenario": scenario, "params": BASELINE, "source": "calibration", "role": role(scenario),
                   "points": spread["points"], "near_best": held["near_best"],
                   "seed_list": record.get("seeds", list(CALIBRATION_SEEDS))}
        rows += [{"experiment": EXPERIMENT, "setting": dict(setting), "metric": metric, "ours": spread[key],
                  "paper": spread["paper_m"]} for metric, key in (("calibration_held_out_rmse_min_m", "min_m"),
                                                                  ("calibration_held_out_rmse_max_m", "max_m"))]
    if "interior" in record:
        rows.append({"experiment": EXPERIMENT, "setting": {"params": BASELINE, "source": "calibration"},
                     "metric": "calibration_interior", "ours": bool(record["interior"]), "paper": None})
    return rows + sweep_rows(record)


def sweep_rows(record: dict[str, Any]) -> list[dict[str, Any]]:
    """The open-settings sweep around the best grid point (calibration seeds): each swept value's fitted figures
    beside the paper's targets, and its failed runs."""
    targets = record.get("fitted_to", {})
    rows = []
    for point in record.get("sweep", []):
        (name, value), = point["open"].items()
        setting = {"params": BASELINE, "source": "calibration", "open_setting": name, "value": value}
        rows += [{"experiment": EXPERIMENT, "setting": {**setting, "scenario": scenario}, "metric": "sweep_rmse_m",
                  "ours": rmse, "paper": targets.get("rmse_m", {}).get(scenario)}
                 for scenario, rmse in point["rmse_m"].items()]
        rows += [{"experiment": EXPERIMENT, "setting": {**setting, "scenario": TIME_SCENARIO},
                  "metric": "sweep_approach_s", "ours": point["approach_s"],
                  "paper": targets.get("approach_s", {}).get(TIME_SCENARIO)},
                 {"experiment": EXPERIMENT, "setting": dict(setting), "metric": "sweep_failures",
                  "ours": point["failures"], "paper": None}]
    return rows


def summary_figures(s: Summary, paper: PaperFigures | None) -> list[tuple[str, float | None, float | None]]:
    return [("tracking_rmse_m", s.rmse.mean, paper.rmse_m if paper else None),
            ("tracking_rmse_ci95_m", s.rmse.half_width, None),
            ("tracking_max_abs_m", s.max_abs_mean_m, paper.max_abs_m if paper else None),
            ("success_pct", s.success_pct, None),
            ("wall_crossings", s.wall_crossings, None),
            ("search_s", s.search.mean, None)]


def json_rows(summaries: dict[tuple[str, str], Summary], results: dict[tuple[str, str], list[RouteRun]],
              seeds: list[int], condition_rows: list[Condition], route_seeds: list[int] | None = None,
              record: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    rows = condition_json_rows(EXPERIMENT, condition_rows)
    for params in PARAM_SETS:
        for scenario in SCENARIOS:
            s, paper = summaries[(params, scenario)], PAPER[scenario]
            setting = {"scenario": scenario, "params": params, "seeds": len(seeds), "seed_list": seeds,
                       "role": role(scenario) if params == BASELINE else "development"}
            figures = summary_figures(s, paper)
            if scenario == TIME_SCENARIO:
                figures += [("approach_s", s.approach.mean, PAPER_TIME_TO_FIRST_TAG_S),
                            ("approach_ci95_s", s.approach.half_width, None),
                            ("time_to_first_tag_s", s.time_to_first_tag_mean_s, PAPER_TIME_TO_FIRST_TAG_S),
                            ("first_tag_within_1cm_pct", s.within_1cm_pct, None),
                            ("first_arrival_s", s.first_arrival.mean, PAPER_TIME_TO_FIRST_TAG_S)]
            if params == TUNED:
                difference = paired_difference(results, scenario)
                figures += [("paired_rmse_difference_m", difference.mean, None),
                            ("paired_rmse_difference_ci95_m", difference.half_width, None)]
            rows += [{"experiment": EXPERIMENT, "setting": dict(setting), "metric": metric, "ours": ours,
                      "paper": paper_value} for metric, ours, paper_value in figures]
        if route_seeds and (params, RANDOM) in summaries:
            s = summaries[(params, RANDOM)]
            setting = {"scenario": RANDOM, "params": params, "routes": len(route_seeds), "seed_list": route_seeds,
                       "role": "fresh"}
            figures = summary_figures(s, None)
            if params == TUNED:
                difference = paired_difference(results, RANDOM)
                figures += [("paired_rmse_difference_m", difference.mean, None),
                            ("paired_rmse_difference_ci95_m", difference.half_width, None)]
            rows += [{"experiment": EXPERIMENT, "setting": dict(setting), "metric": metric, "ours": ours,
                      "paper": paper_value} for metric, ours, paper_value in figures]
    return rows + calibration_rows(record if record is not None else calibration_record())
