"""reproduce fused: the worlds, the localizers and the runs' own settings, and what each world runs (its driver, its
rfid_localizer and reader files, its late start and kidnap)."""

from __future__ import annotations

from pathlib import Path

from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.two_tier import HOMES, home
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario

EXPERIMENT = "fused"
RUNS = 10
DEVELOPMENT_SEED = 1
EVALUATION = evaluation.current(EXPERIMENT)   # the ledger's one evaluation set of this reproduction...
EVALUATION_SEED = EVALUATION.seeds[0]         # ...its seed: what the command reports, never used to tune
MIXED = "mixed_floor"
PARTITIONS = "partition_field"
RING = "building_ring"
HALLWAY = "hallway"
DRIVING = "mixed_floor_fused"      # the fused pose drives the robot (pose_navigator), in-process
PARTITION_DRIVING = "partition_field_fused"   # the fused pose drives paper 000's partition navigator
TIER_ONE = tuple(f"{name}_fused" for name in HOMES)   # paper 003's navigator takes tier one from the fused pose
DRIVING_WORLDS = (*TIER_ONE, PARTITION_DRIVING, DRIVING)   # the fused pose in the loop (none kidnapped nor late)
WORLDS = (*HOMES, MIXED, PARTITIONS, RING, HALLWAY, *DRIVING_WORLDS)
# Their figures include arrival and the true final error: the paper's navigators on their own localizers, and each
# navigator with the fused localizer in the loop, on the same missions.
ARRIVING_WORLDS = (*HOMES, PARTITIONS, *DRIVING_WORLDS)
UHF_2ANT_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_uhf_2ant.yaml"
WALL_SIDE_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_wall_side.yaml"
# Paper 000: the partition navigator with the paper's localizer drives tasks of this length across the field (the
# scenario's world, r = 20 cm), with this much relative odometry noise (the fused filter's motion model needs
# some; the paper's simulated motion is exact).
PARTITION_TASK_M = 3.0
PARTITION_ODOMETRY_NOISE = 0.02
FLOOR_LATTICE_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_floor_lattice.yaml"
# Paper 003's robot: its rfid_localizer file where the scenario runs none (the homes).
HF_FLOOR_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_hf_floor.yaml"
SINGLE_EVIDENCE = {"floor_only": ("floor", "compass"), "phase_only": ("phase", "compass"),
                   "wall_only": ("wall", "compass"), "wifi_only": ("wifi", "compass")}
KIDNAP_AT_S = 30.0
PARTITION_KIDNAP_AT_S = 5.0        # a 3 m task takes ~20 s
PARTITION_LATE_START_S = 3.0
LATE_START_S = 20.0        # a second global localization, out of the start's room (a mission takes 50-250 s)
NEES_BAND = 0.95


def localizer_file(world: str) -> Path:
    """The rfid_localizer file a world's fused localizers are set from."""
    if world in (PARTITIONS, PARTITION_DRIVING):
        return FLOOR_LATTICE_LOCALIZER
    if world == RING:
        return WALL_SIDE_LOCALIZER
    if world == HALLWAY:
        return UHF_2ANT_LOCALIZER
    spec = home(world).scenario.nodes.get("rfid_localizer")
    return spec.param_files[0] if spec is not None else HF_FLOOR_LOCALIZER


def reader_file(world: str) -> Path | None:
    """The reader file a world's runs read through (None: its runner's own read model)."""
    if world in (PARTITIONS, PARTITION_DRIVING, RING):
        return None
    return load_scenario(world).nodes["rfid_reader"].param_files[0]


def driver_of(world: str) -> str:
    if world == DRIVING:
        return "pose_navigator driving on the fused localizer's pose: no other localizer, no kidnap, no late start"
    if world == PARTITION_DRIVING:
        return ("the partition navigator driving on the fused localizer (its settings for a pose estimate) on "
                f"{PARTITIONS}'s tasks, paper 000's localizer beside: no kidnap, no late start")
    if world in TIER_ONE:
        return ("the two-tier navigator with tier one from the fused localizer's pose, on the mission of "
                f"{world.removesuffix('_fused')}; 'paper' is its dead reckoning between fixes: no kidnap, no late "
                "start")
    if world == HALLWAY:
        return ("paper 001's tag route follower driving; it keeps no pose, so its 'paper' pose is the wheel "
                "odometry from the known start")
    if world == RING:
        return "paper 004's mission executor driving; its 'paper' position is the node it believes it is at"
    return ("the partition navigator driving with paper 000's localizer" if world == PARTITIONS
            else "the two-tier navigator driving with paper 003's localizer")


def kidnap_times_of(world: str) -> tuple[float, float]:
    """(late start, kidnap) [s] of the world's runs (none where the fused pose drives)."""
    return (PARTITION_LATE_START_S, PARTITION_KIDNAP_AT_S) if world == PARTITIONS else (LATE_START_S, KIDNAP_AT_S)


def localizers_of(world: str) -> tuple[str, ...]:
    if world == DRIVING:
        return ("fused",)
    return ("fused", *(SINGLE_EVIDENCE if world == MIXED else ()), "paper")
