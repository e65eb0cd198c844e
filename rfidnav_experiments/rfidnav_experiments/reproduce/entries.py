"""The reproductions this package registers (setup.py's ``rfidnav.reproductions`` entry points): light records,
the modules they name are imported only when they run (rfidnav_experiments.reproduce.driver)."""

from __future__ import annotations

from rfidnav_experiments.reproduce.driver import ReproductionEntry

FLC = ReproductionEntry(
    "flc", "rfidnav_experiments.reproduce.flc", "reproduce_flc", "seeds", "--seeds", 10,
    help="paper 001 sec. V: the fuzzy heading controller's line and route experiments",
    rank=1, count_help="seeds per setting, default 10", pinned={"seeds": 1})
PARTITIONS = ReproductionEntry(
    "partitions", "rfidnav_experiments.reproduce.partitions", "reproduce_partitions", "runs", "--runs", 250,
    help="paper 000 sec. 6: navigations by partitions, Figs. 11-14",
    rank=2, count_help="runs per (read range, level, method), default 250", pinned={"runs": 5})
TWO_TIER = ReproductionEntry(
    "two_tier", "rfidnav_experiments.reproduce.two_tier", "reproduce_two_tier", "runs", "--runs", 20,
    help="paper 003 sec. 4.2: WiFi fingerprints and tag groups, Figs. 10-12",
    rank=3, count_help="runs per route, default 20", pinned={"runs": 1, "fig10_runs": 2, "seed": 1})
TOPOLOGICAL = ReproductionEntry(
    "topological", "rfidnav_experiments.reproduce.topological", "reproduce_topological", "missions", "--runs", 100,
    help="paper 004 sec. 5: topological missions under read failures",
    rank=4, count_help="missions per evaluation floor, method and miss rate, default 100 (development floors fewer)",
    pinned={"missions": 1})
FUSED = ReproductionEntry(
    "fused", "rfidnav_experiments.reproduce.fused", "reproduce_fused", "runs", "--runs", 10,
    help="ours: the fused localizer beside each paper's own localizer, same runs, paired",
    rank=5, count_help="runs per world, default 10",
    pinned={"runs": 1, "seed": 1, "worlds": ["mixed_floor", "partition_field", "partition_field_fused",
                                             "mixed_floor_fused"]})
