"""``./rfidnav reproduce two_tier``: paper 003 section 4.2, in-process, beside the paper's figures.

Every run reads the floor tags through the HF reader of config/params/reader_hf_floor.yaml, the rfid_reader_sim
node's over DDS: polled every 500-600 ms (paper 003 sec. 4.1), one poll in ten failing (ours), so a tag the
robot passes between two polls is never read and a fix is known only when a poll reads it.

* The conditions first: every physical setting that shapes the figures, with where it comes from (``paper``
  and the section, or ``ours`` and why; nothing is calibrated: the paper's first experiment, Fig. 10, needs no
  fitted setting), for the paper's method and ours.
* Fig. 10: spiral search distance against the robot's initial distance from a 29 x 29 cm cross, the paper's
  search (d = L / pi^2, at the robot's speed) and ours (d widened by the reader's range on both sides, at the
  navigator's search speed) on the SAME placements (seed -> bearing, group rotation, start heading, the
  reader's polls and failures), each point with its n and 95 % interval, the paired difference with its
  interval, and the paper's two figures at its distances: about 120 cm at 40 cm ("less than 40 cm: no more
  than one spiral"), about 300 cm at 50 cm ("larger than 40 cm: two spirals"). Its sensitivity, on the same
  placements: the initial distance measured to the group's centre or to its nearest tag (the paper does not say),
  and the reader's 500-600 ms taken as the time between two polls (the main figure) or as the latency of each
  result of a reader polled at its base rate. Beside it Theorem 1 against simulated searches from a Gaussian
  start, with the continuous reader the theorem assumes.
* Fig. 11: direct moving (dead reckoning all the way) against indirect moving (through intermediate landmarks
  by geographic forwarding): the accumulated error at the target.
* Fig. 12: at each turning point of two routes, the error of WiFi fingerprinting alone against the two-tier
  scheme (tier one, then the landmark, a spiral search if needed, the tag fix): ours, and the same polls taken
  the paper's way (the position of the tags read), paired. Our target: the median tag-fix error at the turning
  points at most 3 cm with the reader's delay and failures, reported met or not met, never tuned to.
* The radio map: a site survey on a 1 m grid against the robot's own survey (fingerprints at its tier-two
  fixes, paper 003's automatic radio map construction): the tier-one error at random points.
* Homes (ours): each two-tier scenario of HOMES (the in-tree flat and two flats of ours whose origin is at their
  centre) run in-process from its start to its goal, with the radio map its map names (the location server's
  over DDS), its legs straight as the paper drives them or planned round the map's walls, on the same streams:
  how many arrive, the final error, the path length and the steps the walls stopped (bumps).

Development and evaluation apart: every random draw comes from ``rng_for(seed, stream)``. The code was developed
and its settings chosen on DEVELOPMENT_SEED; the command reports EVALUATION_SEED, the seed of the evaluation set
the ledger (rfidnav_experiments.evaluation) holds for two_tier, never used to tune anything; seed 301, the set
reported before issue 31, is a development set since the navigator was redesigned after its figures were seen.
The report and the conditions' ``runs.seed`` row say which set the seed belongs to.

With ``--json`` the rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (DESIGN.md), the conditions
first; where the paper gives no number "paper" is null. Plots: ``two_tier_figs10_12.png`` in the output folder.

The package by concern: ``conditions`` (the settings, the spiral searches, the reader's delay), ``provenance`` (where
every setting comes from, the conditions table), ``searches`` (Fig. 10 and Theorem 1's spiral searches as engine
tasks), ``navigations`` (Figs. 11, 12 and the homes' navigations as engine tasks, tier one's error), ``summary``
(medians, intervals, the tag fixes, a home's figures), ``report`` (the text tables), ``rows`` (the JSON rows) and
``plots``; this module runs them in turn.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import load_route_map
from rfidnav_experiments.reproduce.two_tier.conditions import (
    CENTRE,
    DELAYS,
    DEVELOPMENT_SEED,
    DISTANCES_TO,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG10_DISTANCES_M,
    FIG10_RUNS,
    FIG10_SIZE_M,
    HOMES,
    LATENCY,
    LEGS,
    MAP_FILE,
    METHODS,
    NEAREST,
    OURS,
    PAPER_FIG10_M,
    ROBOT_SURVEY_SPACING_M,
    SENSITIVITY_VARIANTS,
    WORLD_FILE,
    spiral_methods,
)
from rfidnav_experiments.reproduce.two_tier.navigations import (
    Home,
    fig11,
    fig12,
    grid_site,
    home,
    home_run,
    homes,
    tier_one_errors,
)
from rfidnav_experiments.reproduce.two_tier.plots import plot_figures
from rfidnav_experiments.reproduce.two_tier.provenance import (
    METHOD_SOURCES,
    NOT_READ,
    READER_SOURCES,
    SOURCES,
    conditions,
)
from rfidnav_experiments.reproduce.two_tier.report import home_lines, report_lines
from rfidnav_experiments.reproduce.two_tier.rows import home_json_rows, json_rows, sensitivity_json_rows
from rfidnav_experiments.reproduce.two_tier.searches import fig10, fig10_placement, fig10_sensitivity, theorem1
from rfidnav_experiments.reproduce.two_tier.summary import Crossings, fix_figures
from rfidnav_experiments.runners.two_tier import Site, robot_survey
from rfidnav_localization.fingerprint import RadioMap
from rfidnav_sim.world import load_world

# The names the tests and reproduce fused use, kept where they were before the module became a package.
__all__ = ["CENTRE", "DELAYS", "DEVELOPMENT_SEED", "DISTANCES_TO", "EVALUATION_SEED", "EXPERIMENT",
           "FIG10_DISTANCES_M", "FIG10_SIZE_M", "HOMES", "LATENCY", "LEGS", "METHODS", "METHOD_SOURCES", "NEAREST",
           "NOT_READ", "OURS", "PAPER_FIG10_M", "READER_SOURCES", "SENSITIVITY_VARIANTS", "SOURCES", "Home",
           "conditions", "fig10", "fig10_placement", "fig10_sensitivity", "home", "home_run", "reproduce_two_tier",
           "spiral_methods"]


def reproduce_two_tier(runs: int, out_dir: Path, as_json: bool, seed: int = EVALUATION_SEED,
                       fig10_runs: int = FIG10_RUNS) -> int:
    """Run, report and plot; 0 when our median tag-fix error at the turning points meets the target, else 1."""
    if runs < 1 or fig10_runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {min(runs, fig10_runs)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    world = load_world(WORLD_FILE)
    condition_rows = conditions(world, seed)
    site = grid_site(seed)
    spiral = fig10(fig10_runs, seed)
    sensitivity = fig10_sensitivity(fig10_runs, seed)
    theorem = theorem1(fig10_runs, seed)
    moving, moving_crossings = fig11(runs, seed)
    legs = fig12(runs, seed)
    fixes = fix_figures(legs)
    crossings = Crossings(2 * runs + len(legs), moving_crossings + sum(leg.wall_crossings for leg in legs))
    survey_map = RadioMap(robot_survey(Site.of(world, RadioMap()), load_route_map(MAP_FILE), seed,
                                      ROBOT_SURVEY_SPACING_M))
    radio = {"grid": tier_one_errors(site, site.radio_map, seed), "survey": tier_one_errors(site, survey_map, seed)}
    home_runs = homes(runs, seed)
    rows = [*json_rows(condition_rows, spiral, theorem, moving, legs, fixes, radio, crossings, seed),
            *sensitivity_json_rows(sensitivity, spiral, seed), *home_json_rows(home_runs, seed)]
    (out_dir / "two_tier_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_figures(spiral, moving, legs, fig10_runs, out_dir)
    # Only the JSON goes to stdout with --json, so a program can parse it whole.
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join([*report_lines(condition_rows, spiral, sensitivity, theorem, moving, legs, fixes, radio,
                                        crossings, len(site.radio_map), len(survey_map), runs, fig10_runs, seed),
                         "", *home_lines(home_runs, runs)]))
    print(f"plot: {plot}; rows: {out_dir / 'two_tier_rows.json'}", file=notes)
    return 0 if fixes.target_met else 1
