"""``./rfidnav reproduce fused``: the fused localizer (rfidnav_localization.fused) beside each paper's own
localizer, on the same runs, paired.

Worlds: paper 003's homes (HOMES of reproduce two_tier: the in-tree flat and two of ours), the mixed floor (ours:
every kind of tag on one floor), paper 000's field, paper 004's ring and paper 001's hallway. On the homes and the
mixed floor each run is the two-tier navigator's mission from the scenario's start to its goal, its legs planned
round the map's walls, driven by the paper's localizer (WiFi fingerprints, then floor tag groups, dead reckoning
between) with the scenario's reader; the fused localizers ride beside it on what the same sensors gave in each
reader round (every antenna's reads, the location server's answers to the navigator's locate calls, the compass, the
odometry). On paper 000's field (``partition_field``) each run is a 3 m task of the partition navigator on the
paper's localizer, the fused localizers beside it on the same rounds (its robot has no compass and no WiFi). On
paper 004's ring (``building_ring``) each run is one of the mission executor's missions, the fused localizers beside
it on the side antenna's wall tags and the odometry, scored with the node the executor believes the robot is at. On
paper 001's hallway (Figs. 12/13) each run is the tag route follower's whole route under the seven ceiling tags, the
fused localizers beside it on the two receiving antennas' phases, the floor tags under the ceiling tags and the
odometry; the follower keeps no pose, so the robot's own idea of where it is, scored as the paper's, is its odometry
from the known start. Two worlds where the fused localizer drives: ``partition_field_fused``, the same tasks as paper
000's field, the partition navigator driving on the fused estimate (rfid_localizer's status, through the same
conversions as over DDS: runners.fused.FusedPartitions) with its settings for a pose estimate, paper 000's localizer
beside; and ``mixed_floor_fused``, pose_navigator driving on it across the mixed floor. The fused settings are
those of the robot's rfid_localizer parameter file (the filter's the same for every robot and world). Every fused
localizer starts, as the paper's does, knowing only the map: global localization from its first evidence.

Localizers: ``fused`` (every kind of evidence), on the mixed floor also the same filter given one kind of evidence
and the compass (``floor_only``: lattice and tag-group reads, paper 000's and 003's tier two; ``phase_only``:
ceiling tags, paper 001; ``wall_only``: wall tags, paper 004; ``wifi_only``: paper 003's tier one), and ``paper``
(the two-tier navigator's own estimate). A ``kidnap`` run of the fused filter is told at KIDNAP_AT_S, confidently,
that the robot stands half the floor away in x and in y, facing the other way (a wrong /initialpose:
runners.fused.kidnapped); the figures give how long it takes to find the robot again. A ``late`` one starts at
LATE_START_S, mid-mission, with no idea where the robot is (a second global localization, away from the start).

Per run and localizer: the position and heading RMSE over the rounds it had an estimate, the fix rate (the share
of rounds it had one), the share of rounds whose NEES lies in its two-sided 95 % chi-square band (consistency);
the time global localization took (error below 0.5 m for 5 s, from the start) and the kidnap's recovery time (the
same, from the kidnap). A localizer that reports a heading only some of the time (paper 000's, after a straight
stretch) is also set beside the others on its own rounds: the heading RMSE over the rounds the paper had one. Per
world: means with 95 % intervals over the runs, and the paired difference of each localizer less the fused one.

The conditions first (:func:`conditions`): every physical setting of the runs with where it comes from, read from
the parameter objects the runs use: the fused filter of each robot's rfid_localizer file (one column per robot), the
readers the runs read through (one column per reader file, each field's source per reader), paper 003's navigator,
sensors, matcher and base as reproduce two_tier lists them, pose_navigator's, what each world runs, and the
experiment's own settings.

Development and evaluation apart: the code and its settings were chosen on DEVELOPMENT_SEED; the command reports
EVALUATION_SEED, the seed of the evaluation set the ledger (rfidnav_experiments.evaluation) holds for fused, never
used to tune anything (seed 401, reported before issue 31, is a development set since a model change was made after
its figures were seen). The report and the conditions' ``runs.seed`` row say which set the seed belongs to.

With ``--json`` (and always in ``fused_rows.json``) the rows ``{"experiment", "setting", "metric", "ours",
"paper"}``, the conditions first (metric "condition"); each figure's setting names its ``world`` and ``localizer``
(``fused``, a single kind, ``paper``, or a paired difference ``NAME-fused``), the seed and the runs; "paper" is null
(no paper reports these figures).

The package by concern: ``conditions`` (the worlds, localizers and the runs' settings), ``provenance`` (where every
setting comes from: the conditions table), ``riders`` (the localizers of a run and what they read), ``jobs`` (the
runs as engine tasks), ``summary`` (the figures of a run and of a world's runs), ``report`` (the text tables) and
``rows`` (the JSON rows); this module runs them in turn.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path

from rfidnav_common.errors import ConfigError
from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.fused.conditions import (
    DEVELOPMENT_SEED,
    EVALUATION,
    EVALUATION_SEED,
    EXPERIMENT,
    WORLDS,
)
from rfidnav_experiments.reproduce.fused.jobs import fused_runs
from rfidnav_experiments.reproduce.fused.provenance import all_condition_rows, conditions
from rfidnav_experiments.reproduce.fused.report import conditions_report, report_lines
from rfidnav_experiments.reproduce.fused.rows import json_rows


def reproduce_fused(runs: int, out_dir: Path, as_json: bool, seed: int = EVALUATION_SEED,
                    worlds: Sequence[str] = WORLDS) -> int:
    """Run and report ``runs`` runs of each of ``worlds`` (all by default; fewer for a quick subset)."""
    if runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {runs}")
    unknown = [world for world in worlds if world not in WORLDS]
    if unknown or not worlds:
        raise ConfigError("worlds", "", f"expected some of {', '.join(WORLDS)}, got {list(worlds)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    parts = conditions(seed, runs)
    results = fused_runs(runs, seed, worlds)
    rows = json_rows(results, seed, all_condition_rows(parts))
    (out_dir / "fused_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        which = evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)
        print("\n".join([f"reproduce fused: seed {seed}: {which} (the "
                          f"ledger's evaluation set is '{EVALUATION.name}', seed {EVALUATION_SEED}; development seed "
                          f"{DEVELOPMENT_SEED})", "", *conditions_report(parts), *report_lines(results, runs)]))
    print(f"rows: {out_dir / 'fused_rows.json'}", file=sys.stderr if as_json else sys.stdout)
    return 0
