"""Every reproduction's evaluation sets, declared in one place, with their ledger.

An evaluation set (seeds, floors, homes, routes) is used once: it is reported, and a design change made after its
figures were looked at turns it into a development set. A fresh set is then drawn by a recorded rule that nobody
can steer: :func:`drawn_seed` hashes the experiment, the set's name and the day it was drawn. The reproductions take
their sets from :data:`LEDGER` (``current(experiment)``) and nothing else; ``docs/results/evaluation-ledger.md`` is
rendered from it (``./rfidnav reproduce all`` writes it, ``test_results.py`` checks it is current).

Pure: no rclpy, no simulation.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from typing import Any, Literal

Status = Literal["evaluation", "development"]

SEED_RANGE = (10_000, 1_000_000)        # drawn seeds never collide with the hand-chosen ones (1-2000)


def drawn_seed(experiment: str, name: str, drawn_on: str) -> int:
    """The recorded rule: a seed from SHA-256 of ``experiment/name/date`` (ISO date), in :data:`SEED_RANGE`.

    Anyone can recompute it; nobody chose it."""
    digest = hashlib.sha256(f"rfidnav/{experiment}/{name}/{drawn_on}".encode()).digest()
    low, high = SEED_RANGE
    return low + int.from_bytes(digest[:8], "big") % (high - low)


@dataclass(frozen=True)
class EvaluationSet:
    """One set of an experiment: what it holds, its status and its history."""
    experiment: str                     # the reproduction (``reproduce NAME``)
    name: str                           # how the docs and rows call it
    holds: str                          # what the set is, in words: seeds, floors, homes, routes
    seeds: tuple[int, ...]              # the seeds (of missions, placements, routes) the set consists of
    status: Status
    first_reported: str                 # the commit (and date) that first reported figures on it
    drawn_by: str                       # how it was chosen: by hand, or the rule with its inputs
    looked_at_then_changed: tuple[str, ...] = field(default=())   # design changes made after its figures were seen
    replaced_by: str = ""               # the fresh set drawn when it became development
    drawn_on: str = ""                  # the day a drawn set was drawn (drawn_seed's date); "" when chosen by hand


DRAWN_ON = "2026-12-04"                 # the day issue 31's fresh sets were drawn
REDRAWN_ON = "2026-12-06"               # the day issue 32's were
THIRD_DRAWN_ON = "2026-12-07"           # the day issue 34's tracking metric made flc's drawn again


def _drawn(experiment: str, name: str, holds: str, count: int = 1, drawn_on: str = DRAWN_ON,
           first_reported: str = "issue 31 (this ledger's first report)", status: Status = "evaluation",
           looked_at_then_changed: tuple[str, ...] = (), replaced_by: str = "") -> EvaluationSet:
    seeds = tuple(drawn_seed(experiment, f"{name}#{k}" if count > 1 else name, drawn_on) for k in range(count))
    return EvaluationSet(experiment, name, holds, seeds, status, first_reported,
                         f"drawn_seed({experiment!r}, {name!r}{', #k' if count > 1 else ''}, {drawn_on!r})",
                         looked_at_then_changed, replaced_by, drawn_on)


LEDGER: tuple[EvaluationSet, ...] = (
    # paper 001: the baseline is calibrated on seeds 1-8 of the lines; the routes were reported on 101-110
    EvaluationSet("flc", "paper routes, seeds 101-110", "paper 001's four routes (two lines, the acute path, the "
                  "hallway), seeds 101-110", tuple(range(101, 111)), "development",
                  "09c204a (2026-12-01)", "by hand",
                  ("flc_tuned was developed with reproduce flc on all four routes",),
                  "flc random routes"),
    _drawn("flc", "flc random routes", "seeded random routes of ceiling tags, turns 20-150 degrees, legs 2-12 m, "
           "neither controller developed on them", count=10, status="development",
           looked_at_then_changed=("calibrate flc, rerun on a machine without AVX-512 whose arithmetic differs in the "
                                   "last bits (issue 32), chose other open settings: phase noise 0.085 rad/m and "
                                   "output scale 2 for 0.07 and 3",), replaced_by="flc random routes, drawn again"),
    _drawn("flc", "flc random routes, drawn again", "seeded random routes of ceiling tags, turns 20-150 degrees, legs "
           "2-12 m, neither controller developed on them", count=10, drawn_on=REDRAWN_ON,
           first_reported="issue 32", status="development",
           looked_at_then_changed=("the tracking RMSE (issue 34) was made to leave out the searches for an unheard "
                                   "tag, then also the way back from where each ended, after this set's figures under "
                                   "the first rule were seen (paired difference +23.07 +- 23.67 cm; under the second "
                                   "-4.91 +- 3.85)",),
           replaced_by="flc random routes, drawn a third time"),
    _drawn("flc", "flc random routes, drawn a third time", "seeded random routes of ceiling tags, turns 20-150 "
           "degrees, legs 2-12 m, neither controller developed on them", count=10, drawn_on=THIRD_DRAWN_ON,
           first_reported="issue 34"),
    # paper 000
    EvaluationSet("partitions", "tasks of seed 101", "paper 000's random navigation tasks and streams of seed 101",
                  (101,), "evaluation", "5761d6e (2026-12-01)", "by hand",
                  (), ""),
    # paper 003
    EvaluationSet("two_tier", "seed 301", "paper 003's placements, routes and homes' streams of seed 301", (301,),
                  "development", "b090752 (2026-12-01)", "by hand",
                  ("29/160 stalled legs seen, then the navigator was redesigned (planned legs, stall back-off) and the "
                   "same seed re-reported as 160/160",), "two_tier fresh seed"),
    _drawn("two_tier", "two_tier fresh seed", "paper 003's placements, routes and homes' streams of a drawn seed"),
    # paper 004
    EvaluationSet("topological", "building_eval, seed 1001", "the hand-drawn evaluation floor's missions of seed 1001",
                  (1001,), "development", "fc1febb (2026-12-01)", "by hand",
                  ("the odometry gate was written after looking at six evaluation-floor missions",),
                  "topological fresh floors"),
    EvaluationSet("topological", "building_ring, seed 1802", "the generated ring's missions of seed 1802", (1802,),
                  "development", "3c4c546 (2026-12-02)", "by hand",
                  ("three executor faults were fixed on it",), "topological fresh floors"),
    _drawn("topological", "topological fresh floors", "floors of new layouts from a seeded generator, and their "
           "missions, nobody has looked at", count=3),
    # ours: the fused localizer
    EvaluationSet("fused", "seed 401", "the fused localizer's worlds' runs of seed 401", (401,), "development",
                  "46d4e32 (2026-12-03)", "by hand",
                  ("NEES went from 89.7 % (missed) to 90.1 % (met) on it after a model change",), "fused fresh seed"),
    _drawn("fused", "fused fresh seed", "the fused localizer's worlds' runs of a drawn seed", status="development",
           looked_at_then_changed=("the simulation rig (issue 32) puts the in-process WiFi scans on the step grid, as "
                                   "wifi_sim's over DDS, where a running sum of the steps made some one step late",),
           replaced_by="fused fresh seed, drawn again"),
    _drawn("fused", "fused fresh seed, drawn again", "the fused localizer's worlds' runs of a drawn seed",
           drawn_on=REDRAWN_ON, first_reported="issue 32"),
)


def current(experiment: str) -> EvaluationSet:
    """The experiment's one evaluation set (what its reproduction reports)."""
    sets = [entry for entry in LEDGER if entry.experiment == experiment and entry.status == "evaluation"]
    if len(sets) != 1:
        raise LookupError(f"{experiment}: {len(sets)} evaluation sets in the ledger, expected one")
    return sets[0]


