"""``./rfidnav bench rtf``: one scenario over real DDS at rising real-time factors.

The simulator keeps the requested RTF whether or not the rest of the graph keeps up, so on a busy machine a
high RTF turns compute latency into sim-time latency and tracking degrades. This finds the highest RTF at
which the runs still succeed with their mean tracking RMSE within ``tolerance`` of the RTF 1 runs' (each
lower RTF too), and reports the graph's CPU use at every RTF from summary.json. Over DDS the same seed does
not give the same run (rounds and commands interleave differently), so one run per RTF mostly measures that
spread: use several seeds.
"""

from __future__ import annotations

import json
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rfidnav_bringup.orchestrator import Orchestrator, RunOptions
from rfidnav_bringup.scenario import Scenario
from rfidnav_common.errors import ConfigError

REFERENCE_RTF = 1.0


@dataclass(frozen=True)
class SweepRow:
    """The runs at one RTF (one per seed): did all succeed, mean RMSE, mean CPU and wall time."""
    rtf: float
    success: bool
    rmse_m: float | None
    cpu_percent_of_one_core: float | None
    wall_s: float | None
    run_dirs: tuple[str, ...]

    def within(self, reference: SweepRow, tolerance: float) -> bool:
        return self.success and self.rmse_m is not None and reference.rmse_m is not None and \
            self.rmse_m <= reference.rmse_m * (1.0 + tolerance)


def _mean(values: list[float | None]) -> float | None:
    return round(statistics.fmean(values), 6) if values and None not in values else None


def sweep(scenario: Scenario, rtfs: list[float], seeds: list[int], out_dir: Path) -> list[SweepRow]:
    if REFERENCE_RTF not in rtfs:
        raise ConfigError("--rtfs", "", f"must include the reference RTF {REFERENCE_RTF:g}")
    rows = []
    for rtf in sorted(set(rtfs)):
        documents, run_dirs = [], []
        for seed in seeds:
            orchestrator = Orchestrator(scenario, RunOptions(rtf=rtf, seed=seed, out_dir=out_dir, quiet=True))
            summary = orchestrator.run()
            if orchestrator.interrupted:   # Ctrl-C stops the sweep, not just the run in progress
                raise KeyboardInterrupt
            documents.append(summary.document)
            run_dirs.append(str(summary.run_dir))
            print(f"bench rtf: RTF {rtf:g} seed {seed}: {'success' if summary.success else 'FAILED'}", flush=True)
        rows.append(SweepRow(
            rtf, all(d["success"] for d in documents),
            _mean([d["metrics"].get("tracking_rmse_m") for d in documents]),
            _mean([(d.get("cpu") or {}).get("graph_cpu_percent_of_one_core") for d in documents]),
            _mean([d.get("wall_duration_s") for d in documents]), tuple(run_dirs)))
    return rows


def highest_usable_rtf(rows: list[SweepRow], tolerance: float) -> SweepRow | None:
    """The highest RTF whose runs, and every lower RTF's, are within tolerance of the reference."""
    reference = next(row for row in rows if row.rtf == REFERENCE_RTF)
    best = None
    for row in sorted(rows, key=lambda r: r.rtf):
        if not row.within(reference, tolerance):
            break
        best = row
    return best


def report(scenario: str, rows: list[SweepRow], tolerance: float, as_json: bool) -> str:
    reference = next(row for row in rows if row.rtf == REFERENCE_RTF)
    best = highest_usable_rtf(rows, tolerance)
    if as_json:
        document: dict[str, Any] = {
            "scenario": scenario, "tolerance": tolerance,
            "highest_rtf": best.rtf if best else None,
            "graph_cpu_percent_of_one_core_there": best.cpu_percent_of_one_core if best else None,
            "rows": [{**row.__dict__, "run_dirs": list(row.run_dirs)} for row in rows]}
        return json.dumps(document)
    lines = [f"{scenario} over DDS, mean over {len(reference.run_dirs)} seed(s) per RTF: RMSE against RTF "
             f"{REFERENCE_RTF:g}, graph CPU during the mission (100% = one core)",
             f"{'RTF':>5}  {'success':>7}  {'RMSE cm':>8}  {'vs RTF 1':>8}  {'CPU %':>6}  {'wall s':>7}  runs"]
    for row in rows:
        ratio = f"{row.rmse_m / reference.rmse_m:.2f}x" if row.rmse_m and reference.rmse_m else "-"
        rmse = f"{100 * row.rmse_m:.2f}" if row.rmse_m is not None else "-"
        cpu = f"{row.cpu_percent_of_one_core:.1f}" if row.cpu_percent_of_one_core is not None else "-"
        wall = f"{row.wall_s:.1f}" if row.wall_s is not None else "-"
        lines.append(f"{row.rtf:>5g}  {str(row.success):>7}  {rmse:>8}  {ratio:>8}  {cpu:>6}  {wall:>7}  "
                     f"{' '.join(row.run_dirs)}")
    lines.append(f"highest RTF within {100 * tolerance:.0f}% of the RTF 1 RMSE: "
                 + (f"{best.rtf:g}, graph CPU {best.cpu_percent_of_one_core:.1f}% of one core" if best else "none"))
    return "\n".join(lines)
