"""``./rfidnav reproduce flc``: paper 001 section V, in-process, beside the paper's figures.

Runs the paper-faithful controller (config/params/flc_paper.yaml) and ours (flc_tuned.yaml) on the
four scenarios of the paper (straight line from 90 and 0 degrees, the acute-angle path, the hallway)
for seeds 1..N with :func:`rfidnav_experiments.runners.tag_route.run_tag_route` (no DDS, so hundreds of runs
take minutes), then reports:

* a table per scenario: the paper's RMSE, ours for both parameter sets (mean +- sd over the
  successful runs), the target for flc_tuned (half the paper's RMSE) and whether the mean meets it;
  max |e| beside the paper's error envelope; success rates; on line_follow_90 the time to come
  within 1 cm of the first tag (paper: about 110 s) with the fraction of runs that did at all;
* with ``--json``, rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (DESIGN.md);
* plots ``flc_<scenario>.png`` in the output folder: seed 1's trajectory of both parameter sets
  over the desired path and e(t) below, like paper 001 Figs. 9, 11 and 13.

Nothing here asserts the targets: the command reports, the person reads. The exit code is 0 when
every flc_tuned run reached all its tags and 1 otherwise, so a script can tell that our controller
still completes its missions; the paper-faithful set may fail without changing it.
"""

from __future__ import annotations

import json
import multiprocessing
import statistics
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from rfidnav_bringup.metrics import FIRST_TAG_RADIUS_M, tracking_error  # noqa: E402
from rfidnav_bringup.scenario import CONFIG_DIR, Scenario, load_scenario  # noqa: E402
from rfidnav_common.errors import ConfigError  # noqa: E402
from rfidnav_experiments.reproduce.tables import mean_or_none, progress, save, table  # noqa: E402
from rfidnav_experiments.runners.tag_route import (  # noqa: E402
    RouteRun,
    controller_parameters,
    role_parameters,
    run_tag_route,
    tag_points,
)

EXPERIMENT = "flc"
PARAM_SETS = ("flc_paper", "flc_tuned")
TUNED = "flc_tuned"
SCENARIOS = ("line_follow_90", "line_follow_0", "acute_path", "hallway")
TIME_SCENARIO = "line_follow_90"        # the only experiment for which the paper gives the approach time
WORKERS = 2                             # the target machine has two cores


@dataclass(frozen=True)
class PaperFigures:
    """What paper 001 section V reports for one experiment."""
    rmse_m: float
    envelope_m: tuple[float, float]     # the band e(t) stayed in (Figs. 9b, 9d, 11b, 13b)

    @property
    def max_abs_m(self) -> float:
        return max(abs(bound) for bound in self.envelope_m)


PAPER = {
    "line_follow_90": PaperFigures(0.034, (-0.05, 0.05)),
    "line_follow_0": PaperFigures(0.093, (-0.30, 0.05)),
    "acute_path": PaperFigures(0.175, (-0.05, 0.50)),
    "hallway": PaperFigures(0.13, (-0.30, 0.25)),
}
PAPER_TIME_TO_FIRST_TAG_S = 110.0
TUNED_RMSE_FRACTION = 0.5               # our target: half the paper's RMSE
TUNED_TIME_TARGET_S = 45.0              # our target for the approach to the first tag


@dataclass(frozen=True)
class Summary:
    """Aggregate of the runs of one (parameter set, scenario)."""
    params: str
    scenario: str
    runs: int
    successes: int
    rmse_mean_m: float | None           # over successful runs: a failed run's e(t) covers only part of the route
    rmse_sd_m: float | None             # sample sd; None with fewer than two successful runs
    max_abs_mean_m: float | None
    first_tag_times_s: tuple[float, ...]   # runs that came within 1 cm of the first tag
    first_arrival_mean_s: float | None  # mean time the follower declared arrival at the first tag

    @property
    def success_pct(self) -> float:
        return 100.0 * self.successes / self.runs

    @property
    def within_1cm_pct(self) -> float:
        return 100.0 * len(self.first_tag_times_s) / self.runs

    @property
    def time_to_first_tag_mean_s(self) -> float | None:
        return statistics.fmean(self.first_tag_times_s) if self.first_tag_times_s else None


# ---------------------------------------------------------------------------------------------- runs

