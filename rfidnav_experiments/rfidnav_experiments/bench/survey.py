"""``./rfidnav bench survey``: paper 003's robot survey through the node graph beside the in-process one.

Both survey the same flat (two_tier_home's world and map) from the same dock by the same plan and rule
(rfidnav_planning.two_tier_survey), on the same seed:

1. over DDS, ``./rfidnav run two_tier_home_survey``: two_tier_navigator's ``/survey`` action drives every leg and
   adds each due scan of wifi_sim to the location server, whose database (the run folder's location.db) starts
   without fingerprints; the scans come when wifi_sim scans (every 2 s of sim time), so a scan is due at most
   every 2 s of driving, where the in-process survey takes its scan the moment one is due;
2. in-process, rfidnav_experiments.runners.two_tier.robot_survey.

Each radio map is then measured as ``reproduce two_tier`` measures the robot's survey: tier one's error at the
same TEST_POINTS random points of the flat (median and its 95 % interval); and used: ``two_tier_home`` over DDS
on seeds 1..N with its location server given a database holding that map's fingerprints only (the map's tag
groups are loaded by the server itself, as in every run).
"""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from typing import Any

import yaml

from rfidnav_bringup.api import RunOptions
from rfidnav_common.robot_map import load_route_map
from rfidnav_experiments.bench.runs import quiet_run
from rfidnav_experiments.reproduce.two_tier.conditions import MAP_FILE, TEST_POINTS, WORLD_FILE
from rfidnav_experiments.reproduce.two_tier.navigations import tier_one_errors
from rfidnav_experiments.reproduce.two_tier.summary import Median
from rfidnav_experiments.runners.two_tier import Site, robot_survey
from rfidnav_localization.fingerprint import Fingerprint, RadioMap
from rfidnav_localization.location_store import LocationStore
from rfidnav_planning.two_tier_survey import SURVEY_SPACING_M
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from rfidnav_sim.world import load_world

SURVEY_SCENARIO = "two_tier_home_survey"
MISSION_SCENARIO = "two_tier_home"
MAPS = ("dds", "in_process")


def run(scenario: str, seed: int, out_dir: Path, location_server_params: Path | None = None) -> dict[str, Any]:
    """One run over DDS at the stepped clock's top speed: its summary document (with the run folder's path)."""
    loaded = load_scenario(scenario, param_files=None if location_server_params is None else
                           {"location_server": location_server_params})
    return quiet_run(loaded, RunOptions(rtf=math.inf, seed=seed, out_dir=out_dir, quiet=True)).document


def surveyed_fingerprints(run_dir: Path) -> list[Fingerprint]:
    """The fingerprints a survey over DDS added to its location server's database (source ``survey``)."""
    with LocationStore.open(run_dir / "location.db") as store:
        return [fingerprint for fingerprint in store.fingerprints() if fingerprint.source == "survey"]


def location_server_params(fingerprints: list[Fingerprint], folder: Path, name: str) -> Path:
    """A location_server parameter file whose database holds ``fingerprints`` only (a new file in ``folder``)."""
    database = (folder / f"{name}.db").resolve()
    with LocationStore.open(database, create=True) as store:
        store.add_fingerprints(fingerprints)
    shipped = yaml.safe_load((CONFIG_DIR / "params" / "location_server.yaml").read_text())
    shipped["location_server"]["ros__parameters"].update(database_file=str(database), create_database=False)
    params = folder / f"{name}_location_server.yaml"
    params.write_text(yaml.safe_dump(shipped))
    return params


def map_figures(site: Site, fingerprints: list[Fingerprint], seed: int) -> dict[str, Any]:
    median = Median.of(tier_one_errors(site, RadioMap(fingerprints), seed))
    return {"fingerprints": len(fingerprints), "tier_one_median_error_m": median.value,
            "tier_one_median_error_ci95_m": None if median.bounds is None else list(median.bounds)}


def mission_figures(documents: list[dict[str, Any]]) -> dict[str, Any]:
    arrived = [d for d in documents if d["success"]]
    finals = [d["metrics"]["final_error_m"] for d in documents if d["metrics"].get("final_error_m") is not None]
    return {"runs": len(documents), "arrived": len(arrived),
            "final_errors_m": [d["metrics"].get("final_error_m") for d in documents],
            "median_final_error_m": statistics.median(finals) if finals else None,
            "path_lengths_m": [d["metrics"].get("path_length_m") for d in documents],
            "messages": [d["message"] for d in documents]}


def survey_benchmark(seed: int, mission_seeds: int, out_dir: Path) -> dict[str, Any]:
    out_dir.mkdir(parents=True, exist_ok=True)
    survey = run(SURVEY_SCENARIO, seed, out_dir / "survey")
    fingerprints = {"dds": surveyed_fingerprints(Path(survey["run_dir"]))}
    world = load_world(WORLD_FILE)
    fingerprints["in_process"] = robot_survey(Site.of(world, RadioMap()), load_route_map(MAP_FILE), seed,
                                              SURVEY_SPACING_M)
    site = Site.of(world, RadioMap())       # the WiFi of the test points: both maps on the same draws
    figures: dict[str, Any] = {
        "seed": seed, "spacing_m": SURVEY_SPACING_M, "test_points": TEST_POINTS,
        "dds_survey": {key: survey.get(key) for key in ("success", "message", "sim_duration_s", "wall_duration_s")},
        "maps": {name: map_figures(site, prints, seed) for name, prints in fingerprints.items()}}
    missions: dict[str, Any] = {}
    for name in MAPS:
        params = location_server_params(fingerprints[name], out_dir, name)
        missions[name] = mission_figures([run(MISSION_SCENARIO, mission_seed, out_dir / name, params)
                                          for mission_seed in range(1, mission_seeds + 1)])
    figures["missions"] = missions
    return figures


def survey_lines(figures: dict[str, Any]) -> list[str]:
    lines = [f"robot survey of two_tier_home, seed {figures['seed']}, a scan every {figures['spacing_m']:g} m near "
             f"tag fixes; over DDS: {figures['dds_survey']['message']}"]
    for name in MAPS:
        radio, missions = figures["maps"][name], figures["missions"][name]
        interval = radio["tier_one_median_error_ci95_m"]
        lines.append(
            f"  {name:10s} {radio['fingerprints']:3d} fingerprints, tier one median error "
            f"{radio['tier_one_median_error_m'] * 100:.0f} cm"
            + (f" [{interval[0] * 100:.0f}, {interval[1] * 100:.0f}]" if interval else "")
            + f" at {figures['test_points']} points; two_tier_home on it: {missions['arrived']}/{missions['runs']} "
              f"arrived, final errors " + ", ".join("-" if e is None else f"{e * 100:.1f}"
                                                   for e in missions["final_errors_m"]) + " cm")
    return lines


def print_figures(figures: dict[str, Any], as_json: bool) -> None:
    print(json.dumps(figures) if as_json else "\n".join(survey_lines(figures)))
