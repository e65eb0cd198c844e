"""``./rfidnav reproduce fused``: the fused localizer (rfidnav_localization.fused) beside each paper's own
localizer, on the same runs, paired.

So far: paper 003's homes (HOMES of reproduce two_tier: the in-tree flat and two of ours). Each run is the
two-tier navigator's mission from the scenario's start to its goal, its legs planned round the map's walls,
driven by the paper's localizer (WiFi fingerprints, then floor tag groups, dead reckoning between); the fused
localizer runs beside it on what the same sensors gave in each step (floor reads, the location server's
answers, the compass, the odometry), with the same shipped settings on every world. Per run and localizer: the
position and heading RMSE over the steps it had an estimate, the fix rate (the share of steps it had one), and
the share of steps whose NEES lies in its two-sided 95 % chi-square band (consistency). Per home: means with
95 % intervals over the runs, and the paired difference fused - paper with its interval.

Development and evaluation apart: the code and its settings were chosen on DEVELOPMENT_SEED; the command
reports EVALUATION_SEED, never used to tune anything.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from rfidnav_common.errors import ConfigError
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.tables import Interval, paired_interval, table
from rfidnav_experiments.reproduce.two_tier import HOMES, floor_range_m, home
from rfidnav_experiments.runners.fused import Beside, Track
from rfidnav_experiments.runners.two_tier import COMPASS, FLOOR_READER, NAVIGATOR, SETTINGS, run_two_tier
from rfidnav_localization.fused.filter import FusedSettings
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.models import CompassModel, FloorModel
from rfidnav_localization.fused.tag_map import FusedMap

EXPERIMENT = "fused"
RUNS = 10
DEVELOPMENT_SEED = 1
EVALUATION_SEED = 401
LOCALIZERS = ("fused", "paper")
NEES_BAND = 0.95


def two_tier_settings() -> FusedSettings:
    """The fused localizer on paper 003's robot: its HF floor antenna and the compass_sim node's noise."""
    antenna = np.reshape(FLOOR_READER.antenna_positions, (-1, 3))[NAVIGATOR.floor_antenna - 1]   # ports 1, 2, ...
    return FusedSettings(floor=FloorModel((float(antenna[0]), float(antenna[1]))),
                         tag_group_read_range_m=floor_range_m(),
                         compass=CompassModel(sd_rad=max(COMPASS.noise_sd_rad, math.radians(0.5))))


@dataclass(frozen=True)
class TrackFigures:
    position_rmse_m: float | None
    heading_rmse_deg: float | None
    fix_rate: float
    consistent: float | None          # share of steps with an estimate whose NEES is in its 95 % band

    @classmethod
    def of(cls, track: Track) -> TrackFigures:
        low, high = (float(stats.chi2.ppf(q, track.nees_dof)) for q in ((1 - NEES_BAND) / 2, (1 + NEES_BAND) / 2))
        inside = [low <= value <= high for value in track.nees]
        return cls(_rms(track.position_errors_m), _rms([math.degrees(e) for e in track.heading_errors_rad]),
                   track.fix_rate, sum(inside) / len(inside) if inside else None)


@dataclass(frozen=True)
class FusedRun:
    world: str
    run: int
    success: bool                     # the paper's mission arrived
    fused: TrackFigures
    paper: TrackFigures


def _rms(values: list[float]) -> float | None:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else None


def home_run(job: tuple[str, int, int]) -> FusedRun:
    """One two-tier mission of a home with the fused localizer beside; the same streams as reproduce two_tier's
    planned-legs run of that home and run number."""
    name, run, seed = job
    place = home(name)
    robot_map = place.scenario.route_map
    assert robot_map is not None                       # home() refuses a home without its map
    beside = Beside(FusedLocalizer(two_tier_settings(), FusedMap.of_route_map(robot_map, place.site.radio_map),
                                   rng_for(seed, f"fused:{name}:{run}")))
    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    result = run_two_tier(place.site, (x, y, math.radians(yaw_deg)), (target["x"], target["y"]), SETTINGS,
                          rng_for(seed, f"homes:{name}:{run}"), derive_seed(seed, f"homes:{name}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s, floor=place.floor, observe=beside)
    return FusedRun(name, run, result.success, TrackFigures.of(beside.fused), TrackFigures.of(beside.paper))


def fused_runs(runs: int, seed: int) -> list[FusedRun]:
    results = run_tasks(home_run, [(name, run, seed) for name in HOMES for run in range(runs)],
                        "reproduce fused: paper 003 homes")
    return sorted(results, key=lambda r: (HOMES.index(r.world), r.run))


METRICS = {"position_rmse_m": ("position RMSE [m]", 1.0, 3),
           "heading_rmse_deg": ("heading RMSE [deg]", 1.0, 2),
           "fix_rate": ("fix rate [%]", 100.0, 1),
           "consistent": ("NEES in its 95 % band [%]", 100.0, 1)}


def figures(results: list[FusedRun], world: str) -> dict[str, dict[str, Interval]]:
    """Per metric: each localizer's mean over the runs and the paired difference fused - paper."""
    mine = [r for r in results if r.world == world]
    out: dict[str, dict[str, Interval]] = {}
    for metric in METRICS:
        values = {name: {r.run: getattr(getattr(r, name), metric) for r in mine} for name in LOCALIZERS}
        out[metric] = {name: Interval.of([v for v in values[name].values() if v is not None]) for name in LOCALIZERS}
        out[metric]["difference"] = paired_interval(values["fused"], values["paper"])
    return out


def report_lines(results: list[FusedRun], runs: int) -> list[str]:
    lines = [f"reproduce fused: the fused localizer beside each paper's own, same runs ({runs} per world)", ""]
    for world in dict.fromkeys(r.world for r in results):
        arrived = sum(r.success for r in results if r.world == world)
        lines += [f"{world} (paper 003, two-tier navigator driving; {arrived}/{runs} arrived)"]
        rows = [[label, *(figure[name].text(scale, digits) for name in (*LOCALIZERS, "difference"))]
                for metric, (label, scale, digits) in METRICS.items()
                for figure in (figures(results, world)[metric],)]
        lines += table(["metric", "fused", "paper", "fused - paper (paired)"], rows) + [""]
    return lines


def json_rows(results: list[FusedRun], seed: int) -> list[dict[str, Any]]:
    rows = []
    for world in dict.fromkeys(r.world for r in results):
        for metric, figure in figures(results, world).items():
            rows.append({"experiment": EXPERIMENT, "setting": f"{world} seed {seed}", "metric": metric,
                         "ours": _interval_json(figure["fused"]), "paper": _interval_json(figure["paper"]),
                         "difference": _interval_json(figure["difference"])})
    return rows


def _interval_json(interval: Interval) -> dict[str, Any]:
    return {"mean": interval.mean, "half_width": interval.half_width, "n": interval.n}


def reproduce_fused(runs: int, out_dir: Path, as_json: bool, seed: int = EVALUATION_SEED) -> int:
    if runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {runs}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results = fused_runs(runs, seed)
    rows = json_rows(results, seed)
    (out_dir / "fused_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join(report_lines(results, runs)))
    print(f"rows: {out_dir / 'fused_rows.json'}", file=sys.stderr if as_json else sys.stdout)
    return 0
