"""reproduce two_tier: the figure (Fig. 10 and its paired difference, Fig. 11, Fig. 12)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FixedLocator, NullLocator  # noqa: E402

from rfidnav_experiments.reproduce.tables import save  # noqa: E402
from rfidnav_experiments.reproduce.two_tier.conditions import (  # noqa: E402
    FIG10_DISTANCES_M,
    METHODS,
    OURS,
    PAPER,
    PAPER_FIG10_M,
    ROUTES,
)
from rfidnav_experiments.reproduce.two_tier.navigations import Leg  # noqa: E402
from rfidnav_experiments.reproduce.two_tier.searches import Search  # noqa: E402
from rfidnav_experiments.reproduce.two_tier.summary import (  # noqa: E402
    Median,
    done,
    legs_at,
    paired_difference,
    spiral_point,
)

COLOURS = {PAPER: "tab:blue", OURS: "tab:red"}
FIG12_TICKS_CM = (1, 3, 10, 30, 100, 300)


def plot_fig10(axes: plt.Axes, difference_axes: plt.Axes, spiral: dict[str, dict[float, list[Search]]],
               runs: int) -> None:
    for offset, method in zip((-0.6, 0.6), METHODS):
        points = [spiral_point(spiral[method][d]) for d in FIG10_DISTANCES_M]
        x = [d * 100 + offset for d in FIG10_DISTANCES_M]
        means = [np.nan if p.length.mean is None else p.length.mean * 100 for p in points]
        half = [0.0 if p.length.half_width is None else p.length.half_width * 100 for p in points]
        axes.errorbar(x, means, yerr=half, fmt="o-", color=COLOURS[method], capsize=3, markersize=4,
                      label=f"{method} (mean, 95 % interval)")
        for xi, mean, point in zip(x, means, points):
            if math.isfinite(mean):
                axes.annotate(str(point.length.n), (xi, mean), textcoords="offset points", fontsize=6,
                              xytext=(-12 if method == PAPER else 4, 4), color=COLOURS[method])
    axes.plot([d * 100 for d in PAPER_FIG10_M], [v * 100 for v in PAPER_FIG10_M.values()], "k*", markersize=11,
              label="paper, sec. 4.2")
    axes.set(xlabel="initial distance to the group's centre [cm]", ylabel="search length [cm]",
             title=f"Fig. 10: {runs} placements per distance (numbers: n found)")
    axes.legend(fontsize=8)
    axes.grid(True, alpha=0.3)
    differences = [paired_difference(spiral, d) for d in FIG10_DISTANCES_M]
    difference_axes.errorbar([d * 100 for d in FIG10_DISTANCES_M],
                             [np.nan if i.mean is None else i.mean * 100 for i in differences],
                             yerr=[0.0 if i.half_width is None else i.half_width * 100 for i in differences],
                             fmt="o-", color="tab:purple", capsize=3, markersize=4)
    for distance, interval in zip(FIG10_DISTANCES_M, differences):
        if interval.mean is not None:
            difference_axes.annotate(str(interval.n), (distance * 100, interval.mean * 100), fontsize=6,
                                     textcoords="offset points", xytext=(4, 4))
    difference_axes.axhline(0.0, color="0.5", linewidth=0.8)
    difference_axes.set(xlabel="initial distance [cm]", ylabel="ours - paper [cm]",
                        title="Fig. 10, paired: ours minus the paper's (numbers: pairs)")
    difference_axes.grid(True, alpha=0.3)


def plot_fig11(axes: plt.Axes, moving: dict[str, dict[int, float | None]]) -> None:
    values = [[e * 100 for e in done(errors)] for errors in moving.values()]
    axes.boxplot(values, tick_labels=[f"{kind}\nn={len(v)}" for kind, v in zip(moving, values)])
    axes.set(ylabel="final error [cm]", title="Fig. 11: direct vs indirect moving")
    axes.grid(True, axis="y", alpha=0.3)


def plot_fig12(axes: plt.Axes, legs: list[Leg]) -> None:
    points = [(route, point) for route, (_, route_points) in ROUTES.items() for point in route_points]
    x = np.arange(len(points))
    series = {"fingerprinting": lambda leg: leg.fingerprint_m, f"two-tier {OURS}": lambda leg: leg.fix_m,
              f"two-tier {PAPER}": lambda leg: leg.tag_position_m}
    for offset, (label, value) in zip((-0.27, 0.0, 0.27), series.items()):
        medians = [Median.of([v for v in map(value, legs_at(legs, route, point)) if v is not None])
                   for route, point in points]
        centres = np.array([np.nan if m.value is None else m.value * 100 for m in medians])
        low = [0.0 if m.bounds is None or m.value is None else (m.value - m.bounds[0]) * 100 for m in medians]
        high = [0.0 if m.bounds is None or m.value is None else (m.bounds[1] - m.value) * 100 for m in medians]
        axes.errorbar(x + offset, centres, yerr=[low, high], fmt="o", capsize=3, markersize=4, label=label)
    counts = [len([leg for leg in legs_at(legs, route, point) if leg.fix_m is not None]) for route, point in points]
    axes.set_xticks(x, [f"{point}\nn={n}" for (_, point), n in zip(points, counts)], fontsize=8)
    axes.set_yscale("log")
    axes.yaxis.set_major_locator(FixedLocator(FIG12_TICKS_CM))
    axes.yaxis.set_minor_locator(NullLocator())
    axes.set_yticklabels([str(tick) for tick in FIG12_TICKS_CM])
    axes.set(ylabel="error [cm], median and 95 % interval", title="Fig. 12: error at the turning points")
    axes.legend(fontsize=8)
    axes.grid(True, axis="y", alpha=0.3)


def plot_figures(spiral, moving, legs: list[Leg], runs: int, out_dir: Path) -> Path:
    figure, axes = plt.subplots(2, 2, figsize=(14, 10))
    plot_fig10(axes[0][0], axes[1][0], spiral, runs)
    plot_fig11(axes[0][1], moving)
    plot_fig12(axes[1][1], legs)
    return save(figure, out_dir / "two_tier_figs10_12.png", dpi=110)
