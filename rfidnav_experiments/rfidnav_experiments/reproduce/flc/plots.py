"""reproduce flc: the plots, like paper 001 Figs. 9, 11 and 13: the first evaluation seed's trajectories of both
parameter sets over the desired path, e(t) below."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from rfidnav_experiments.calibrate.flc import calibrated_reader
from rfidnav_experiments.reproduce.flc.conditions import PAPER, PARAM_SETS, SCENARIOS, params_file, scenario_named
from rfidnav_experiments.reproduce.flc.report import cm
from rfidnav_experiments.reproduce.tables import save
from rfidnav_experiments.runners.tag_route import RouteRun, controller_parameters, floor_read_radius_m, tag_points
from rfidnav_scenario.metrics import tracking_error
from rfidnav_scenario.scenario import Scenario

PLOT_COLOURS = {"flc_paper": "tab:blue", "flc_tuned": "tab:red"}


def plot_scenario(scenario: Scenario, runs: dict[str, RouteRun], out_dir: Path) -> Path:
    """The first evaluation seed of each parameter set: trajectory over the desired path (equal aspect, so the
    corners' angles are true), e(t) below (Figs. 9, 11, 13)."""
    route = list(scenario.mission.goal["tag_ids"])
    points = tag_points(scenario, route)
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(8, 10), gridspec_kw={"height_ratios": [2, 1]})
    for x1, y1, x2, y2 in scenario.world.walls:
        top.plot([x1, x2], [y1, y2], color="0.6", linewidth=2)
    top.plot(points[:, 0], points[:, 1], "--", color="tab:green", label="desired path")
    top.plot(points[:, 0], points[:, 1], "s", color="tab:orange", markersize=5)
    for tag_id, point in zip(route, points):
        top.annotate(tag_id, point, textcoords="offset points", xytext=(4, 4))
    for params, run in runs.items():
        label = params if run.success else f"{params} ({run.message})"
        top.plot(run.trajectory.xy[:, 0], run.trajectory.xy[:, 1], color=PLOT_COLOURS[params], linewidth=1,
                 label=label)
        error = tracking_error(run.trajectory, points, read_radius_m=floor_read_radius_m(
            calibrated_reader(scenario, run.seed), controller_parameters(scenario, params_file(params), run.seed)))
        rmse = run.metrics.tracking_rmse_m
        bottom.plot(error.times_s, error.xy[:, 0] * 100.0, color=PLOT_COLOURS[params], linewidth=1,
                    label=f"{params} (RMSE {cm(rmse, 2)} cm)")
    top.plot(*next(iter(runs.values())).trajectory.xy[0], "k^", label="start")
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title(f"{scenario.name}: trajectory, seed {next(iter(runs.values())).seed} (one run)")
    top.legend(loc="best")
    top.grid(True, alpha=0.3)
    low, high = PAPER[scenario.name].envelope_m
    for bound in (low, high):     # the paper's envelope, for the eye only
        bottom.axhline(bound * 100.0, color="0.5", linestyle=":", linewidth=1)
    bottom.axhline(0.0, color="0.5", linewidth=0.8)
    bottom.set_title(f"tracking error (dotted: paper's envelope {low * 100:+.0f}..{high * 100:+.0f} cm, "
                     f"RMSE {PAPER[scenario.name].rmse_m * 100:.1f} cm)")
    bottom.set_xlabel("time since mission start [s]")
    bottom.set_ylabel("e(t) [cm], + = left of path")
    bottom.legend(loc="best")
    bottom.grid(True, alpha=0.3)
    return save(figure, out_dir / f"flc_{scenario.name}.png", dpi=100)


def write_plots(results: dict[tuple[str, str], list[RouteRun]], out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    return [plot_scenario(scenario_named(name), {params: results[(params, name)][0] for params in PARAM_SETS},
                          out_dir) for name in SCENARIOS]
