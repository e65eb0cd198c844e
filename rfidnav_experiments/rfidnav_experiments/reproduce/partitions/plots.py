"""reproduce partitions: the plots (the headline, Figs. 11-20 and one task's trajectories)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullFormatter, ScalarFormatter

from rfidnav_common.tag_lattice import LAYOUTS
from rfidnav_experiments.reproduce.partitions.deployments import Accuracy, OrientationErrors
from rfidnav_experiments.reproduce.partitions.jobs import NavigationResult, example_job, navigate, task_of
from rfidnav_experiments.reproduce.partitions.settings import (
    ABLATION,
    ACCURACY_RANGES_M,
    COUNT_RANGE_M,
    DISTANCES_M,
    FIG11_PARTITIONS,
    FIG11_RANGE_M,
    FILTER,
    LEVELS,
    METHODS,
    NAVIGATION_RANGES_M,
    PAPER,
    PAPER_BAND_2CM_PCT,
    TRAJECTORY_DISTANCE_M,
    TRAJECTORY_RANGE_M,
    deployment,
    headline_level,
)
from rfidnav_experiments.reproduce.partitions.summary import CostSummary, Key, oracle_interval
from rfidnav_experiments.reproduce.tables import Interval, save

METHOD_COLOURS = {PAPER: "tab:blue", FILTER: "tab:red", ABLATION: "tab:gray"}


def plot_headline(summaries: dict[Key, CostSummary], groups: dict[Key, list[NavigationResult]],
                  out_dir: Path) -> Path:
    """Both costs at the headline level per r and method, with their 95 % intervals and numbers of runs."""
    level = headline_level()
    figure, axes = plt.subplots(1, len(NAVIGATION_RANGES_M), figsize=(15, 4.8), squeeze=False)
    for ax, r in zip(axes[0], NAVIGATION_RANGES_M):
        for offset, method in zip((-0.2, 0.0, 0.2), METHODS):
            s = summaries[(method, r, level)]
            for x, interval in ((0, s.cost), (1, s.time_cost)):
                if interval.mean is None:
                    continue
                ax.errorbar(x + offset, interval.mean, yerr=interval.half_width or 0.0, fmt="o", capsize=4,
                            color=METHOD_COLOURS[method], label=f"{method} (n = {interval.n})" if x == 0 else None)
                ax.annotate(f"n={interval.n}", (x + offset, interval.mean), textcoords="offset points",
                            xytext=(5, -10), fontsize=7, color=METHOD_COLOURS[method])
        oracle = oracle_interval(groups, r, level)
        ax.hlines(oracle.mean, 0.7, 1.3, colors="k", linestyles=":",
                  label=f"oracle: one turn, then straight (n = {oracle.n})")
        ax.set_xticks([0, 1], ["(l-|SD|)/|SD|", "time, turns charged"])
        ax.set_xlim(-0.5, 1.5)
        ax.set_ylabel("extra cost [%], mean ± 95 %")
        ax.set_title(f"r = {r * 100:g} cm, level {level}")
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    return save(figure, out_dir / "partitions_headline.png", dpi=90)


def plot_costs(summaries: dict[Key, CostSummary], runs: int, out_dir: Path) -> Path:
    """Figs. 12-14: the translational cost against distance per level, for the paper's method and the filter."""
    methods = (PAPER, FILTER)
    figure, axes = plt.subplots(len(methods), len(NAVIGATION_RANGES_M), figsize=(15, 8), sharex=True, squeeze=False)
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(LEVELS)))
    for row_index, method in enumerate(methods):
        for column, r in enumerate(NAVIGATION_RANGES_M):
            ax = axes[row_index][column]
            for level, colour in zip(LEVELS, colours):
                s = summaries.get((method, r, level))
                if s is None:
                    continue
                means = [s.cost_by_distance[d].mean for d in DISTANCES_M]
                ax.plot([d * 100 for d in DISTANCES_M], [np.nan if y is None else y for y in means], "o-",
                        color=colour, label=f"{level}-approximation", markersize=3)
            if r == 0.02:
                ax.axhspan(*PAPER_BAND_2CM_PCT, color="0.85", label="paper's band")
            ax.set_title(f"{method}, r = {r * 100:g} cm (Fig. {12 + column}); n <= {runs // len(DISTANCES_M)} "
                         "per point", fontsize=9)
            ax.set_xlabel("distance to the destination [cm]")
            ax.set_ylabel("extra navigation cost [%]")
            ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=7)
    return save(figure, out_dir / "partitions_fig12_14_cost.png", dpi=90)


