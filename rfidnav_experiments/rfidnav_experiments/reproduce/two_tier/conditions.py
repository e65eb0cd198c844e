"""reproduce two_tier: the experiment's settings (its seeds, files, Fig. 10's cross, distances and placements, the
sensitivity's variants, the routes, the survey and the homes), the two spiral searches and the reader's delay read
two ways. Where each comes from: :mod:`.provenance`."""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.polling import Polling
from rfidnav_control.spiral import separation_for_group
from rfidnav_experiments import evaluation
from rfidnav_experiments.runners.two_tier import FLOOR_READER, SETTINGS
from rfidnav_planning.two_tier_survey import SURVEY_SPACING_M
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.parameters import ReaderParameters

EXPERIMENT = "two_tier"
METHODS = ("paper", "ours")
PAPER, OURS = METHODS
DEVELOPMENT_SEED = 1                    # every figure looked at while the code and its settings were chosen
EVALUATION = evaluation.current(EXPERIMENT)   # the ledger's one evaluation set of this reproduction...
EVALUATION_SEED = EVALUATION.seeds[0]         # ...its seed: what the command reports, never used to tune

WORLD_FILE = CONFIG_DIR / "worlds" / "two_tier_home.yaml"
MAP_FILE = CONFIG_DIR / "maps" / "two_tier_home.yaml"       # the landmarks as the robot knows them: its goals

FIG10_SIZE_M = 0.29                     # paper 003 sec. 4.2: a 29 x 29 cm cross
FIG10_DISTANCES_M = tuple(round(0.1 * k, 1) for k in range(11))
FIG10_RUNS = 200
FIG10_BEYOND_M = 0.5                    # a search ends this far beyond the group's distance: its turns have passed it
PAPER_FIG10_M = {0.4: 1.20, 0.5: 3.00}  # sec. 4.2: ~120 cm within 40 cm, a jump to ~300 cm beyond
# Fig. 10's sensitivity, on the same placements: the initial distance measured to the group's centre (the main
# figure) or to its nearest tag; and the reader's 500-600 ms taken as the time between two polls (the main figure:
# the tags read where the reply comes) or as the latency of each result of a reader polled at its base rate (the
# tags read where the poll was, the robot told 500-600 ms later, having driven on).
CENTRE, NEAREST = DISTANCES_TO = ("group_centre", "nearest_tag")
PERIOD, LATENCY = DELAYS = ("period", "latency")
LATENCY_POLL_RATE_HZ = ReaderParameters().rate_hz      # the reader's base rate: its parameter's default
Variant = tuple[str, str]                 # (distance_to, delay)
SENSITIVITY_VARIANTS: tuple[Variant, ...] = ((NEAREST, PERIOD), (CENTRE, LATENCY), (NEAREST, LATENCY))
MAIN_VARIANT: Variant = (CENTRE, PERIOD)  # the main figure's
THEOREM_SIGMAS_M = (0.25, 0.5, 1.0)
ROUTES = {"route 1": ((1.0, 1.0, 0.3), ("T1", "T2", "T3", "T4", "T5")),
          "route 2": ((1.5, 2.0, 1.2), ("R1", "R2", "R3"))}
# West to east through the door in x = 6 (y 3.0-4.2): the straight line the direct run drives meets no wall
# (the walls stop the robot; the old route along y = 1 drove through the x = 6 wall).
LONG_ROUTE = ((1.0, 3.6, 0.0), (11.0, 3.6))
FIG11_SPACINGS_M = {"direct": 0.1, "indirect": 4.0}    # geographic forwarding's reach: no landmark helps at 0.1 m
GRID_SPACING_M = 1.0
GRID_SCANS_PER_POINT = 3
ROBOT_SURVEY_SPACING_M = SURVEY_SPACING_M   # the robot's own survey: a scan this often while fresh from a fix
TEST_POINTS = 300
TARGET_FIX_ERROR_M = 0.03               # ours: median tag-fix error at the turning points
HOMES = ("two_tier_home", "two_tier_flat", "two_tier_corridor")    # scenarios: start, goal, world, map, radio map
LEGS = {"straight": "the paper's: straight to each landmark", "planned": "ours: round the map's walls"}


def floor_range_m() -> float:
    """The reader's range on the floor: its 5 cm antenna range less the antenna's height above the tags."""
    height = FLOOR_READER.antenna_positions[2]
    return math.sqrt(FLOOR_READER.antenna_max_range_m[0] ** 2 - height ** 2)


@dataclass(frozen=True)
class SpiralMethod:
    d_m: float
    speed_mps: float


def spiral_methods() -> dict[str, SpiralMethod]:
    """The paper's search (d = L / pi^2, at the robot's driving speed: the paper gives no other) and ours, the
    navigator's (the band the reader reads around the cross crossed, at its search speed)."""
    return {PAPER: SpiralMethod(separation_for_group("cross", FIG10_SIZE_M), SETTINGS.go_to.speed_mps),
            OURS: SpiralMethod(separation_for_group("cross", FIG10_SIZE_M, SETTINGS.read_range_m),
                               SETTINGS.search_speed_mps)}


def latency_polling() -> Polling:
    """The reader polled at its base rate (ReaderParameters' default rate_hz), failing as the floor reader does."""
    return Polling(1.0 / LATENCY_POLL_RATE_HZ, 0.0, FLOOR_READER.round_failure_probability)


def delay_text(delay: str) -> str:
    polling = FLOOR_READER.polling()
    delay_ms = f"{polling.interval_s * 1000:.0f}-{polling.max_interval_s * 1000:.0f} ms"
    if delay == PERIOD:
        return f"a poll every {delay_ms}, the tags read where its reply comes"
    return (f"a poll every {latency_polling().interval_s * 1000:.0f} ms, each result {delay_ms} late (the robot "
            "drives on meanwhile)")
