"""reproduce topological: the figure and the evaluation floors' files."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rfidnav_experiments.reproduce.tables import save
from rfidnav_experiments.reproduce.topological.conditions import (
    EVALUATION_FLOORS,
    HAND_DRAWN,
    LARGE,
    MISS_RATES,
    PATH_TARGET,
    POOLED,
    RADII_M,
    RING,
    SEEDS,
    TARGET_SUCCESS_PCT,
)
from rfidnav_experiments.reproduce.topological.summary import RateSummary
from rfidnav_experiments.runners.topological import load_floor
from rfidnav_scenario.metrics import GOAL_RADIUS_M
from rfidnav_sim.floor_generator import write_floor


def plot_summaries(summaries: list[RateSummary], out_dir: Path) -> Path:
    """Success and path ratio against the miss rate (the pooled evaluation solid, the development floors dashed),
    success against the radius (pooled evaluation), 95 % intervals, n on the legend; the evaluation floors below,
    walls, tags and maps to scale."""
    figure, axes = plt.subplots(2, 3, figsize=(17, 10))
    labels = {"paper": "paper's loop (edges, no recovery)", "ours": "ours (lengths, recovery)"}
    styles = {POOLED: "-", HAND_DRAWN: "--", RING: "-.", LARGE: ":"}
    for floor, style in styles.items():
        for method, label in labels.items():
            mine = [s for s in summaries if s.floor == floor and s.method == method]
            if not mine:
                continue
            rates = np.array([s.miss_rate * 100 for s in mine]) + (0.6 if method == "ours" else -0.6)
            success = np.array([s.success.mean for s in mine], dtype=float)
            bounds = np.array([s.success.bounds for s in mine], dtype=float)
            yerr = np.maximum(0.0, [success - bounds[:, 0], bounds[:, 1] - success])
            name = "evaluation (pooled)" if floor == POOLED else f"{floor} (development)"
            axes[0, 0].errorbar(rates, success, yerr=yerr, fmt="o", linestyle=style, capsize=3,
                                label=f"{label}, {name} (n={mine[0].missions})")
            ratio = np.array([np.nan if s.path_ratio.mean is None else s.path_ratio.mean for s in mine])
            width = np.array([0.0 if s.path_ratio.half_width is None else s.path_ratio.half_width for s in mine])
            axes[0, 1].errorbar(rates, ratio, yerr=width, fmt="o", linestyle=style, capsize=3,
                                label=f"{label}, {name}")
    axes[0, 0].axhline(TARGET_SUCCESS_PCT, color="grey", linestyle="--", linewidth=0.8)
    axes[0, 0].set(xlabel="tag read misses per passage [%]", ylabel="missions reaching the goal [%] (95 % Wilson)",
                   ylim=(0, 105), title="Success against read failures")
    axes[0, 0].legend(fontsize=6, loc="lower left")
    axes[0, 1].axhline(PATH_TARGET, color="grey", linestyle="--", linewidth=0.8, label=f"target {PATH_TARGET}")
    axes[0, 1].set(xlabel="tag read misses per passage [%]", ylabel="path / shortest, successful (± 95 %)",
                   title="Path length")
    axes[0, 1].legend(fontsize=6)
    for method, label in labels.items():
        for rate in MISS_RATES:
            s = next(s for s in summaries if (s.floor, s.method, s.miss_rate) == (POOLED, method, rate))
            axes[0, 2].plot(RADII_M, [w.mean for w in s.within], marker="o",
                            linestyle="-" if method == "ours" else "--",
                            label=f"{label}, {rate * 100:g} %")
    axes[0, 2].axvline(GOAL_RADIUS_M, color="grey", linewidth=0.8)
    axes[0, 2].set(xlabel="success radius [m]", ylabel="missions reaching the goal [%]", ylim=(0, 105),
                   title="Success against the radius (evaluation, pooled)")
    axes[0, 2].legend(fontsize=6, loc="lower right")
    for axis, floor in zip(axes[1], EVALUATION_FLOORS):
        robot_map, world = load_floor(floor)
        for x1, y1, x2, y2 in world.walls:
            axis.plot([x1, x2], [y1, y2], color="black", linewidth=1.0)
        positions = {name: node.position for name, node in robot_map.nodes.items() if node.position is not None}
        for edge in robot_map.edges():
            if edge.node_a in positions and edge.node_b in positions:
                (xa, ya), (xb, yb) = positions[edge.node_a], positions[edge.node_b]
                axis.plot([xa, xb], [ya, yb], color="tab:blue", linestyle="--", linewidth=0.6)
        for name, (x, y) in positions.items():
            axis.annotate(name, (x, y), textcoords="offset points", xytext=(3, 3), color="tab:blue", fontsize=7)
        for tag in world.wall_tags:
            axis.plot(*tag.position, "s", color="tab:orange", markersize=2)
        axis.set_aspect("equal", adjustable="datalim")
        axis.set_title(f"{floor} (evaluation; North {robot_map.north_deg:g} deg)", fontsize=9)
    return save(figure, out_dir / "topological_missions.png", dpi=100)


def write_floors(out_dir: Path) -> Path:
    """The evaluation floors' map and world files, for the record (the runs draw them again from their seeds)."""
    folder = out_dir / "topological_floors"
    folder.mkdir(parents=True, exist_ok=True)
    for floor in EVALUATION_FLOORS:
        write_floor(SEEDS[floor], folder / f"{floor}_map.yaml", folder / f"{floor}_world.yaml")
    return folder
