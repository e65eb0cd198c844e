"""``./rfidnav bench topological`` and ``bench scaling``: how fast the reproductions' tasks go on the engine.

``topological``: paper 004's missions on the evaluation floors, both loops at the four miss rates (what
``reproduce topological`` runs there), on the command's engine: missions per second, each loop's success as a check
that the figures are the reproduction's. ``scaling``: one slice of a reproduction on local clusters of 1, 2, ...
workers, each cluster started before its clock starts: wall time, tasks per second, the speed-up over the fewest
workers, and whether every count gave the same rows to the bit.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rfidnav_experiments.engine import Engine, EngineOptions, engine_workers, machine_cores
from rfidnav_experiments.reproduce.partitions import FILTER, LEVELS, PAPER, navigation_jobs, run_navigation_job
from rfidnav_experiments.reproduce.topological import (
    EVALUATION_FLOORS,
    METHODS,
    MISS_RATES,
    mission_jobs,
    missions_chunk,
    run_all,
)
from rfidnav_experiments.task_rows import canonical


def topological_benchmark(runs: int) -> dict[str, Any]:
    started = time.perf_counter()
    results = run_all(runs, EVALUATION_FLOORS, "bench topological")
    wall = time.perf_counter() - started
    missions = sum(len(missions) for missions in results.values())

    def success_pct(method: str, rate: float) -> float:
        at_rate = [run for floor in EVALUATION_FLOORS for run in results[(floor, method, rate)]]
        return round(100.0 * sum(run.success for run in at_rate) / len(at_rate), 1)

    return {"floors": list(EVALUATION_FLOORS), "runs": runs, "missions": missions, "workers": engine_workers(),
            "wall_s": round(wall, 2), "missions_per_s": round(missions / wall, 3),
            "success_pct": {method: {f"{rate:g}": success_pct(method, rate) for rate in MISS_RATES}
                            for method in METHODS}}


def scaling_slice(experiment: str, runs: int) -> tuple[Callable[[Any], Any], list[Any], str]:
    """(task, jobs, unit) of the slice: the whole Figs. 12-14 grid of both paper 000 methods at ``runs`` per
    point, or the evaluation floors' missions of both paper 004 loops."""
    if experiment == "partitions":
        return run_navigation_job, navigation_jobs(runs, methods=(PAPER, FILTER), levels=LEVELS), "navigations"
    return missions_chunk, mission_jobs(runs, EVALUATION_FLOORS), "mission chunks"


def scaling_benchmark(experiment: str, worker_counts: list[int] | None, runs: int) -> list[dict[str, Any]]:
    function, jobs, unit = scaling_slice(experiment, runs)
    counts = worker_counts or sorted({1, 2, machine_cores()})
    rows: list[dict[str, Any]] = []
    reference: list[str] | None = None
    for workers in counts:
        with Engine(EngineOptions(workers=workers)) as engine:
            started = time.perf_counter()
            results = engine.map(function, jobs, f"bench scaling {experiment}: {workers} worker(s)")
            wall = time.perf_counter() - started
        encoded = [canonical(result) for result in results]
        reference = reference or encoded
        rows.append({"experiment": experiment, "workers": workers, "tasks": len(jobs), "unit": unit,
                     "wall_s": round(wall, 2), "tasks_per_s": round(len(jobs) / wall, 2),
                     "speedup": round(rows[0]["wall_s"] / wall, 2) if rows else 1.0,
                     "identical": encoded == reference, "cores": machine_cores()})
    return rows


def scaling_lines(rows: list[dict[str, Any]]) -> list[str]:
    return [f"{row['experiment']}: {row['tasks']} {row['unit']} on {row['workers']} worker(s): {row['wall_s']:.1f} s, "
            f"{row['tasks_per_s']:.1f} per second, x{row['speedup']:.2f}, "
            f"{'the same rows' if row['identical'] else 'ROWS DIFFER from the first count'}" for row in rows]