def plot_with_intervals(ax: Any, xs: Sequence[float], intervals: Sequence[Interval], style: str, label: str) -> None:
    """Means joined by a line, each with its 95 % interval as an error bar."""
    ax.errorbar(xs, [np.nan if i.mean is None else i.mean for i in intervals],
                yerr=[i.half_width or 0.0 for i in intervals], fmt=style, capsize=3, markersize=4, label=label)


def plot_fig11(errors: OrientationErrors, out_dir: Path) -> Path:
    figure, ax = plt.subplots(figsize=(6, 4))
    ks = list(FIG11_PARTITIONS)
    plot_with_intervals(ax, ks, [errors.paper_deg[k] for k in ks], "o-",
                        f"paper bounds (sec. 4.2), n = {errors.lines} per point")
    filter_ks = [k for k in ks if k in errors.filter_deg]
    # The filter may have no heading yet after the first partitions of some lines: those points average fewer.
    counts = sorted({errors.filter_deg[k].n for k in filter_ks})
    spread = "-" if not counts else str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"
    plot_with_intervals(ax, filter_ks, [errors.filter_deg[k] for k in filter_ks], "s-",
                        f"particle filter, n = {spread} per point")
    ax.set_xlabel("partitions traversed")
    ax.set_ylabel("orientation error [deg], mean ± 95 %")
    ax.set_title(f"Fig. 11: r = {FIG11_RANGE_M * 100:g} cm")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save(figure, out_dir / "partitions_fig11_orientation.png", dpi=100)


def plot_deployments(counts: dict[int, dict[str, int]], accuracy: dict[tuple[str, float], Accuracy],
                     out_dir: Path) -> Path:
    figure, (ax_count, ax_loc, ax_orient) = plt.subplots(1, 3, figsize=(15, 4.5))
    sides = list(counts)
    ranges_cm = [r * 100 for r in ACCURACY_RANGES_M]
    for layout in LAYOUTS:
        ax_count.plot([s * s for s in sides], [counts[s][layout] for s in sides], "o-", label=layout)
        samples = accuracy[(layout, ACCURACY_RANGES_M[0])].location_rel.n
        plot_with_intervals(ax_loc, ranges_cm, [accuracy[(layout, r)].location_rel for r in ACCURACY_RANGES_M], "o-",
                            f"{layout}, n = {samples} per point")
        plot_with_intervals(ax_orient, ranges_cm, [accuracy[(layout, r)].orientation_deg for r in ACCURACY_RANGES_M],
                            "o-", f"{layout}, n = {samples} per point")
    ax_count.set(xlabel="area [m^2]", ylabel="tags (exact count)",
                 title=f"Figs. 15, 18: tags (r = {COUNT_RANGE_M * 100:g} cm)")
    ax_loc.set(xlabel="read range r [cm]", ylabel="location error / r, mean ± 95 %",
               title="Figs. 16, 19: location error")
    ax_orient.set(xlabel="read range r [cm]", ylabel="orientation error [deg], mean ± 95 %",
                  title="Figs. 17, 20: orientation error (1 partition)")
    for ax in (ax_loc, ax_orient):
        # A log axis labels its minor ticks too (3, 4, 6, ... on top of each other): label the ranges measured only.
        ax.set_xscale("log")
        ax.set_xticks(ranges_cm)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    for ax in (ax_count, ax_loc, ax_orient):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    return save(figure, out_dir / "partitions_fig15_20_deployments.png", dpi=90)


def plot_trajectories(out_dir: Path, seed: int) -> Path:
    """One task driven by the three configurations over the tags, at equal aspect (the turns' angles true)."""
    field = deployment(TRAJECTORY_RANGE_M)
    figure, ax = plt.subplots(figsize=(7, 7))
    tags = field.lattice.positions(field.coordinates())
    ax.plot(tags[:, 0], tags[:, 1], ".", color="0.8", markersize=2, label="tags")
    start = goal = None
    for method in METHODS:
        job = example_job(method, seed)
        run = navigate(job)
        (x, y, _), goal = task_of(job)
        start = (x, y)
        ax.plot(run.trajectory[:, 0], run.trajectory[:, 1], color=METHOD_COLOURS[method], linewidth=1.2,
                label=f"{method}: {run.extra_cost_pct:.1f} % path, {run.extra_time_cost_pct:.1f} % time"
                      f"{'' if run.success else ' (' + run.message + ')'}")
    assert start is not None and goal is not None
    ax.plot(*start, "k^", label="start")
    ax.plot(*goal, "k*", markersize=10, label="goal")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"one task (n = 1 per method): r = {TRAJECTORY_RANGE_M * 100:g} cm, "
                                                  f"level {headline_level()}, |SD| = {TRAJECTORY_DISTANCE_M:g} m, "
                                                  f"seed {seed}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return save(figure, out_dir / "partitions_trajectories.png", dpi=100)
