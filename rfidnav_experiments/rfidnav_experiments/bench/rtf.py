"""``./rfidnav bench rtf``: one scenario over real DDS at rising real-time factors.

With the free-running clock (``--clock free``, the default here) the simulator keeps the requested RTF whether
or not the rest of the graph keeps up, so on a busy machine a high RTF turns compute latency into sim-time
latency and tracking degrades. This finds the highest RTF at which the runs still succeed with their mean
tracking RMSE within ``tolerance`` of the lowest RTF's runs (each lower RTF too), and reports the graph's CPU at
every RTF from summary.json. Over DDS with that clock the same seed does not give the same run (rounds and
commands interleave differently): use several seeds.

With the stepped clock (``--clock stepped``) the RTF is a ceiling (``max``: none) and the same seed should give
the same figures at every RTF and load; ``--hogs N`` keeps N busy loops running to load the machine. Beside the
RMSE each row gives the achieved speed (sim seconds per wall second) and the graph's CPU per simulated second.
"""

from __future__ import annotations

import json
import math
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rfidnav_bag.bags import bag_info
from rfidnav_bringup.api import RunOptions, cpu_hogs
from rfidnav_common.errors import ConfigError
from rfidnav_common.progress import progress
from rfidnav_experiments.bench.runs import quiet_run
from rfidnav_scenario.scenario import Scenario


@dataclass(frozen=True)
class SweepRow:
    """The runs at one RTF (one per seed): did all succeed, mean RMSE, mean CPU and wall time."""
    rtf: float
    success: bool
    rmse_m: float | None
    cpu_percent_of_one_core: float | None
    wall_s: float | None
    run_dirs: tuple[str, ...]
    clock: str = "free"
    sim_per_wall: float | None = None        # achieved speed: sim seconds per wall second of the mission
    cpu_s_per_sim_s: float | None = None     # the graph's CPU (all processes) per simulated second
    process_cpu_s_per_sim_s: dict[str, float] | None = None
    rmses_m: tuple[float | None, ...] = ()   # each seed's, to see identical figures as identical
    topic_msgs_per_sim_s: dict[str, float] | None = None   # messages each topic carried per simulated second (bag)

    def within(self, reference: SweepRow, tolerance: float) -> bool:
        if not self.success:
            return False
        if reference.success and reference.rmse_m is None:
            # A mission with no route to track (building_large's wall following, a two-tier navigation): its runs
            # are scored by success alone.
            return self.rmse_m is None
        return self.rmse_m is not None and reference.rmse_m is not None and \
            self.rmse_m <= reference.rmse_m * (1.0 + tolerance)


def _mean(values: list[float | None]) -> float | None:
    return round(statistics.fmean(values), 6) if values and None not in values else None


def _per_sim_s(document: dict[str, Any]) -> tuple[float | None, float | None, dict[str, float]]:
    cpu, sim_s = document.get("cpu") or {}, document.get("sim_duration_s")
    if not cpu or not sim_s:
        return None, None, {}
    per_process = {role: round(value / sim_s, 4) for role, value in cpu["process_cpu_s"].items() if value is not None}
    return round(sim_s / cpu["mission_wall_s"], 2), round(cpu["graph_cpu_s"] / sim_s, 4), per_process


def _topic_rates(document: dict[str, Any], run_dir: Path) -> dict[str, float]:
    """Messages per simulated second of each recorded topic (the bag's counts over the run's sim time)."""
    sim_s = document.get("sim_duration_s")
    if not sim_s or not (run_dir / "bag").is_dir():
        return {}
    return {topic.name: round(topic.count / sim_s, 2) for topic in bag_info(run_dir / "bag").topics}


def _means(dicts: list[dict[str, float]]) -> dict[str, float]:
    """Per key, the mean over the dicts that have it."""
    values: dict[str, list[float]] = {}
    for entries in dicts:
        for key, value in entries.items():
            values.setdefault(key, []).append(value)
    return {key: round(statistics.fmean(found), 4) for key, found in sorted(values.items())}


