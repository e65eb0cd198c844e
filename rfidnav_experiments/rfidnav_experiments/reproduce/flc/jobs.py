"""reproduce flc: the runs as engine tasks (each parameter set on the paper routes' evaluation seeds and on each
random route once), grouped by (parameter set, scenario)."""

from __future__ import annotations

from rfidnav_experiments.calibrate.flc import calibrated_reader, timeout_s
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.flc.conditions import (
    HEADING_UPDATE,
    PARAM_SETS,
    RANDOM,
    SCENARIOS,
    params_file,
    scenario_named,
)
from rfidnav_experiments.runners.random_routes import is_random_route, route_name
from rfidnav_experiments.runners.tag_route import RouteRun, controller_parameters, run_tag_route


def run_one(job: tuple[str, str, int]) -> tuple[str, RouteRun]:
    """One (parameter set, scenario, seed) run in the calibrated conditions (an engine task)."""
    params, scenario_name, seed = job
    scenario = scenario_named(scenario_name)
    controller = controller_parameters(scenario, params_file(params), seed)
    return params, run_tag_route(scenario, controller, seed, reader=calibrated_reader(scenario, seed),
                                 timeout_s=timeout_s(scenario), heading_update=HEADING_UPDATE)


def jobs(seeds: list[int], route_seeds: list[int] | None = None) -> list[tuple[str, str, int]]:
    """The paper routes on the evaluation seeds and each random route once, on its own seed."""
    # Longest routes first, so the two workers do not end with one long hallway run each.
    order = sorted(SCENARIOS, key=lambda name: -len(scenario_named(name).mission.goal["tag_ids"]))
    randoms = [(params, route_name(seed), seed) for seed in (route_seeds or []) for params in PARAM_SETS]
    return randoms + [(params, name, seed) for name in order for params in PARAM_SETS for seed in seeds]


def run_all(seeds: list[int], route_seeds: list[int] | None = None) -> dict[tuple[str, str], list[RouteRun]]:
    """Every run, grouped by (parameter set, scenario; the random routes together as RANDOM) and sorted by seed."""
    results: dict[tuple[str, str], list[RouteRun]] = {}
    for params, run in run_tasks(run_one, jobs(seeds, route_seeds), "reproduce flc"):
        results.setdefault((params, RANDOM if is_random_route(run.scenario) else run.scenario), []).append(run)
    return {key: sorted(runs, key=lambda run: run.seed) for key, runs in results.items()}
