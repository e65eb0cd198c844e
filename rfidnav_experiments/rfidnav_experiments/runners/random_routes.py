"""Seeded random routes of ceiling tags for paper 001's reproduction: fresh routes neither controller was developed on.

flc_tuned was developed with ``reproduce flc`` on the paper's four routes, so its figures there are development
figures (issue 31). These routes are drawn from the seeds of the ledger's evaluation set
(``rfidnav_experiments.evaluation.current("flc")``), one route per seed, by a fixed rule:

* ``TAGS`` ceiling tags 3 m up (paper 001 sec. V), each with its floor arrival tag under it (sec. IV-C step 8);
* legs of 2-12 m and turns of 20-150 degrees (either way) between consecutive legs, uniform;
* the robot starts 2 m before the first tag on the first leg's line, heading along it (as the acute path starts
  on its route).

Legs longer than the reader's reach (about 9.1 m for a 3 m ceiling) leave the next tag unheard at the corner; both
parameter sets search for it (``unheard_search``). The worlds have no walls. Each route is built in-process as a
Scenario like the YAML ones (line_follow_90's nodes and parameter files, its own world, route map, start and route),
so :func:`rfidnav_experiments.runners.tag_route.run_tag_route` runs it unchanged; no files are written.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from rfidnav_common.robot_map import RouteMap
from rfidnav_common.seeding import rng_for
from rfidnav_scenario.scenario import Scenario, load_scenario
from rfidnav_sim.world import Tag, World

PREFIX = "random_route_"
TAGS = 6                                 # five legs, four turns
LEG_M = (2.0, 12.0)
TURN_DEG = (20.0, 150.0)
CEILING_M = 3.0
START_BEFORE_M = 2.0
SPEED_MPS = 0.2
BASE_SCENARIO = "line_follow_90"         # the nodes and parameter files the routes run with


def route_name(seed: int) -> str:
    return f"{PREFIX}{seed}"


def is_random_route(name: str) -> bool:
    return name.startswith(PREFIX)


def route_points(seed: int) -> np.ndarray:
    """The route's tag projections (TAGS x 2), drawn from ``seed`` by the module's rule."""
    rng = rng_for(seed, "flc random route")
    heading = float(rng.uniform(-math.pi, math.pi))
    points = [np.zeros(2)]
    for leg in range(TAGS - 1):
        if leg:
            turn = math.radians(float(rng.uniform(*TURN_DEG)))
            heading += turn if rng.random() < 0.5 else -turn
        length = float(rng.uniform(*LEG_M))
        points.append(points[-1] + length * np.array([math.cos(heading), math.sin(heading)]))
    return np.array(points)


def turns_deg(points: np.ndarray) -> list[float]:
    """The magnitude of each turn between consecutive legs [deg]."""
    legs = np.diff(points, axis=0)
    angles = np.arctan2(legs[:, 1], legs[:, 0])
    return [abs(math.degrees(math.remainder(b - a, 2.0 * math.pi))) for a, b in zip(angles, angles[1:])]


@functools.cache
def random_route(seed: int) -> Scenario:
    """The route of ``seed`` as a Scenario (cached per process, as loading the YAML ones is)."""
    base = load_scenario(BASE_SCENARIO)
    points = route_points(seed)
    ceiling = [f"R{k + 1}" for k in range(len(points))]
    floor = [f"F{k + 1}" for k in range(len(points))]
    tags = tuple([Tag(tag_id, (float(x), float(y), CEILING_M)) for tag_id, (x, y) in zip(ceiling, points)]
                 + [Tag(tag_id, (float(x), float(y), 0.0), kind="floor") for tag_id, (x, y) in zip(floor, points)])
    name = route_name(seed)
    world = World(name=name, frame_id=base.world.frame_id, tags=tags, walls=(), source=f"{__name__} seed {seed}")
    first_leg = points[1] - points[0]
    heading = math.atan2(first_leg[1], first_leg[0])
    start = points[0] - START_BEFORE_M * np.array([math.cos(heading), math.sin(heading)])
    length = START_BEFORE_M + float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
    # Four times the drive at 0.2 m/s, and the searches' time: flc_tuned slows to 10 % in turns and over each tag.
    timeout_s = 600.0 + 4.0 * length / SPEED_MPS
    mission = dataclasses.replace(base.mission, goal={"tag_ids": ceiling}, timeout_s=timeout_s)
    return dataclasses.replace(
        base, name=name, description=f"random route of seed {seed}: {len(points)} ceiling tags, {length:.1f} m, "
                                     f"turns {', '.join(f'{t:.0f}' for t in turns_deg(points))} deg",
        robot=(float(start[0]), float(start[1]), math.degrees(heading)), mission=mission, world=world,
        route_map=RouteMap(name=name, arrival_tags=dict(zip(ceiling, floor))), warnings=())
