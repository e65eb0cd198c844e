"""``./rfidnav reproduce two_tier``: paper 003 section 4.2, in-process, beside the paper's figures.

* Fig. 10: spiral search distance against the robot's initial distance from a 29 x 29 cm cross group (0-100
  cm), the HF reader's 5 cm range, random bearings and group rotations; the spiral sized as the paper sizes
  it (d = L / pi^2) and as we size it (the group widened by the reader's range on both sides). Beside it
  Theorem 1 (the expected search length for a Gaussian tier-one error) against simulated searches whose start
  is drawn from that Gaussian.
* Fig. 11: direct moving (dead reckoning all the way) against indirect moving (through intermediate landmarks
  chosen by geographic forwarding) on a long route: the accumulated position error at the target.
* Fig. 12: at each turning point of two routes through the flat, the error of WiFi fingerprinting alone
  against the two-tier scheme (tier one, then the spiral search and a tag fix).
* The radio map: a site survey on a 1 m grid against the robot's own survey (fingerprints at its tier-two
  fixes, paper 003's automatic radio map construction): the tier-one error at random points.

The paper gives Fig. 10 in numbers (about 120 cm within 40 cm, about 300 cm beyond) and Figs. 11-12 as plots
("indirect moving avoids larger accumulated error", "error will not be accumulated in our scheme"); RADAR's
2-3 m is the literature's fingerprinting figure. Where the paper gives no number the JSON row's paper is null.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rfidnav_bringup.scenario import CONFIG_DIR  # noqa: E402
from rfidnav_common.errors import ConfigError  # noqa: E402
from rfidnav_common.robot_map import load_route_map  # noqa: E402
from rfidnav_common.seeding import rng_for  # noqa: E402
from rfidnav_common.tag_groups import HF_READ_RANGE_M, TagGroup  # noqa: E402
from rfidnav_control.spiral import expected_search_length, separation_for_group, simulate_search  # noqa: E402
from rfidnav_experiments.reproduce.tables import save, table  # noqa: E402
from rfidnav_experiments.runners.two_tier import (  # noqa: E402
    Site,
    floor_extent,
    grid_radio_map,
    robot_survey,
    run_two_tier,
)
from rfidnav_localization.fingerprint import RadioMap  # noqa: E402
from rfidnav_planning.two_tier_navigation import TwoTierSettings  # noqa: E402
from rfidnav_sim.world import World, load_world  # noqa: E402

WORLD_FILE = CONFIG_DIR / "worlds" / "two_tier_home.yaml"
MAP_FILE = CONFIG_DIR / "maps" / "two_tier_home.yaml"       # the landmarks as the robot knows them: its goals
FIG10_SIZE_M = 0.29
FIG10_DISTANCES_M = tuple(round(0.1 * k, 1) for k in range(11))
FIG10_RUNS = 200
PAPER_FIG10_CM = {"near": 120.0, "far": 300.0}      # within 40 cm, beyond
THEOREM_SIGMAS_M = (0.25, 0.5, 1.0)
ROUTES = {"route 1": ((1.0, 1.0, 0.3), ("T1", "T2", "T3", "T4", "T5")),
          "route 2": ((1.5, 2.0, 1.2), ("R1", "R2", "R3"))}
LONG_ROUTE = ((1.0, 1.0, 0.0), (11.0, 1.0))
RUNS = 20
GRID_SPACING_M = 1.0
TEST_POINTS = 300


def spiral_d(size_m: float, ours: bool) -> float:
    """The paper's d = L / pi^2, or ours: the cross widened by the reader's range on each side."""
    if not ours:
        return size_m / math.pi ** 2
    return separation_for_group("cross", size_m + 2.0 * math.sqrt(2.0) * HF_READ_RANGE_M)


def fig10(runs: int, seed: int) -> dict[str, dict[float, float]]:
    """Mean search length [m] at each initial distance, for the paper's d and ours."""
    rng = rng_for(seed, "fig10")
    means: dict[str, dict[float, float]] = {}
    for ours in (False, True):
        d = spiral_d(FIG10_SIZE_M, ours)
        by_distance = {}
        for distance in FIG10_DISTANCES_M:
            lengths = []
            for _ in range(runs):
                bearing, rotation, heading = rng.uniform(-math.pi, math.pi, 3)
                group = TagGroup("G", "cross", (distance * math.cos(bearing), distance * math.sin(bearing)),
                                 FIG10_SIZE_M, rotation)
                length = simulate_search(group.tag_positions(), (0.0, 0.0), heading, d, HF_READ_RANGE_M, 5.0)
                lengths.append(math.inf if length is None else length)
            by_distance[distance] = statistics.fmean(lengths)
        means["ours" if ours else "paper d"] = by_distance
    return means