def sweep(scenario: Scenario, rtfs: list[float], seeds: list[int], out_dir: Path, clock: str = "free",
          hogs: int = 0) -> list[SweepRow]:
    if clock == "free" and not all(math.isfinite(rtf) for rtf in rtfs):
        raise ConfigError("--rtfs", "", "max needs the stepped clock (--clock stepped)")
    rows = []
    with cpu_hogs(hogs), progress(f"bench rtf {scenario.name} ({clock} clock)", len(set(rtfs)) * len(seeds)) as advance:
        for rtf in sorted(set(rtfs)):
            documents, run_dirs = [], []
            for seed in seeds:
                summary = quiet_run(scenario, RunOptions(rtf=rtf, clock=clock, seed=seed, out_dir=out_dir,
                                                         quiet=True))
                documents.append(summary.document)
                run_dirs.append(str(summary.run_dir))
                advance(1)
            speeds = [_per_sim_s(d) for d in documents]
            topics = [_topic_rates(d, Path(run_dir)) for d, run_dir in zip(documents, run_dirs, strict=True)]
            rows.append(SweepRow(
                rtf, all(d["success"] for d in documents),
                _mean([d["metrics"].get("tracking_rmse_m") for d in documents]),
                _mean([(d.get("cpu") or {}).get("graph_cpu_percent_of_one_core") for d in documents]),
                _mean([d.get("wall_duration_s") for d in documents]), tuple(run_dirs), clock,
                _mean([speed for speed, _, _ in speeds]), _mean([cpu for _, cpu, _ in speeds]),
                _means([processes for _, _, processes in speeds]),
                tuple(d["metrics"].get("tracking_rmse_m") for d in documents), _means(topics)))
    return rows


def highest_usable_rtf(rows: list[SweepRow], tolerance: float) -> SweepRow | None:
    """The highest RTF whose runs, and every lower RTF's, are within tolerance of the reference."""
    reference = min(rows, key=lambda r: r.rtf)
    best = None
    for row in sorted(rows, key=lambda r: r.rtf):
        if not row.within(reference, tolerance):
            break
        best = row
    return best


def report(scenario: str, rows: list[SweepRow], tolerance: float, as_json: bool) -> str:
    reference = min(rows, key=lambda r: r.rtf)
    best = highest_usable_rtf(rows, tolerance)
    if as_json:
        document: dict[str, Any] = {
            "scenario": scenario, "tolerance": tolerance,
            "highest_rtf": (best.rtf if math.isfinite(best.rtf) else "max") if best else None,
            "graph_cpu_percent_of_one_core_there": best.cpu_percent_of_one_core if best else None,
            "rows": [{**row.__dict__, "rtf": row.rtf if math.isfinite(row.rtf) else "max",
                      "run_dirs": list(row.run_dirs)} for row in rows]}
        return json.dumps(document)
    lines = [f"{scenario} over DDS, {reference.clock} clock, mean over {len(reference.run_dirs)} seed(s) per RTF: "
             f"RMSE against RTF {reference.rtf:g}, graph CPU during the mission (100% = one core), speed in sim s "
             f"per wall s, graph CPU-s per sim s",
             f"{'RTF':>5}  {'success':>7}  {'RMSE cm':>8}  {'vs ref':>7}  {'CPU %':>6}  {'wall s':>7}  {'speed':>6}  "
             f"{'CPU/sim':>7}  runs"]
    for row in rows:
        ratio = f"{row.rmse_m / reference.rmse_m:.4f}x" if row.rmse_m and reference.rmse_m else "-"
        rmse = f"{100 * row.rmse_m:.4f}" if row.rmse_m is not None else "-"
        cpu = f"{row.cpu_percent_of_one_core:.1f}" if row.cpu_percent_of_one_core is not None else "-"
        wall = f"{row.wall_s:.1f}" if row.wall_s is not None else "-"
        speed = f"{row.sim_per_wall:.1f}" if row.sim_per_wall is not None else "-"
        per_sim = f"{row.cpu_s_per_sim_s:.3f}" if row.cpu_s_per_sim_s is not None else "-"
        lines.append(f"{row.rtf:>5g}  {str(row.success):>7}  {rmse:>8}  {ratio:>7}  {cpu:>6}  {wall:>7}  "
                     f"{speed:>6}  {per_sim:>7}  {' '.join(row.run_dirs)}")
    lines += _breakdown("graph CPU-s per sim s, by process", [row.process_cpu_s_per_sim_s or {} for row in rows],
                        rows, "{:.4f}")
    lines += _breakdown("messages per sim s, by topic (the bag's)", [row.topic_msgs_per_sim_s or {} for row in rows],
                        rows, "{:.1f}")
    lines.append(f"highest RTF within {100 * tolerance:.0f}% of the RTF {reference.rtf:g} RMSE: "
                 + (f"{best.rtf:g}, graph CPU {best.cpu_percent_of_one_core:.1f}% of one core" if best else "none"))
    return "\n".join(lines)


def _breakdown(title: str, columns: list[dict[str, float]], rows: list[SweepRow], number: str) -> list[str]:
    """A table of one figure per key (a process, a topic) and RTF, largest first."""
    keys = sorted({key for column in columns for key in column}, key=lambda k: -max(c.get(k, 0.0) for c in columns))
    if not keys:
        return []
    width = max(len(key) for key in keys)
    header = "  ".join(f"{'max' if math.isinf(row.rtf) else f'{row.rtf:g}':>9}" for row in rows)
    return [title + ":", f"{'':<{width}}  {header}", *(
        f"{key:<{width}}  " + "  ".join(f"{number.format(column[key]) if key in column else '-':>9}"
                                        for column in columns) for key in keys)]
