"""``./rfidnav bench reader``: the reader simulator's round over many listed tags (a building's ceiling tags, paper
001's reader), where it looks them up in a k-d tree (``rfid_model.ReaderSimulator.tags_in_range``)."""

from __future__ import annotations

import math
import time

import numpy as np

from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.rfid_model import ReaderSimulator

TAG_COUNTS = (1_000, 10_000, 100_000)
TAG_SPACING_M = 2.0          # one ceiling tag per 4 m^2 on average, 3 m up: ~60 within each antenna's 9 m reach
CEILING_M = 3.0


def listed_tags_benchmark(rounds: int = 200, seed: int = 1) -> dict[str, float]:
    """Microseconds per inventory round of the shipped two-antenna UHF reader (reader_uhf_2ant.yaml) among 1k, 10k
    and 100k ceiling tags placed at random on a square of TAG_SPACING_M^2 per tag, at random poses over it."""
    model = file_parameters(ReaderParameters, CONFIG_DIR / "params" / "reader_uhf_2ant.yaml", "rfid_reader_sim",
                            world_file="unused").reader_model()
    figures: dict[str, float] = {"rounds": rounds}
    for count in TAG_COUNTS:
        rng = np.random.default_rng([seed, count])
        side = math.sqrt(count) * TAG_SPACING_M
        positions = np.column_stack((rng.uniform(0.0, side, (count, 2)), np.full(count, CEILING_M)))
        simulator = ReaderSimulator(model, [f"C{index}" for index in range(count)], positions, np.zeros(count), rng)
        poses = rng.uniform((0.0, 0.0, -math.pi), (side, side, math.pi), (rounds, 3))
        started = time.perf_counter()
        reads = sum(len(simulator.inventory(x, y, yaw, 0.0)) for x, y, yaw in poses)
        figures[f"round_us_{count}"] = 1e6 * (time.perf_counter() - started) / rounds
        figures[f"reads_per_round_{count}"] = reads / rounds
    return figures
