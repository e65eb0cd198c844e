"""``./rfidnav reproduce flc``: paper 001 section V, in-process, beside the paper's figures.

The paper-faithful controller (flc_paper: the paper's method on the paper's robot, with the two settings the
paper leaves open fitted by ``./rfidnav calibrate flc`` to the line experiments alone, in
config/params/flc_paper_calibrated.yaml) and ours (flc_tuned.yaml) run in the same conditions (the calibrated
phase noise for both) on the four experiments of the paper (a line from 90 and from 0 degrees, the acute-angle
path, the hallway; evaluation seeds 101, 102, ..., which the calibration never saw) and on fresh seeded random
routes (runners.random_routes, the ledger's evaluation set ``current("flc")``), with
:func:`rfidnav_experiments.runners.tag_route.run_tag_route` (no DDS, so hundreds of runs take minutes). For flc_paper
the lines are fitted and the acute path and the hallway held out; flc_tuned was developed on all four, so for it
they are development routes and only the random routes are fresh. Every run is scored over the stretch ground truth
decides (rfidnav_scenario.metrics). Reports:

* the conditions: every setting a run reads, with where it comes from, per parameter set where they differ
  (``paper``, with the section; ``paper, interpreted``; ``calibrated``, by which command, to which figures;
  ``ours``, and why);
* per experiment: the paper's RMSE, both controllers' mean with its 95 % interval over the successful runs, and
  the paired difference (ours minus the baseline, on the same seeds) with its interval; the baseline against the
  paper within +-25 %; our target, at most half the baseline's; max |e| beside the paper's error envelope; success
  rates; the approach on line_follow_90; both on the random routes; the calibration's held-out spread (from
  flc_paper_calibration.json);
* with ``--json``, rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (DESIGN.md), the conditions too,
  also written to ``OUT/flc_rows.json``;
* plots ``flc_<scenario>.png`` in the output folder: the first evaluation seed's trajectories of both over the
  desired path (equal aspect) and e(t) below, like paper 001 Figs. 9, 11 and 13.

Nothing here asserts the targets: the command reports, the person reads. The exit code is 0 when every
flc_tuned run reached all its tags and 1 otherwise; the paper-faithful set may fail without changing it (a
failure is the method's result, reported). The pinned configuration (a test's): ``reproduce_flc(seeds=1, ...)``.

The package by concern: ``conditions`` (the parameter sets, routes, seeds and the paper's figures), ``provenance``
(where every setting comes from: the conditions table, and the calibration's record), ``jobs`` (the runs as engine
tasks), ``summary`` (a setting's runs summed up, the paired differences), ``rows`` (the JSON rows), ``report`` (the
text tables) and ``plots``; this module runs them in turn.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.flc.conditions import ROWS_FILE, TUNED, evaluation_seeds, random_seeds
from rfidnav_experiments.reproduce.flc.jobs import run_all
from rfidnav_experiments.reproduce.flc.plots import write_plots
from rfidnav_experiments.reproduce.flc.provenance import calibration_record, conditions
from rfidnav_experiments.reproduce.flc.report import human_report
from rfidnav_experiments.reproduce.flc.rows import json_rows
from rfidnav_experiments.reproduce.flc.summary import all_succeeded, summarise


def reproduce_flc(seeds: int, out_dir: Path, as_json: bool) -> int:
    """Run, report and plot; 0 when every flc_tuned run reached all its tags, else 1.

    ``seeds``: the evaluation seeds of the paper routes (101, 102, ...) and as many of the ledger's random routes
    (at most all of them). The --json rows are also written to ``out_dir/flc_rows.json``."""
    if seeds < 1:
        raise ConfigError("--seeds", "", "must be at least 1")
    out_dir = Path(out_dir)
    chosen = evaluation_seeds(seeds)
    route_seeds = random_seeds(seeds)
    condition_rows = conditions()
    record = calibration_record()
    results = run_all(chosen, route_seeds)
    summaries = {key: summarise(*key, runs) for key, runs in results.items()}
    plots = write_plots(results, out_dir)
    rows = json_rows(summaries, results, chosen, condition_rows, route_seeds, record)
    rows_file = out_dir / ROWS_FILE
    rows_file.write_text(json.dumps(rows, indent=1) + "\n")
    # Only the JSON goes to stdout with --json, so a program can parse it whole.
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print(human_report(summaries, results, chosen, condition_rows, route_seeds, record))
    print(f"plots: {', '.join(str(path) for path in plots)}; rows: {rows_file}", file=notes)
    tuned_ok = all_succeeded(run for (params, _), runs in results.items() if params == TUNED for run in runs)
    if not tuned_ok:
        print(f"reproduce flc: not every {TUNED} run reached all its tags (exit code 1)", file=notes)
    return 0 if tuned_ok else 1
