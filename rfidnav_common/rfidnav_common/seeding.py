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