_scenario_cache: dict[str, Scenario] = {}


def _scenario(name: str) -> Scenario:
    # Loading validates world, map and every parameter file; once per worker process is enough.
    if name not in _scenario_cache:
        _scenario_cache[name] = load_scenario(name)
    return _scenario_cache[name]


def params_file(params: str) -> Path:
    return CONFIG_DIR / "params" / f"{params}.yaml"


def run_one(job: tuple[str, str, int]) -> tuple[str, RouteRun]:
    """One (parameter set, scenario, seed) run; module-level so the pool can pickle it."""
    params, scenario_name, seed = job
    scenario = _scenario(scenario_name)
    return params, run_tag_route(scenario, controller_parameters(scenario, params_file(params), seed), seed)


def jobs(seeds: int) -> list[tuple[str, str, int]]:
    # Longest routes first, so the two workers do not end with one long hallway run each.
    order = sorted(SCENARIOS, key=lambda name: -len(_scenario(name).mission.goal["tag_ids"]))
    return [(params, name, seed) for name in order for params in PARAM_SETS for seed in range(1, seeds + 1)]


def run_all(seeds: int) -> dict[tuple[str, str], list[RouteRun]]:
    """Every run, grouped by (parameter set, scenario) and sorted by seed, with a progress line."""
    todo = jobs(seeds)
    results: dict[tuple[str, str], list[RouteRun]] = {}
    started = time.monotonic()
    # forkserver, not fork: the caller may hold DDS threads (the test suite's own rclpy contexts), and a
    # forked copy of those can hang; the server imports this module once and forks the workers from it.
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__])
    with context.Pool(WORKERS) as pool:
        for done, (params, run) in enumerate(pool.imap_unordered(run_one, todo), start=1):
            results.setdefault((params, run.scenario), []).append(run)
            progress(f"reproduce flc: {done}/{len(todo)} runs ({params} {run.scenario} seed {run.seed}: "
                     f"{'ok' if run.success else run.message})", final=False)
    progress(f"reproduce flc: {len(todo)} runs in {time.monotonic() - started:.0f} s", final=True)
    return {key: sorted(runs, key=lambda run: run.seed) for key, runs in results.items()}


# ----------------------------------------------------------------------------------------- aggregate

def summarise(params: str, scenario: str, runs: list[RouteRun]) -> Summary:
    ok = [run for run in runs if run.success and run.metrics.tracking_rmse_m is not None]
    rmse = [run.metrics.tracking_rmse_m for run in ok]
    return Summary(
        params=params, scenario=scenario, runs=len(runs), successes=sum(run.success for run in runs),
        rmse_mean_m=mean_or_none(rmse),
        rmse_sd_m=statistics.stdev(rmse) if len(rmse) >= 2 else None,
        max_abs_mean_m=mean_or_none([run.metrics.tracking_max_abs_m for run in ok]),
        first_tag_times_s=tuple(run.metrics.time_to_first_tag_s for run in runs
                                if run.metrics.time_to_first_tag_s is not None),
        first_arrival_mean_s=mean_or_none([run.arrival_times_s[0] for run in runs if run.arrival_times_s]))


def json_rows(summaries: dict[tuple[str, str], Summary], seeds: int) -> list[dict[str, Any]]:
    rows = []
    for params in PARAM_SETS:
        for scenario in SCENARIOS:
            s, paper = summaries[(params, scenario)], PAPER[scenario]
            setting = {"scenario": scenario, "params": params, "seeds": seeds}
            figures: list[tuple[str, float | None, float | None]] = [
                ("tracking_rmse_m", s.rmse_mean_m, paper.rmse_m),
                ("tracking_rmse_sd_m", s.rmse_sd_m, None),
                ("tracking_max_abs_m", s.max_abs_mean_m, paper.max_abs_m),
                ("success_pct", s.success_pct, None),
            ]
            if scenario == TIME_SCENARIO:
                figures += [("time_to_first_tag_s", s.time_to_first_tag_mean_s, PAPER_TIME_TO_FIRST_TAG_S),
                            ("first_tag_within_1cm_pct", s.within_1cm_pct, None)]
            rows += [{"experiment": EXPERIMENT, "setting": dict(setting), "metric": metric, "ours": ours,
                      "paper": paper_value} for metric, ours, paper_value in figures]
    return rows


