"""``./rfidnav bench planner``: paper 000's Algorithm 1 and the reader simulator's round over a huge described floor
(a 30 x 30 m triangular field at r = 2 cm, about 870,000 tags)."""

from __future__ import annotations

import math
import time

import numpy as np

from rfidnav_common.tag_lattice import make_deployment
from rfidnav_planning.partition_planner import plan_partition_path
from rfidnav_sim.rfid_model import Antenna, ReaderModel, ReaderSimulator

BENCHMARK_FIELD_M = 30.0
BENCHMARK_READ_RANGE_M = 0.02


def planning_benchmark(plans: int = 200, seed: int = 1) -> dict[str, float]:
    """Plan ``plans`` random segments (uniform start and goal) in a 30 x 30 m triangular field at r = 2 cm
    (about 870,000 tags); planning times in milliseconds."""
    deployment = make_deployment("triangular", BENCHMARK_READ_RANGE_M,
                                 (0.0, 0.0, BENCHMARK_FIELD_M, BENCHMARK_FIELD_M))
    rng = np.random.default_rng(seed)
    endpoints = rng.uniform(0.0, BENCHMARK_FIELD_M, size=(plans, 2, 2))
    times_ms, partition_counts = [], []
    for start, goal in endpoints:
        began = time.perf_counter()
        plan = plan_partition_path(deployment, (float(start[0]), float(start[1])), (float(goal[0]), float(goal[1])))
        times_ms.append((time.perf_counter() - began) * 1e3)
        partition_counts.append(len(plan.partitions))
    times = np.array(times_ms)
    return {"field_m": BENCHMARK_FIELD_M, "read_range_m": BENCHMARK_READ_RANGE_M,
            "tags": deployment.tag_count(), "plans": plans,
            "mean_ms": float(times.mean()), "p50_ms": float(np.percentile(times, 50)),
            "p99_ms": float(np.percentile(times, 99)), "max_ms": float(times.max()),
            "mean_partitions": float(np.mean(partition_counts))}


def reader_round_benchmark(rounds: int = 2000, seed: int = 1) -> dict[str, float]:
    """Inventory rounds of one downward antenna over a 30 x 30 m triangular floor at r = 2 cm (868,367 tags,
    described, never listed), at random poses: the cost of "which tags are within r of this antenna"."""
    deployment = make_deployment("triangular", 0.02, (0.0, 0.0, 30.0, 30.0))
    model = ReaderModel(antennas=(Antenna(1, (0.0, 0.0, 0.05), False, 0.1, math.radians(60.0)),),
                        channels_hz=(915.25e6,))
    simulator = ReaderSimulator(model, [], np.empty((0, 3)), np.empty(0), np.random.default_rng(seed), (deployment,))
    poses = np.random.default_rng(seed).uniform((0.0, 0.0, -math.pi), (30.0, 30.0, math.pi), (rounds, 3))
    started = time.perf_counter()
    tags_read = sum(len(simulator.inventory(x, y, yaw, 0.0)) for x, y, yaw in poses)
    elapsed = time.perf_counter() - started
    return {"reader_tags": deployment.tag_count(), "reader_rounds": rounds,
            "reader_round_us": 1e6 * elapsed / rounds, "reader_tags_per_round": tags_read / rounds}
