"""reproduce partitions: the JSON rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (what ``--json``
prints and the results file keeps), the conditions first."""

from __future__ import annotations

from typing import Any

from rfidnav_common.tag_lattice import LAYOUTS
from rfidnav_experiments.reproduce.partitions.deployments import Accuracy, OrientationErrors, saved_pct
from rfidnav_experiments.reproduce.partitions.jobs import NavigationResult
from rfidnav_experiments.reproduce.partitions.settings import (
    ABLATION,
    COUNT_RANGE_M,
    DISTANCES_M,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG11_PARTITIONS,
    FIG11_RANGE_M,
    FILTER,
    METHODS,
    NAVIGATION_RANGES_M,
    PAPER,
    PAPER_BAND_2CM_PCT,
    PAPER_SAVED_PCT,
    headline_level,
)
from rfidnav_experiments.reproduce.partitions.summary import (
    COSTS,
    CostSummary,
    Key,
    met,
    oracle_interval,
    paired_difference,
    target_pct,
)
from rfidnav_experiments.reproduce.tables import Condition, Interval, condition_json_rows


def interval_rows(experiment: str, setting: dict[str, Any], metric: str, interval: Interval,
                  paper: list[float] | None = None) -> list[dict[str, Any]]:
    """A mean, its 95 % interval's half width and its number of runs, as three rows."""
    return [{"experiment": experiment, "setting": setting, "metric": metric, "ours": interval.mean, "paper": paper},
            {"experiment": experiment, "setting": setting, "metric": f"{metric}_ci95", "ours": interval.half_width,
             "paper": None},
            {"experiment": experiment, "setting": setting, "metric": f"{metric}_n", "ours": interval.n, "paper": None}]


def headline_json_rows(summaries: dict[Key, CostSummary], groups: dict[Key, list[NavigationResult]]) \
        -> list[dict[str, Any]]:
    level = headline_level()
    rows: list[dict[str, Any]] = []
    for r in NAVIGATION_RANGES_M:
        setting = {"read_range_m": r, "level": level, "seed": EVALUATION_SEED}
        rows += interval_rows("partitions.headline", setting, "oracle_extra_time_cost_pct",
                              oracle_interval(groups, r, level))
        for method in METHODS:
            s = summaries[(method, r, level)]
            for figure, attribute in COSTS:
                # The paper's one number: Fig. 12's band, for its translational cost at 2 cm.
                paper = list(PAPER_BAND_2CM_PCT) if (r == 0.02 and figure == "extra_cost_pct") else None
                rows += interval_rows("partitions.headline", {**setting, "method": method}, figure,
                                      getattr(s, attribute), paper)
            rows += interval_rows("partitions.headline", {**setting, "method": method}, "success_pct", s.success)
        for ours, baseline in ((FILTER, PAPER), (ABLATION, FILTER), (ABLATION, PAPER)):
            for figure in ("extra_cost_pct", "extra_time_cost_pct"):
                rows += interval_rows("partitions.headline", {**setting, "ours": ours, "baseline": baseline},
                                      f"paired_difference_{figure}",
                                      paired_difference(groups, ours, baseline, r, level, figure))
        for figure, attribute in COSTS:
            ours_cost = getattr(summaries[(FILTER, r, level)], attribute)
            target = target_pct(r, getattr(summaries[(PAPER, r, level)], attribute).mean)
            rows.append({"experiment": "partitions.headline", "setting": {**setting, "method": FILTER},
                         "metric": f"target_{figure}", "ours": target, "paper": None})
            rows.append({"experiment": "partitions.headline", "setting": {**setting, "method": FILTER},
                         "metric": f"target_{figure}_met", "ours": met(ours_cost, target) == "met", "paper": None})
    return rows


def json_rows(condition_rows: list[Condition], summaries: dict[Key, CostSummary],
              groups: dict[Key, list[NavigationResult]], fig11: OrientationErrors | None,
              counts: dict[int, dict[str, int]] | None, accuracy: dict[tuple[str, float], Accuracy] | None) \
        -> list[dict[str, Any]]:
    rows = [*condition_json_rows(EXPERIMENT, condition_rows), *headline_json_rows(summaries, groups)]

    def row(experiment: str, setting: dict, metric: str, ours: float | None, paper: float | None = None) -> None:
        rows.append({"experiment": experiment, "setting": setting, "metric": metric, "ours": ours, "paper": paper})

    for (method, r, level), s in sorted(summaries.items()):
        setting = {"method": method, "read_range_m": r, "level": level, "seed": EVALUATION_SEED}
        for d in DISTANCES_M:
            rows.extend(interval_rows("partitions.fig12_14", {**setting, "distance_m": d}, "extra_cost_pct",
                                      s.cost_by_distance[d]))
            rows.extend(interval_rows("partitions.fig12_14", {**setting, "distance_m": d}, "extra_time_cost_pct",
                                      s.time_cost_by_distance[d]))
        rows.extend(interval_rows("partitions.fig12_14", setting, "success_pct", s.success))
        rows.extend(interval_rows("partitions.fig12_14", setting, "extra_cost_pct", s.cost))
        rows.extend(interval_rows("partitions.fig12_14", setting, "extra_time_cost_pct", s.time_cost))
        rows.extend(interval_rows("partitions.fig12_14", setting, "extra_cost_to_goal_pct", s.to_goal))
        row("partitions.fig12_14", setting, "final_error_m", s.final_error_mean_m)
    if fig11 is not None:
        for k in FIG11_PARTITIONS:
            setting = {"partitions": k, "read_range_m": FIG11_RANGE_M}
            rows.extend(interval_rows("partitions.fig11", {"method": PAPER, **setting}, "orientation_error_deg",
                                      fig11.paper_deg[k]))
            if k in fig11.filter_deg:
                rows.extend(interval_rows("partitions.fig11", {"method": FILTER, **setting}, "orientation_error_deg",
                                          fig11.filter_deg[k]))
    if counts is not None:
        for side, c in counts.items():
            for layout in LAYOUTS:
                row("partitions.fig15_18", {"layout": layout, "area_m": side, "read_range_m": COUNT_RANGE_M},
                    "tags", c[layout])
        for layout in ("triangular", "compressed"):
            row("partitions.fig15_18", {"layout": layout}, "saved_vs_grid_pct", saved_pct(counts, layout),
                PAPER_SAVED_PCT[layout])
    if accuracy is not None:
        for (layout, r), a in accuracy.items():
            setting = {"layout": layout, "read_range_m": r}
            rows.extend(interval_rows("partitions.fig16_20", setting, "location_error_m", a.location_m))
            rows.extend(interval_rows("partitions.fig16_20", setting, "orientation_error_deg", a.orientation_deg))
    return rows
