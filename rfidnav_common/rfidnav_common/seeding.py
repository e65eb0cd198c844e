"""One seed per run; every node derives its own stream from it, so runs repeat and nodes stay independent."""

from __future__ import annotations

import hashlib

import numpy as np


def derive_seed(run_seed: int, stream: str) -> int:
    """A stable 63-bit seed for ``stream`` (e.g. a node name) within run ``run_seed``."""
    digest = hashlib.sha256(f"{run_seed}:{stream}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def rng_for(run_seed: int, stream: str) -> np.random.Generator:
    return np.random.default_rng(derive_seed(run_seed, stream))


def robot_seed(run_seed: int, robot: str) -> int:
    """The seed of robot ``robot``'s nodes in a run of several robots (rfidnav_scenario.scenario's ``robots:``): each
    robot's streams (its reader's noise, its odometry's slip) independent of the others', all from the run's seed."""
    return derive_seed(run_seed, f"robot {robot}")
