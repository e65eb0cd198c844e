"""``./rfidnav bench fused``: the fused localizer's update at sensor rate (one reader round: an odometry increment
and the round's evidence) on one core, per kind of evidence and with every kind at once, at the node's default
particle count (rfid_localizer's parameters, the shipped values).

The building: a 20 x 10 m floor with a triangular lattice of floor tags (r = 6 cm) over a 6 x 4 m part of it, a
tag group, a ceiling tag 3 m up and a wall tag on the wall along the lattice's edge, each placed so the robot's
antennas read them the way its sensors would (the reads are given, not simulated: this times the filter, not the
simulator). The particles start about the true pose (sd 10 cm), as after a fix; a compact cloud is where the
lattice and tag-group models also weigh the known tags near the robot that were not read.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from rfidnav_common.rf import round_trip_phase
from rfidnav_common.tag_groups import TagGroup
from rfidnav_common.tag_lattice import make_deployment
from rfidnav_common.wall_tags import WallTag
from rfidnav_localization.fused.filter import Evidence, PhaseReading
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.parameters import RfidLocalizerParameters

ROUNDS = 400
FREQUENCY_HZ = 915.25e6
EXTENT = (0.0, 0.0, 20.0, 10.0)
LATTICE = make_deployment("triangular", 0.06, (0.0, 0.0, 6.0, 4.0))
GROUP = TagGroup("G1", "cross", (10.0, 5.0))
CEILING_TAG = ("C1", (6.0, 3.0, 3.0))
WALL_TAG = WallTag("W1", (4.0, 4.0), (0.0, -1.0))    # on the wall along the lattice's north edge
# The robot's reader: floor antenna (port 1), the two receiving antennas 6 cm apart (2, 3), the side antenna (4).
PARAMETERS = RfidLocalizerParameters(
    map_file="(in memory)", antenna_positions=[0.0, 0.0, 0.05, 0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0, 0.30],
    antenna_phase_offset_rad=[0.0, 0.0, 0.0, 0.0], floor_antenna=1, phase_antennas=[2, 3], wall_antenna=4,
    use_wifi=True)


def fused_map() -> FusedMap:
    return FusedMap(extent=EXTENT, floor_tags=dict(GROUP.tags()), ceiling_tags=dict([CEILING_TAG]),
                    wall_tags={WALL_TAG.tag_id: WALL_TAG}, deployment_area=LATTICE.area)


def phase_reading(x: float, y: float, yaw: float) -> PhaseReading:
    """The noiseless phases of the ceiling tag on the two receiving antennas at pose (x, y, yaw)."""
    tag = np.array(CEILING_TAG[1])
    phases = []
    for port in PARAMETERS.phase_antennas:
        ax, ay, az = PARAMETERS.antenna(port)
        antenna = np.array((x + math.cos(yaw) * ax - math.sin(yaw) * ay, y + math.sin(yaw) * ax + math.cos(yaw) * ay,
                            az))
        phases.append(float(round_trip_phase(float(np.linalg.norm(tag - antenna)), FREQUENCY_HZ)))
    return PhaseReading(CEILING_TAG[0], phases[0], phases[1], FREQUENCY_HZ)


def lattice_reads(x: float, y: float) -> list[str]:
    """The lattice tags within the read range of a floor antenna at (x, y) (it sits over the robot's centre)."""
    lattice = LATTICE.lattice
    return [lattice.tag_id(c) for c in lattice.within(x, y, LATTICE.read_range_m)]


GROUP_TAG_ID, (GROUP_TAG_X, GROUP_TAG_Y) = GROUP.tags()[0]
# Kind -> where the robot drives (start x, y, heading) and what each round gives there.
CASES: dict[str, tuple[tuple[float, float, float], Callable[[float, float, float], Evidence]]] = {
    "odometry_only": ((8.0, 7.0, 0.0), lambda x, y, yaw: Evidence()),
    "compass": ((8.0, 7.0, 0.0), lambda x, y, yaw: Evidence(compass_yaw_rad=yaw)),
    "lattice": ((1.0, 2.0, 0.0), lambda x, y, yaw: Evidence(floor_tag_ids=lattice_reads(x, y))),
    "tag_group": ((GROUP_TAG_X - 0.05, GROUP_TAG_Y, 0.0), lambda x, y, yaw: Evidence(floor_tag_ids=[GROUP_TAG_ID])),
    "ceiling_phase": ((5.0, 3.0, 0.0), lambda x, y, yaw: Evidence(phase=[phase_reading(x, y, yaw)])),
    "wall_tag": ((3.95, 3.2, 0.0), lambda x, y, yaw: Evidence(wall_tag_ids=[(4, WALL_TAG.tag_id)])),
    "wifi": ((8.0, 7.0, 0.0), lambda x, y, yaw: Evidence(wifi_fix=((x + 1.0, y - 0.5), 1.5))),
    # Where the lattice, the ceiling tag and the wall tag are all in reach (the tag group is elsewhere).
    "all_kinds": ((3.95, 3.2, 0.0), lambda x, y, yaw: Evidence(
        floor_tag_ids=lattice_reads(x, y), phase=[phase_reading(x, y, yaw)],
        wall_tag_ids=[(4, WALL_TAG.tag_id)], wifi_fix=((x + 1.0, y - 0.5), 1.5), compass_yaw_rad=yaw)),
}
STEP_M = 0.012      # odometry per round: 0.3 m/s at the reader's 25 Hz


def time_case(kind: str, rounds: int, seed: int) -> list[float]:
    """Microseconds per round (odometry increment and update) over ``rounds`` rounds of one case."""
    (x0, y0, yaw), evidence_at = CASES[kind]
    localizer = FusedLocalizer(PARAMETERS.settings(), fused_map(), np.random.default_rng([seed, len(kind)]))
    localizer.on_odometry((0.0, 0.0, 0.0))
    localizer.set_pose(x0, y0, yaw, np.diag(np.square(PARAMETERS.initial_sd)))
    times = []
    for index in range(rounds):
        # Back and forth over a 10 cm stretch: the robot stays where this case's evidence is.
        offset = STEP_M * (index % 8 if index % 16 < 8 else 8 - index % 8)
        evidence = evidence_at(x0 + offset, y0, yaw)
        started = time.perf_counter()
        localizer.on_odometry((offset, 0.0, 0.0))
        localizer.on_round(evidence)
        times.append(1e6 * (time.perf_counter() - started))
    return times


def fused_benchmark(rounds: int = ROUNDS, seed: int = 1) -> dict[str, object]:
    figures: dict[str, object] = {"particles": PARAMETERS.particles, "rounds": rounds}
    for kind in CASES:
        times = time_case(kind, rounds, seed)
        times.sort()
        figures[kind] = {"median_us": statistics.median(times), "p99_us": times[int(0.99 * (len(times) - 1))],
                         "max_us": times[-1]}
    return figures


def fused_lines(figures: dict[str, object]) -> list[str]:
    lines = [f"fused localizer update (odometry + one round), {figures['particles']} particles, "
             f"{figures['rounds']} rounds per case, one core:"]
    for kind in CASES:
        case = figures[kind]
        assert isinstance(case, dict)
        lines.append(f"  {kind:14s} median {case['median_us'] / 1000:6.2f} ms  p99 {case['p99_us'] / 1000:6.2f} ms  "
                     f"max {case['max_us'] / 1000:6.2f} ms")
    return lines
