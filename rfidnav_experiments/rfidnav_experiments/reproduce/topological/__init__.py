"""``./rfidnav reproduce topological``: paper 004, in-process (rfidnav_experiments.runners.topological).

* The conditions: every setting the runs read and where it comes from (``paper``, with the section; ``paper,
  interpreted: ...`` where the value reads the paper one way of several; ``ours``, and why; one source per method
  where the methods differ; nothing here is fitted).
* The paper's run (section 5): from before tag 23 to tag 19 with a right turn, a 1.6 m passage, about 8 m.
* Missions between random (start tag, goal node) pairs at tag read-miss probabilities 0, 10, 20 and 30 % (per
  tag passage), on floors kept apart by their role in the evaluation ledger (``rfidnav_experiments.evaluation``):

  - EVALUATION: three floors of new layouts, ``generated_SEED`` for the ledger's three drawn seeds
    (``current("topological").seeds``), each drawn by ``rfidnav_sim.floor_generator`` from its seed and built by
    ``rfidnav_sim.building``; each floor's missions are drawn from the same seed. Nobody looked at them while
    designing; they are the result, per floor and pooled.
  - DEVELOPMENT, reported beside with fewer missions: ``building_eval`` (hand-drawn, seed 1001: the odometry gate
    was written after looking at six of its missions), ``building_ring`` (generated, seed 1802: three executor
    faults were fixed on it), ``building_large`` (the floor the stack was developed on, seed 7, at two rates).

  Every floor, miss rate and method faces the same missions with the same sensor and odometry draws (paired).
  "paper" is the paper's loop on the paper's knowledge: routes by fewest hallways (the paper's robot knows no
  lengths) and no recovery from a missed tag (it follows on until the next tag re-localizes it). "ours" routes
  by the map's lengths and carries the route's expectation through a junction passed without its tag, gated by
  the odometry distance (mission_executor). Both use our wall follower, the simulated base (walls stop it: a
  bump is counted) with drifting odometry, sonar with specular loss, and stop at the goal junction's centre.

Success: the executor arrived and the robot stopped within 0.5 m of the goal node (``GOAL_RADIUS_M``); every
rate with its 95 % Wilson interval, and beside it the success within 0.25, 0.5, 0.75 and 1.0 m of the same
missions. Path over shortest: ground-truth path length over the shortest path on the map (by length) from the
start, mean over the successful missions with its 95 % t-interval. The paired difference (ours minus the paper's
loop, mission by mission) of success and of mission time with its 95 % interval. Every failed evaluation mission
is put in one class of :func:`failure_cause` (what the run recorded: where it stopped, whether it stopped, the
bumper, the executor's belief), counted per method, with how many of them had missed a tag.

Nothing here asserts the targets: the command reports, the person reads. The exit code is 0 when ours meets the
evaluation's targets (pooled over the evaluation floors: >= 95 % success at 20 % misses, path <= 1.15 x
shortest), else 1.

The package by concern: ``conditions`` (the floors, rates, counts and every setting's source), ``jobs`` (the
missions as engine tasks), ``summary`` (the figures of a setting's missions, the failure causes), ``report`` (the
text tables and the JSON rows) and ``plots``; this module runs them in turn.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.topological.conditions import (
    CHUNK,
    DEVELOPMENT_FLOORS,
    EVALUATION,
    EVALUATION_FLOORS,
    EVALUATION_SET,
    EXPERIMENT,
    FLOOR_ORDER,
    HAND_DRAWN,
    HISTORY,
    LARGE,
    MISS_RATES,
    MISSIONS,
    PAPER_RUN_SEED,
    POOLED,
    RADII_M,
    RATES,
    RING,
    ROLES,
    SEEDS,
    SOURCES,
    conditions,
    missions_on,
)
from rfidnav_experiments.reproduce.topological.jobs import mission_jobs, missions_chunk, run_all, with_pooled
from rfidnav_experiments.reproduce.topological.plots import plot_summaries, write_floors
from rfidnav_experiments.reproduce.topological.report import json_rows, report_lines
from rfidnav_experiments.reproduce.topological.summary import (
    CAUSES,
    CROSSED_WALL,
    DRIVING,
    FAR_FROM_GOAL,
    GAVE_UP,
    HELD_AT_WALL,
    LOST,
    NEAR_GOAL,
    STANDING,
    WRONG_JUNCTION,
    RateSummary,
    failure_cause,
    failure_counts,
    summarise,
    target_met,
)
from rfidnav_experiments.runners.topological import METHODS, paper_run

# The names the tests and the benchmarks use, kept where they were before the module became a package.
__all__ = ["CAUSES", "CHUNK", "CROSSED_WALL", "DEVELOPMENT_FLOORS", "DRIVING", "EVALUATION", "EVALUATION_FLOORS",
           "EVALUATION_SET", "EXPERIMENT", "FAR_FROM_GOAL", "FLOOR_ORDER", "GAVE_UP", "HAND_DRAWN", "HELD_AT_WALL",
           "HISTORY", "LARGE", "LOST", "METHODS", "MISSIONS", "MISS_RATES", "NEAR_GOAL", "POOLED", "RADII_M",
           "RATES", "RING", "ROLES", "SEEDS", "SOURCES", "STANDING", "WRONG_JUNCTION", "RateSummary",
           "conditions", "failure_cause", "failure_counts", "mission_jobs", "missions_chunk", "missions_on",
           "reproduce_topological", "run_all", "summarise", "target_met", "with_pooled"]


def reproduce_topological(missions: int, out_dir: Path, as_json: bool) -> int:
    """Run, report and plot; 0 when ours meets the evaluation's target, else 1."""
    if missions < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {missions}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    condition_rows = conditions(missions)
    paper = paper_run(np.random.default_rng(PAPER_RUN_SEED))
    results = with_pooled(run_all(missions))
    summaries = [summarise(floor, method, rate, results[(floor, method, rate)])
                 for floor in (POOLED, *FLOOR_ORDER) for method in METHODS
                 for rate in (MISS_RATES if floor == POOLED else RATES[floor])]
    rows = json_rows(paper, summaries, results, condition_rows)
    (out_dir / "topological_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_summaries(summaries, out_dir)
    floors = write_floors(out_dir)
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join(report_lines(paper, summaries, results, condition_rows)))
    print(f"plot: {plot}; rows: {out_dir / 'topological_rows.json'}; evaluation floors: {floors}", file=notes)
    return 0 if target_met(summaries) else 1