# ------------------------------------------------------------------------------------------- tables

def _cm(value_m: float | None, digits: int = 1) -> str:
    return "-" if value_m is None else f"{value_m * 100:.{digits}f}"


def _cm_sd(summary: Summary) -> str:
    if summary.rmse_mean_m is None:
        return "no success"
    sd = "" if summary.rmse_sd_m is None else f" ± {summary.rmse_sd_m * 100:.2f}"
    return f"{summary.rmse_mean_m * 100:.2f}{sd}"


def noise_model() -> str:
    # Read from the scenario's reader parameters, so the sentence follows the parameter file.
    reader = role_parameters(_scenario(TIME_SCENARIO), "rfid_reader_sim", 1)
    return (f"noise model: phase noise sd {reader.phase_noise_rad_per_m:g} rad per metre of tag distance, "
            f"read miss probability {reader.miss_probability:g} (rfid_reader_sim parameters)")


def rmse_table(summaries: dict[tuple[str, str], Summary]) -> list[str]:
    rows = []
    for scenario in SCENARIOS:
        paper_m, tuned = PAPER[scenario].rmse_m, summaries[(TUNED, scenario)]
        target_m = TUNED_RMSE_FRACTION * paper_m
        met = "-" if tuned.rmse_mean_m is None else ("yes" if tuned.rmse_mean_m <= target_m else "no")
        rows.append([scenario, _cm(paper_m), _cm_sd(summaries[("flc_paper", scenario)]), _cm_sd(tuned),
                     f"<= {_cm(target_m, 2)}", met])
    return ["tracking RMSE [cm], mean ± sd over successful runs",
            *table(["scenario", "paper", "flc_paper", "flc_tuned", "target flc_tuned (paper/2)", "met?"], rows)]


def envelope_table(summaries: dict[tuple[str, str], Summary]) -> list[str]:
    rows = []
    for scenario in SCENARIOS:
        low, high = PAPER[scenario].envelope_m
        rows.append([scenario, f"{low * 100:+.0f}..{high * 100:+.0f}",
                     *(_cm(summaries[(params, scenario)].max_abs_mean_m) for params in PARAM_SETS),
                     *(f"{summaries[(params, scenario)].successes}/{summaries[(params, scenario)].runs}"
                       for params in PARAM_SETS)])
    return ["max |e| [cm] (mean over successful runs) beside the paper's error envelope; runs reaching every tag",
            *table(["scenario", "paper envelope", "flc_paper max|e|", "flc_tuned max|e|",
                     "flc_paper success", "flc_tuned success"], rows)]


def first_tag_lines(summaries: dict[tuple[str, str], Summary]) -> list[str]:
    lines = [f"{TIME_SCENARIO}: time to within {FIRST_TAG_RADIUS_M * 100:.0f} cm of the first tag's projection "
             f"(paper: about {PAPER_TIME_TO_FIRST_TAG_S:.0f} s; target for {TUNED}: <= {TUNED_TIME_TARGET_S:.0f} s)"]
    for params in PARAM_SETS:
        s = summaries[(params, TIME_SCENARIO)]
        mean = s.time_to_first_tag_mean_s
        came = (f"mean {mean:.1f} s over those runs" if mean is not None
                else "never, so there is no time to compare")
        # The mean covers only the runs that came within 1 cm; say so when that is not all of them.
        met = "" if params != TUNED or mean is None else (
            f", target {'met' if mean <= TUNED_TIME_TARGET_S else 'not met'}"
            f"{'' if len(s.first_tag_times_s) == s.runs else ' by those runs'}")
        arrival = "" if s.first_arrival_mean_s is None else (
            f"; the follower declared arrival at the first tag after {s.first_arrival_mean_s:.1f} s on average")
        lines.append(f"  {params}: {len(s.first_tag_times_s)}/{s.runs} runs ({s.within_1cm_pct:.0f}%) came within "
                     f"{FIRST_TAG_RADIUS_M * 100:.0f} cm: {came}{met}{arrival}")
    return lines


