"""``./rfidnav reproduce partitions``: paper 000 section 6, in-process, beside the paper's figures.

Three configurations navigate, each from the nodes' parameter files (:data:`settings.METHOD_FILES`):

* ``paper``: the paper's localizer and navigator on the paper's robot (one floor antenna on the rotation axis;
  straight drives across N partitions to localize, turns on the spot towards the goal, sec. 4.2 and 5.2);
* ``filter``: our particle filter and navigator on the same robot with the same motion primitives (the headline,
  like for like);
* ``filter_boom_spin``: the same filter on a different robot (an antenna 25 cm ahead of the axis) that localizes
  by turning on the spot: an ablation, run at the headline level only.

Reported, on the evaluation tasks (:data:`settings.EVALUATION_SEED`; the configurations were developed on
:data:`settings.DEVELOPMENT_SEED`'s, which the tests use):

* the conditions: every physical setting that shapes the figures, with where it comes from (``paper`` with the
  section, ``ours`` and why; nothing is calibrated for paper 000);
* the headline at level N = 4 (the files' level): the paper's extra cost (l - |SD|) / |SD| and the extra cost in
  time (turns charged at the robot's turn rate, :func:`rfidnav_scenario.metrics.extra_time_cost_pct`), each a mean
  with its 95 % interval and number of runs; ``filter`` minus ``paper`` paired on the same tasks (common random
  numbers: every method, level and distance faces the same 250 start poses and goals per read range); the issue's
  targets, measured, met or not; the ablation beside them;
* Figs. 12-14: both costs against the destination distance (1-5 m) for levels 1-8 at r = 2, 20 and 50 cm;
* Fig. 11: orientation error against partitions traversed on a straight line (r = 2 cm), the paper's bounds
  and the filter fed the same crossings;
* Figs. 15 and 18: tag counts of grid, triangular and compressed deployments, 5 x 5 to 30 x 30 m;
* Figs. 16, 17, 19, 20: location and orientation error of the three deployments over read ranges;
* with ``--json``, rows ``{"experiment", "setting", "metric", "ours", "paper"}``, the conditions first.

The paper's figures are plots whose numbers the text gives only in part: the 2-6 % band of Fig. 12, "an order of
magnitude more" at 20 and 50 cm, 31 % and 9 % fewer tags. Those are printed beside ours; where the paper gives no
number the JSON row's ``paper`` is null. Nothing is fitted to the paper, and nothing asserts the targets: the
command reports, the person reads.

The package by concern: ``settings`` (the configurations, ranges, levels, counts and seeds, and the parameter files
each configuration runs from), ``conditions`` (where every setting comes from), ``jobs`` (the navigations as engine
tasks), ``summary`` (a (method, r, level)'s navigations summed up, the paired differences, the targets),
``deployments`` (Fig. 11 and Figs. 15-20: what the deployment alone gives), ``report`` (the text tables), ``rows``
(the JSON rows) and ``plots``; this module runs them in turn.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.partitions.conditions import conditions
from rfidnav_experiments.reproduce.partitions.deployments import accuracy_table_data, fig11_orientation, tag_counts
from rfidnav_experiments.reproduce.partitions.jobs import (
    benchmark,
    evaluation_jobs,
    navigation_jobs,
    run_navigation_job,
)
from rfidnav_experiments.reproduce.partitions.plots import (
    plot_costs,
    plot_deployments,
    plot_fig11,
    plot_headline,
    plot_trajectories,
)
from rfidnav_experiments.reproduce.partitions.report import human_report
from rfidnav_experiments.reproduce.partitions.rows import json_rows
from rfidnav_experiments.reproduce.partitions.settings import (
    ACCURACY_SAMPLES,
    DISTANCES_M,
    EVALUATION_SEED,
    FIG11_RUNS,
    FILTER,
    LEVELS,
    PAPER,
    headline_level,
    localizer_settings,
    navigator_settings,
    robot_speeds,
)
from rfidnav_experiments.reproduce.partitions.summary import group, summarise

# What modules outside this package import from it by its name: reproduce/fused.py (the configurations' settings),
# bench/experiments.py and verbs.py (the benchmark's jobs).
__all__ = ["FILTER", "LEVELS", "PAPER", "benchmark", "headline_level", "localizer_settings", "navigation_jobs",
           "navigator_settings", "reproduce_partitions", "robot_speeds", "run_navigation_job"]


def reproduce_partitions(runs: int, out_dir: Path, as_json: bool) -> int:
    """Run, report and plot; 0 when every navigation of ours (filter, filter_boom_spin) succeeded, else 1."""
    if runs < len(DISTANCES_M):
        raise ConfigError("--runs", "", f"must be at least {len(DISTANCES_M)} (one per distance)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    condition_rows = conditions(runs)
    counts = tag_counts()
    accuracy = accuracy_table_data(ACCURACY_SAMPLES, EVALUATION_SEED)
    fig11 = fig11_orientation(FIG11_RUNS, EVALUATION_SEED)
    results = run_tasks(run_navigation_job, evaluation_jobs(runs), "reproduce partitions: navigations")
    groups = group(results)
    summaries = {key: summarise(key, group_runs) for key, group_runs in groups.items()}
    plots = [plot_headline(summaries, groups, out_dir), plot_fig11(fig11, out_dir),
             plot_costs(summaries, runs, out_dir), plot_deployments(counts, accuracy, out_dir),
             plot_trajectories(out_dir, EVALUATION_SEED)]
    notes = sys.stderr if as_json else sys.stdout
    rows = json_rows(condition_rows, summaries, groups, fig11, counts, accuracy)
    (out_dir / "partitions_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print(human_report(condition_rows, summaries, groups, fig11, counts, accuracy, runs))
    print(f"plots: {', '.join(str(p) for p in plots)}; rows: {out_dir / 'partitions_rows.json'}", file=notes)
    failures = [r for r in results if r.job.method != PAPER and not r.success]
    if failures:
        print(f"reproduce partitions: {len(failures)} navigations of ours failed (exit code 1), e.g. "
              f"{failures[0].job.method}: {failures[0].message}", file=notes)
    return 1 if failures else 0
