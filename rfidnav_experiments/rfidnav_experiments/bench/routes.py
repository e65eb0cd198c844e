"""``./rfidnav bench routes``: the tag routes in-process with the shipped files, both controllers.

Paper 001's four routes and ours (``long_legs``: every leg beyond the reader's reach, README "Reach") run with
:func:`rfidnav_experiments.runners.tag_route.run_tag_route` as ``./rfidnav run`` would run them (the scenario's
reader file, not ``reproduce flc``'s calibrated noise), with ``flc_paper.yaml`` and ``flc_tuned.yaml`` on seeds
1..N. Per (route, parameter set): runs reaching every tag, tracking RMSE and max |e| over those runs, sim time,
time spent searching for an unheard target, and each failure's message. Exit code 0 when every run reached every
tag, 1 otherwise.
"""

from __future__ import annotations

import json
import statistics
from typing import Any

from rfidnav_experiments.calibrate.flc import scenario_named
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.tables import table
from rfidnav_experiments.runners.tag_route import RouteRun, controller_parameters, run_tag_route
from rfidnav_scenario.scenario import CONFIG_DIR

ROUTES = ("line_follow_90", "line_follow_0", "acute_path", "hallway", "long_legs")
PARAM_SETS = ("flc_paper", "flc_tuned")


def run_one(job: tuple[str, str, int]) -> tuple[str, RouteRun]:
    """One (parameter set, route, seed) run (an engine task)."""
    params, name, seed = job
    scenario = scenario_named(name)
    controller = controller_parameters(scenario, CONFIG_DIR / "params" / f"{params}.yaml", seed)
    return params, run_tag_route(scenario, controller, seed)


def mean(values: list[float]) -> float | None:
    return statistics.fmean(values) if values else None


def summary_rows(results: list[tuple[str, RouteRun]], seeds: list[int]) -> list[dict[str, Any]]:
    rows = []
    for name in ROUTES:
        for params in PARAM_SETS:
            runs = sorted((run for p, run in results if p == params and run.scenario == name), key=lambda r: r.seed)
            ok = [run for run in runs if run.success]
            rows.append({
                "scenario": name, "params": params, "seeds": seeds, "runs": len(runs), "successes": len(ok),
                "tracking_rmse_m": mean([run.metrics.tracking_rmse_m for run in ok
                                         if run.metrics.tracking_rmse_m is not None]),
                "tracking_max_abs_m": mean([run.metrics.tracking_max_abs_m for run in ok
                                            if run.metrics.tracking_max_abs_m is not None]),
                "sim_duration_s": mean([run.sim_duration_s for run in runs]),
                "search_s": mean([run.metrics.search_s for run in runs]),
                "failures": [f"seed {run.seed}: {run.message}" for run in runs if not run.success]})
    return rows


def _number(value: float | None, scale: float = 1.0, digits: int = 1) -> str:
    return "-" if value is None else f"{value * scale:.{digits}f}"


def human_report(rows: list[dict[str, Any]]) -> str:
    lines = [f"bench routes: in-process, the shipped files, seeds {', '.join(map(str, rows[0]['seeds']))}",
             *table(["scenario", "params", "success", "RMSE [cm]", "max|e| [cm]", "sim time [s]", "searching [s]"],
                    [[row["scenario"], row["params"], f"{row['successes']}/{row['runs']}",
                      _number(row["tracking_rmse_m"], 100.0, 2), _number(row["tracking_max_abs_m"], 100.0),
                      _number(row["sim_duration_s"]), _number(row["search_s"])] for row in rows])]
    lines += [f"  {row['scenario']} {row['params']} {failure}" for row in rows for failure in row["failures"]]
    return "\n".join(lines)


def bench_routes(seeds: int, as_json: bool) -> int:
    chosen = list(range(1, seeds + 1))
    jobs = [(params, name, seed) for name in reversed(ROUTES) for params in PARAM_SETS for seed in chosen]
    rows = summary_rows(run_tasks(run_one, jobs, "bench routes"), chosen)
    print(json.dumps(rows, indent=1) if as_json else human_report(rows))
    return 0 if all(row["successes"] == row["runs"] for row in rows) else 1