def human_report(summaries: dict[tuple[str, str], Summary], seeds: int) -> str:
    lines = [f"reproduce flc: paper 001 section V, {seeds} seed(s) per setting, in-process simulation",
             noise_model(), "", *rmse_table(summaries), "", *envelope_table(summaries), "",
             *first_tag_lines(summaries)]
    return "\n".join(lines)


# -------------------------------------------------------------------------------------------- plots

PLOT_COLOURS = {"flc_paper": "tab:blue", "flc_tuned": "tab:red"}


def plot_scenario(scenario: Scenario, runs: dict[str, RouteRun], out_dir: Path) -> Path:
    """Seed 1 of each parameter set: trajectory over the desired path, e(t) below (Figs. 9, 11, 13)."""
    route = list(scenario.mission.goal["tag_ids"])
    points = tag_points(scenario, route)
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(8, 10), gridspec_kw={"height_ratios": [2, 1]})
    for x1, y1, x2, y2 in scenario.world.walls:
        top.plot([x1, x2], [y1, y2], color="0.6", linewidth=2)
    top.plot(points[:, 0], points[:, 1], "--", color="tab:green", label="desired path")
    top.plot(points[:, 0], points[:, 1], "s", color="tab:orange", markersize=5)
    for tag_id, point in zip(route, points):
        top.annotate(tag_id, point, textcoords="offset points", xytext=(4, 4))
    for params, run in runs.items():
        label = params if run.success else f"{params} ({run.message})"
        top.plot(run.trajectory.xy[:, 0], run.trajectory.xy[:, 1], color=PLOT_COLOURS[params], linewidth=1,
                 label=label)
        error = tracking_error(run.trajectory, points, list(run.arrival_times_s))
        rmse = run.metrics.tracking_rmse_m
        bottom.plot(error.times_s, error.xy[:, 0] * 100.0, color=PLOT_COLOURS[params], linewidth=1,
                    label=f"{params} (RMSE {_cm(rmse, 2)} cm)")
    top.plot(*next(iter(runs.values())).trajectory.xy[0], "k^", label="start")
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title(f"{scenario.name}: trajectory, seed 1")
    top.legend(loc="best")
    top.grid(True, alpha=0.3)
    low, high = PAPER[scenario.name].envelope_m
    for bound in (low, high):     # the paper's envelope, for the eye only
        bottom.axhline(bound * 100.0, color="0.5", linestyle=":", linewidth=1)
    bottom.axhline(0.0, color="0.5", linewidth=0.8)
    bottom.set_title(f"tracking error (dotted: paper's envelope {low * 100:+.0f}..{high * 100:+.0f} cm, "
                     f"RMSE {PAPER[scenario.name].rmse_m * 100:.1f} cm)")
    bottom.set_xlabel("time since mission start [s]")
    bottom.set_ylabel("e(t) [cm], + = left of path")
    bottom.legend(loc="best")
    bottom.grid(True, alpha=0.3)
    return save(figure, out_dir / f"flc_{scenario.name}.png", dpi=100)


def write_plots(results: dict[tuple[str, str], list[RouteRun]], out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    return [plot_scenario(_scenario(name), {params: results[(params, name)][0] for params in PARAM_SETS}, out_dir)
            for name in SCENARIOS]


# --------------------------------------------------------------------------------------------- verb

def all_succeeded(runs: Iterable[RouteRun]) -> bool:
    return all(run.success for run in runs)


def reproduce_flc(seeds: int, out_dir: Path, as_json: bool) -> int:
    """Run, report and plot; 0 when every flc_tuned run reached all its tags, else 1."""
    if seeds < 1:
        raise ConfigError("--seeds", "", "must be at least 1")
    out_dir = Path(out_dir)
    results = run_all(seeds)
    summaries = {key: summarise(*key, runs) for key, runs in results.items()}
    plots = write_plots(results, out_dir)
    # Only the JSON goes to stdout with --json, so a program can parse it whole.
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(json_rows(summaries, seeds), indent=1))
    else:
        print(human_report(summaries, seeds))
    print(f"plots: {', '.join(str(path) for path in plots)}", file=notes)
    tuned_ok = all_succeeded(run for (params, _), runs in results.items() if params == TUNED for run in runs)
    if not tuned_ok:
        print(f"reproduce flc: not every {TUNED} run reached all its tags (exit code 1)", file=notes)
    return 0 if tuned_ok else 1