def theorem1(runs: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(sigma, Theorem 1 as printed, Rayleigh form, simulated) [m] for our spiral around a cross group."""
    rng = rng_for(seed, "theorem1")
    d = spiral_d(FIG10_SIZE_M, True)
    rows = []
    for sigma in THEOREM_SIGMAS_M:
        lengths = []
        for _ in range(runs):
            offset = rng.normal(0.0, sigma, 2)
            group = TagGroup("G", "cross", (float(offset[0]), float(offset[1])), FIG10_SIZE_M,
                             float(rng.uniform(-math.pi, math.pi)))
            length = simulate_search(group.tag_positions(), (0.0, 0.0), float(rng.uniform(-math.pi, math.pi)), d,
                                     HF_READ_RANGE_M, 10.0 * sigma)
            lengths.append(math.inf if length is None else length)
        rows.append((sigma, expected_search_length(sigma, d, as_printed=True),
                     expected_search_length(sigma, d, as_printed=False), statistics.fmean(lengths)))
    return rows


@dataclass(frozen=True)
class RouteErrors:
    fingerprint_m: dict[str, list[float]]     # turning point -> tier-one errors there
    two_tier_m: dict[str, list[float]]        # turning point -> tag-fix errors on arriving there


def fig12(site: Site, runs: int, seed: int) -> dict[str, RouteErrors]:
    """Each route driven ``runs`` times leg by leg (one navigation per turning point, as in the paper)."""
    landmarks = {group.group_id: group for group in load_route_map(MAP_FILE).tag_groups}
    results = {}
    for name, (start, points) in ROUTES.items():
        fingerprint = {p: [] for p in points}
        two_tier = {p: [] for p in points}
        for run in range(runs):
            rng = rng_for(seed, f"fig12:{name}:{run}")
            pose = start
            for point in points:
                centre = landmarks[point].centre
                scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*centre, rng)}
                fingerprint[point].append(math.dist(site.radio_map.locate(scan).position, centre))
                result = run_two_tier(site, pose, centre, TwoTierSettings(), rng)
                if result.success and result.fix_errors_m:
                    two_tier[point].append(result.fix_errors_m[-1])
                heading = math.atan2(centre[1] - pose[1], centre[0] - pose[0])
                pose = (result.final_position[0], result.final_position[1], heading)
        results[name] = RouteErrors(fingerprint, two_tier)
    return results


def fig11(site: Site, runs: int, seed: int) -> dict[str, list[float]]:
    """Final position error [m] of direct and indirect moving along LONG_ROUTE."""
    start, target = LONG_ROUTE
    errors: dict[str, list[float]] = {"direct": [], "indirect": []}
    for run in range(runs):
        for kind, spacing in (("direct", 0.1), ("indirect", 4.0)):
            settings = TwoTierSettings(landmark_spacing_m=spacing, calibration_distance_m=1000.0)
            result = run_two_tier(site, start, target, settings, rng_for(seed, f"fig11:{run}"))
            errors[kind].append(result.final_error_m if result.success else math.inf)
    return errors


def tier_one_errors(site: Site, radio_map: RadioMap, seed: int) -> list[float]:
    rng = rng_for(seed, "test points")
    width, height = floor_extent(site.world)
    errors = []
    for _ in range(TEST_POINTS):
        point = (float(rng.uniform(0.2, width - 0.2)), float(rng.uniform(0.2, height - 0.2)))
        scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*point, rng)}
        errors.append(math.dist(radio_map.locate(scan).position, point))
    return errors


def _median(values: list[float]) -> float:
    return statistics.median(values) if values else math.nan


def reproduce_two_tier(runs: int, out_dir: Path, as_json: bool, seed: int = 1, fig10_runs: int = FIG10_RUNS) -> int:
    """Run, report and plot; 0 when the two-tier median error at the turning points is within 3 cm, else 1."""
    if runs < 1 or fig10_runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {min(runs, fig10_runs)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    world: World = load_world(WORLD_FILE)
    grid_map = grid_radio_map(world, GRID_SPACING_M, rng_for(seed, "grid survey"))
    site = Site.of(world, grid_map)
    spiral = fig10(fig10_runs, seed)
    theorem = theorem1(fig10_runs, seed)
    moving = fig11(site, runs, seed)
    routes = fig12(site, runs, seed)
    survey_map = RadioMap(robot_survey(Site.of(world, RadioMap()), load_route_map(MAP_FILE), seed))
    radio = {"grid": tier_one_errors(site, grid_map, seed), "survey": tier_one_errors(site, survey_map, seed)}
    rows = json_rows(spiral, theorem, moving, routes, radio)
    (out_dir / "two_tier_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_figures(spiral, moving, routes, out_dir)
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join(report_lines(spiral, theorem, moving, routes, radio, len(grid_map), len(survey_map), runs,
                                      fig10_runs)))
    print(f"plot: {plot}; rows: {out_dir / 'two_tier_rows.json'}", file=notes)
    two_tier = [e for r in routes.values() for errors in r.two_tier_m.values() for e in errors]
    return 0 if two_tier and _median(two_tier) <= 0.03 else 1


def report_lines(spiral, theorem, moving, routes, radio, grid_count: int, survey_count: int, runs: int,
                 fig10_runs: int) -> list[str]:
    lines = [f"reproduce two_tier: paper 003 section 4.2, in-process ({runs} runs per route)", "",
             f"Fig. 10: mean spiral search length [cm] from a {FIG10_SIZE_M * 100:g} cm cross, HF range "
             f"{HF_READ_RANGE_M * 100:g} cm, {fig10_runs} random bearings and rotations per distance "
             f"(paper: ~{PAPER_FIG10_CM['near']:g} cm within 40 cm, ~{PAPER_FIG10_CM['far']:g} cm beyond)"]
    header = ["distance cm", *[f"{k} (d {spiral_d(FIG10_SIZE_M, k == 'ours') * 100:.2f} cm)" for k in spiral]]
    lines += table(header, [[f"{d * 100:g}", *[f"{spiral[k][d] * 100:.0f}" for k in spiral]]
                            for d in FIG10_DISTANCES_M])
    lines += ["", "Theorem 1: expected search length [cm] for a Gaussian tier-one error sd sigma (our spiral)"]
    lines += table(["sigma cm", "as printed", "Rayleigh form", "simulated", "simulated / Rayleigh"],
                   [[f"{s * 100:g}", f"{p * 100:.0f}", f"{r * 100:.0f}", f"{m * 100:.0f}", f"{m / r:.2f}"]
                    for s, p, r, m in theorem])
    lines += ["", f"Fig. 11: final position error [cm] from {LONG_ROUTE[0][:2]} to {LONG_ROUTE[1]} "
                  "(paper: indirect moving accumulates less error)"]
    lines += table(["moving", "median", "mean", "max"],
                   [[kind, f"{_median(v) * 100:.1f}", f"{statistics.fmean(v) * 100:.1f}", f"{max(v) * 100:.1f}"]
                    for kind, v in moving.items()])
    lines += ["", "Fig. 12: position error [cm] at the turning points, median over the runs "
                  "(paper: two-tier errors do not accumulate; fingerprinting alone stays at metre level)"]
    for name, errors in routes.items():
        lines += [f"{name}:"]
        lines += table(["turning point", "fingerprinting", "two-tier"],
                       [[p, f"{_median(errors.fingerprint_m[p]) * 100:.0f}",
                         f"{_median(errors.two_tier_m[p]) * 100:.1f}"] for p in errors.fingerprint_m])
    all_fp = [e for r in routes.values() for v in r.fingerprint_m.values() for e in v]
    all_tt = [e for r in routes.values() for v in r.two_tier_m.values() for e in v]
    lines += [f"all turning points: fingerprinting median {_median(all_fp) * 100:.0f} cm (RADAR: 2-3 m), two-tier "
              f"median {_median(all_tt) * 100:.1f} cm (target <= 3 cm)", "",
              f"radio map: tier-one error [cm] at {TEST_POINTS} random points"]
    lines += table(["radio map", "fingerprints", "median", "mean", "p90"],
                   [[kind, str(count), f"{_median(v) * 100:.0f}", f"{statistics.fmean(v) * 100:.0f}",
                     f"{np.percentile(v, 90) * 100:.0f}"]
                    for (kind, v), count in zip(radio.items(), (grid_count, survey_count))])
    return lines


def json_rows(spiral, theorem, moving, routes, radio) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for kind, by_distance in spiral.items():
        for distance, mean in by_distance.items():
            paper = None if distance == 0.4 else PAPER_FIG10_CM["near" if distance < 0.4 else "far"] / 100.0
            rows.append({"experiment": "fig10_spiral", "setting": {"spiral": kind, "distance_m": distance},
                         "metric": "search_length_m", "ours": mean, "paper": paper})
    for sigma, printed, rayleigh, simulated in theorem:
        rows.append({"experiment": "theorem1", "setting": {"sigma_m": sigma}, "metric": "search_length_m",
                     "ours": simulated, "paper": printed, "rayleigh_m": rayleigh})
    for kind, errors in moving.items():
        rows.append({"experiment": "fig11_moving", "setting": {"moving": kind}, "metric": "median_error_m",
                     "ours": _median(errors), "paper": None})
    for name, errors in routes.items():
        for point in errors.fingerprint_m:
            for method, values in (("fingerprinting", errors.fingerprint_m[point]),
                                   ("two_tier", errors.two_tier_m[point])):
                rows.append({"experiment": "fig12_turning_points",
                             "setting": {"route": name, "point": point, "method": method},
                             "metric": "median_error_m", "ours": _median(values), "paper": None})
    for kind, errors in radio.items():
        rows.append({"experiment": "radio_map", "setting": {"map": kind}, "metric": "median_error_m",
                     "ours": _median(errors), "paper": None})
    return rows


def plot_figures(spiral, moving, routes, out_dir: Path) -> Path:
    figure, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    for kind, by_distance in spiral.items():
        axes[0].plot([d * 100 for d in by_distance], [v * 100 for v in by_distance.values()], "o-", label=kind)
    axes[0].axhline(PAPER_FIG10_CM["near"], color="grey", linestyle=":", label="paper, < 40 cm")
    axes[0].axhline(PAPER_FIG10_CM["far"], color="grey", linestyle="--", label="paper, beyond")
    axes[0].set(xlabel="initial distance [cm]", ylabel="search length [cm]", title="Fig. 10: spiral search")
    axes[0].legend()
    axes[1].boxplot([[v * 100 for v in moving[k]] for k in moving], tick_labels=list(moving))
    axes[1].set(ylabel="final error [cm]", title="Fig. 11: direct vs indirect moving")
    points = [(name, p) for name, r in routes.items() for p in r.fingerprint_m]
    x = np.arange(len(points))
    axes[2].bar(x - 0.2, [_median(routes[n].fingerprint_m[p]) * 100 for n, p in points], 0.4, label="fingerprinting")
    axes[2].bar(x + 0.2, [_median(routes[n].two_tier_m[p]) * 100 for n, p in points], 0.4, label="two-tier")
    axes[2].set_xticks(x, [p for _, p in points])
    axes[2].set(ylabel="median error [cm]", yscale="log", title="Fig. 12: error at the turning points")
    axes[2].legend()
    return save(figure, out_dir / "two_tier_figs10_12.png", dpi=110)