def seed_set(experiment: str, seed: int, development_seed: int) -> str:
    """Which set ``seed`` is of ``experiment``'s, in words: a set of the ledger, or the development seed."""
    for entry in LEDGER:
        if entry.experiment == experiment and seed in entry.seeds:
            return f"{entry.status} set '{entry.name}'"
    if seed == development_seed:
        return "the development seed: the code and its settings were chosen on it"
    return "a seed in no set of the ledger"


def evaluation_set_dict(experiment: str) -> dict[str, Any] | None:
    """The experiment's evaluation set as a results file records it (JSON's lists for tuples)."""
    try:
        return json.loads(json.dumps(dataclasses.asdict(current(experiment))))
    except LookupError:
        return None


def ledger_markdown() -> str:
    """docs/results/evaluation-ledger.md: every set with its status and history."""
    lines = ["# Evaluation ledger", "",
             "Rendered from `rfidnav_experiments/evaluation.py` by `./rfidnav reproduce all` (a test checks it is "
             "current). An evaluation set is reported once; a design change made after its figures were looked at "
             "makes it a development set, and a fresh one is drawn by the recorded rule "
             "(`drawn_seed`: SHA-256 of experiment/name/date).", "",
             "| experiment | set | holds | seeds | status | first reported | drawn by | changed after looking | "
             "replaced by |", "|---|---|---|---|---|---|---|---|---|"]
    for entry in LEDGER:
        seeds = ", ".join(map(str, entry.seeds)) if len(entry.seeds) <= 3 else \
            f"{entry.seeds[0]}, ... ({len(entry.seeds)})"
        lines.append(f"| {entry.experiment} | {entry.name} | {entry.holds} | {seeds} | {entry.status} | "
                     f"{entry.first_reported} | {entry.drawn_by} | {'; '.join(entry.looked_at_then_changed) or '-'} | "
                     f"{entry.replaced_by or '-'} |")
    return "\n".join(lines) + "\n"
