"""``./rfidnav reproduce topological``: paper 004, in-process (rfidnav_experiments.runners.topological).

* The paper's run (section 5): from before tag 23 to tag 19 with a right turn, a 1.6 m passage, about 8 m.
* 100 missions between random (start tag, goal node) pairs on the 25-junction floor at tag read-miss
  probabilities 0, 10, 20 and 30 % (per tag passage): success rate, time, path length over the shortest.
  Every miss rate and method faces the same 100 missions. The paper's loop (the baseline) has no recovery
  from a missed tag: it follows on until the next tag re-localizes it; ours carries the route's expectation
  through the junction (mission_executor). Both use our wall follower and stop at the goal junction's centre.
"""

from __future__ import annotations

import json
import multiprocessing
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rfidnav_common.errors import ConfigError  # noqa: E402
from rfidnav_experiments.reproduce.tables import progress, save, table  # noqa: E402
from rfidnav_experiments.runners.topological import MissionRun, paper_run, random_missions  # noqa: E402

MISS_RATES = (0.0, 0.1, 0.2, 0.3)
METHODS = {"paper": False, "ours": True}     # method -> recover_missed_tags
MISSIONS = 100
WORKERS = 2
TARGETS = {0.0: 100.0, 0.2: 95.0}        # success % the issue asks for
PATH_TARGET = 1.10                      # path within 10 % of the shortest on successful missions


@dataclass(frozen=True)
class RateSummary:
    method: str
    miss_rate: float
    missions: int
    success_pct: float
    mean_duration_s: float | None
    path_ratio: float | None            # mean path / shortest over the successful missions
    mean_tags_missed: float
    mean_replans: float


def missions_at(job: tuple[str, float, int, int]) -> list[MissionRun]:
    method, miss_rate, count, seed = job
    return random_missions(count, miss_rate, seed, recover_missed_tags=METHODS[method])


def summarise(method: str, miss_rate: float, runs: list[MissionRun]) -> RateSummary:
    ok = [run for run in runs if run.success]
    return RateSummary(method, miss_rate, len(runs), 100.0 * len(ok) / len(runs),
                       statistics.fmean(run.duration_s for run in ok) if ok else None,
                       statistics.fmean(run.path_length_m / run.shortest_path_m for run in ok) if ok else None,
                       statistics.fmean(run.tags_missed for run in runs), statistics.fmean(run.replans for run in runs))


def reproduce_topological(missions: int, out_dir: Path, as_json: bool, seed: int = 7) -> int:
    """Run, report and plot; 0 when the targets are met, else 1."""
    if missions < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {missions}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paper = paper_run(np.random.default_rng(seed))
    context = multiprocessing.get_context("forkserver")
    jobs = [(method, rate, missions, seed) for method in METHODS for rate in MISS_RATES]
    with context.Pool(WORKERS) as pool:
        results = pool.map(missions_at, jobs)
    progress(f"reproduce topological: {missions} missions at {len(MISS_RATES)} miss rates, {len(METHODS)} methods",
             final=True)
    summaries = [summarise(method, rate, runs) for (method, rate, _, _), runs in zip(jobs, results)]
    rows = json_rows(paper, summaries)
    (out_dir / "topological_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_summaries(summaries, out_dir)
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join(report_lines(paper, summaries)))
    print(f"plot: {plot}; rows: {out_dir / 'topological_rows.json'}", file=notes)
    met = all(s.success_pct >= TARGETS.get(s.miss_rate, 0.0) for s in summaries if s.method == "ours")
    return 0 if met else 1


def report_lines(paper: MissionRun, summaries: list[RateSummary]) -> list[str]:
    turns = ", ".join(f"{action} at {node}" for node, action in paper.turns) or "none"
    lines = ["reproduce topological: paper 004, in-process", "",
             f"The paper's run (tag 23 -> tag 19, building_fig5): {'success' if paper.success else 'FAILED'} "
             f"({paper.message}); turns: {turns}; driven {paper.path_length_m:.1f} m, shortest "
             f"{paper.shortest_path_m:.1f} m (paper: a right turn, 1.6 m passage, about 8 m)", "",
             f"{summaries[0].missions} missions between random (start tag, goal) pairs on building_large "
             "(target for ours: 100 % at 0 % misses, >= 95 % at 20 %; path within 10 % of the shortest). paper: the "
             "paper's loop, no recovery of a missed tag (it cannot count them: 0); ours: the route's expectation"]
    lines += table(["method", "tag misses", "success %", "target", "mean time s", "path / shortest", "tags missed",
                    "replans"],
                   [[s.method, f"{s.miss_rate * 100:g} %", f"{s.success_pct:.0f}",
                     f">= {TARGETS[s.miss_rate]:g}" if s.miss_rate in TARGETS and s.method == "ours" else "-",
                     "-" if s.mean_duration_s is None else f"{s.mean_duration_s:.0f}",
                     "-" if s.path_ratio is None else f"{s.path_ratio:.3f}", f"{s.mean_tags_missed:.2f}",
                     f"{s.mean_replans:.2f}"] for s in summaries])
    return lines


def json_rows(paper: MissionRun, summaries: list[RateSummary]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = [
        {"experiment": "paper_run", "setting": {"from_tag": "23", "goal": "g"}, "metric": "path_length_m",
         "ours": paper.path_length_m, "paper": 8.0, "success": paper.success}]
    for s in summaries:
        setting = {"method": s.method, "miss_rate": s.miss_rate, "missions": s.missions}
        rows.append({"experiment": "random_missions", "setting": setting, "metric": "success_pct",
                     "ours": s.success_pct, "paper": None})
        rows.append({"experiment": "random_missions", "setting": setting, "metric": "path_over_shortest",
                     "ours": s.path_ratio, "paper": None})
    return rows


def plot_summaries(summaries: list[RateSummary], out_dir: Path) -> Path:
    figure, axes = plt.subplots(1, 2, figsize=(10, 4))
    labels = {"paper": "paper's loop (no recovery)", "ours": "ours (recovers missed tags)"}
    for method, label in labels.items():
        mine = [s for s in summaries if s.method == method]
        rates = [s.miss_rate * 100 for s in mine]
        axes[0].plot(rates, [s.success_pct for s in mine], "o-", label=label)
        axes[1].plot(rates, [s.path_ratio or np.nan for s in mine], "o-", label=label)
    axes[0].set(xlabel="tag read misses [%]", ylabel="missions reaching the goal [%]", ylim=(0, 105),
                title="Success against read failures")
    axes[0].legend()
    axes[1].axhline(PATH_TARGET, color="grey", linestyle="--", label="target: within 10 %")
    axes[1].set(xlabel="tag read misses [%]", ylabel="path / shortest (successful)", title="Path length")
    axes[1].legend()
    return save(figure, out_dir / "topological_missions.png", dpi=110)
