"""reproduce fused: the JSON rows (what ``fused_rows.json`` and the results file keep)."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments.reproduce.fused.conditions import ARRIVING_WORLDS, EXPERIMENT
from rfidnav_experiments.reproduce.fused.summary import Arrival, FusedRun, figures, recovery_figures
from rfidnav_experiments.reproduce.tables import Condition, condition_json_rows


def json_rows(results: list[FusedRun], seed: int, condition_rows: list[Condition] | None = None) \
        -> list[dict[str, Any]]:
    """The conditions (metric "condition"), then per world: each localizer's mean over the runs of each metric
    and its 95 % half-width (``METRIC_ci95``), the paired differences (localizer ``NAME-fused``), the fused
    localizer's global localization and recovery times (with how many runs it happened in) and the arrivals."""
    rows = condition_json_rows(EXPERIMENT, condition_rows or [])
    for world in dict.fromkeys(r.world for r in results):
        runs = sum(r.world == world for r in results)
        base = {"world": world, "seed": seed, "runs": runs}
        for metric, figure in figures(results, world).items():
            for name, interval in figure.items():
                setting = {**base, "localizer": name.replace(" - ", "-"), "n": interval.n}
                rows += [_row(setting, metric, interval.mean), _row(setting, f"{metric}_ci95", interval.half_width)]
        for key, (interval, count) in recovery_figures(results, world).items():
            setting = {**base, "localizer": "fused", "n": interval.n}
            rows += [_row(setting, key, interval.mean), _row(setting, f"{key}_ci95", interval.half_width),
                     _row(setting, f"{key}_runs_found", count)]
        if world in ARRIVING_WORLDS:
            arrival = Arrival.of(results, world)
            setting = {**base, "localizer": arrival.driver}
            low, high = arrival.rate.bounds or (None, None)
            rows += [_row(setting, "arrived", arrival.arrived), _row(setting, "arrived_pct", arrival.rate.mean),
                     _row(setting, "arrived_pct_low", low), _row(setting, "arrived_pct_high", high),
                     _row({**setting, "n": arrival.final_error_m.n}, "final_error_m", arrival.final_error_m.mean),
                     _row({**setting, "n": arrival.final_error_m.n}, "final_error_m_ci95",
                          arrival.final_error_m.half_width)]
    return rows


def _row(setting: dict[str, Any], metric: str, ours: Any) -> dict[str, Any]:
    return {"experiment": EXPERIMENT, "setting": setting, "metric": metric, "ours": ours, "paper": None}
