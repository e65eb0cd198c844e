"""The experiments' verbs, added to ``./rfidnav`` through the ``rfidnav.verbs`` entry points (see
:mod:`rfidnav_bringup.cli`): ``reproduce``, ``survey`` and ``bench``. Each ``add_*`` adds its sub-parser and
returns its handler; the heavy modules are imported only when a verb runs."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from rfidnav_common.errors import ConfigError
from rfidnav_scenario.cli_types import (
    RUNS_DIR,
    Handler,
    checked_number,
    count_value,
    option_seconds,
    output_file,
    output_folder,
    positive_number,
    rtf_value,
    seed_value,
)

MAX_RUNS = 100_000          # runs, seeds, missions, plans, evaluations of one experiment
MAX_HOGS = 64               # busy loops beside a benchmark
MAX_GRID_SPACING_M = 1000.0


def rtf_list(text: str) -> list[float]:
    """``--rtfs``: comma-separated real-time factors, ``max`` among them (infinite: the stepped clock unbounded)."""
    return [rtf_value(part) for part in text.split(",")]


runs_value = count_value(MAX_RUNS)
hogs_value = checked_number(int, "a whole number", lambda hogs: 0 <= hogs <= MAX_HOGS,
                            lambda text: f"expected 0-{MAX_HOGS} busy loops, got {text}")
MAX_WORKERS = 256
workers_value = checked_number(int, "a whole number", lambda workers: 1 <= workers <= MAX_WORKERS,
                               lambda text: f"expected 1-{MAX_WORKERS} workers, got {text}")


PARTITION_METHODS = ("paper", "filter", "filter_boom_spin")


def partition_methods(text: str) -> list[str]:
    methods = [part.strip() for part in text.split(",")]
    unknown = [method for method in methods if method not in PARTITION_METHODS]
    if unknown:
        raise argparse.ArgumentTypeError(f"expected some of {', '.join(PARTITION_METHODS)}, got {text!r}")
    return list(dict.fromkeys(methods))


def worker_list(text: str) -> list[int]:
    return sorted({workers_value(part) for part in text.split(",")})


def scheduler_value(text: str) -> str:
    """``--scheduler``: a Dask scheduler's address, [tcp:// | tls://]host:port."""
    address = text.strip()
    _, _, rest = address.rpartition("://")
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536 or any(c.isspace() for c in address):
        raise argparse.ArgumentTypeError(f"expected a scheduler address such as tcp://10.0.0.5:8786, got {text!r}")
    return address
MAX_MIN_PAIRS = 1_000_000


def add_engine_options(parser: argparse.ArgumentParser) -> None:
    """Where an experiment's tasks run (rfidnav_experiments.engine): a local Dask cluster, or an existing one."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=workers_value, default=None,
                       help="worker processes of the local cluster (default: this machine's cores)")
    where.add_argument("--scheduler", type=scheduler_value, default=None, metavar="ADDRESS",
                       help="run the tasks on an existing Dask cluster, e.g. tcp://10.0.0.5:8786 (README, "
                            "\"Experiments on Dask, on this machine or a cluster\")")


def engine(args: argparse.Namespace, experiment: str = "", arguments: dict | None = None,
           tasks_file: Path | None = None):
    """The command's engine from its options; a reproduction's streams its results to ``tasks_file``."""
    from rfidnav_experiments.engine import EngineOptions, engine_for

    return engine_for(EngineOptions(workers=args.workers, scheduler=args.scheduler, tasks_file=tasks_file,
                                    resume=getattr(args, "resume", False), experiment=experiment,
                                    arguments=arguments or {}))


def add_calibrate(verbs: argparse._SubParsersAction) -> Handler:
    calibrate = verbs.add_parser("calibrate", help="fit a paper's unstated settings to its first experiment only; "
                                                   "measure the robot's antenna phase offset")
    names = calibrate.add_subparsers(dest="name", required=True, metavar="SETTING")
    flc = names.add_parser("flc", help="paper 001's phase noise and output range, fitted to Figs. 8/9 (the line "
                                       "experiments)")
    flc.add_argument("--out", type=output_file, help="the parameter file to write (default: the shipped one, "
                                              "config/params/flc_paper_calibrated.yaml)")
    flc.add_argument("--json", action="store_true")
    add_engine_options(flc)
    offset = names.add_parser("phase-offset", help="heading_controller's phase_difference_offset_rad from "
                                                   "/rfid/reads, the robot standing still under (or squarely in "
                                                   "front of) a tag")
    offset.add_argument("--out", type=output_file,
                        help="the --params file with the offset set, may be the same file (default: print only)")
    offset.add_argument("--json", action="store_true")
    offset.add_argument("--params", type=Path,
                        help="the heading_controller parameter file (its left and right antenna ports; the base of "
                             "--out); default: the shipped config/params/flc_tuned.yaml")
    offset.add_argument("--tag", help="the tag's id (EPC hex); default: the tag with the most same-channel pairs")
    offset.add_argument("--duration", type=option_seconds, default=20.0, help="seconds to listen once reads arrive")
    offset.add_argument("--wait", type=option_seconds, default=10.0,
                        help="seconds to wait for the first /rfid/reads message")
    offset.add_argument("--min-pairs", type=count_value(MAX_MIN_PAIRS), default=None,
                        help="fewest same-channel pairs to give an offset (default 50)")
    return run_calibrate


def run_calibrate(args: argparse.Namespace) -> int:
    if args.name == "phase-offset":
        from rfidnav_experiments.calibrate.phase_offset import MIN_PAIRS, calibrate_phase_offset
        from rfidnav_scenario.scenario import CONFIG_DIR

        args.params = args.params or CONFIG_DIR / "params" / "flc_tuned.yaml"
        if not args.params.is_file():
            raise ConfigError("--params", "", f"no such parameter file: {args.params}")
        min_pairs = MIN_PAIRS if args.min_pairs is None else args.min_pairs
        return calibrate_phase_offset(args.params, args.out, args.tag, args.duration, args.wait, min_pairs,
                                      args.json)
    from rfidnav_experiments.calibrate.flc import CALIBRATED_FILE, calibrate_flc

    with engine(args):
        return calibrate_flc(out=args.out or CALIBRATED_FILE, as_json=args.json)


def add_survey(verbs: argparse._SubParsersAction) -> Handler:
    survey = verbs.add_parser("survey", help="paper 003: build a radio map file for a scenario's world (in-process)")
    survey.add_argument("scenario", help="a scenario name or file; its world has the access points")
    how = survey.add_mutually_exclusive_group(required=True)
    how.add_argument("--grid", type=positive_number("a spacing in metres", MAX_GRID_SPACING_M), metavar="SPACING_M",
                     help="a site survey at known positions on a grid this many metres apart")
    how.add_argument("--robot", action="store_true",
                     help="the robot's own survey: it visits the map's landmarks and scans near its tag fixes")
    survey.add_argument("--seed", type=seed_value, default=1)
    survey.add_argument("--out", type=output_file, required=True, help="the radio map file to write (YAML)")
    return run_survey


def add_bench(verbs: argparse._SubParsersAction) -> Handler:
    bench = verbs.add_parser("bench", help="performance benchmarks (JSON figures)")
    names = bench.add_subparsers(dest="name", required=True, metavar="BENCHMARK")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--json", action="store_true", help="print the figures as JSON on stdout")
    flc = names.add_parser("flc", parents=[common], help="the fuzzy controller's fast path against scikit-fuzzy")
    flc.add_argument("--evaluations", type=runs_value, default=2000, help="evaluations per timing")
    rtf = names.add_parser("rtf", parents=[common], help="a scenario over DDS at rising RTF")
    rtf.add_argument("--scenario", default="hallway", help="the scenario to run")
    rtf.add_argument("--rtfs", type=rtf_list, default=[1.0, 3.0, 5.0, 8.0, 12.0],
                     help="e.g. 1,2,5 or 1,5,max; the lowest is the reference")
    rtf.add_argument("--clock", choices=("free", "stepped"), default="free",
                     help="the clock of the runs (free: how high an RTF the free-running clock stands; stepped: "
                          "whether the figures follow the seed at every RTF)")
    rtf.add_argument("--hogs", type=hogs_value, default=0,
                     help="busy-loop processes kept running through the sweep (a loaded machine)")
    rtf.add_argument("--tolerance", type=positive_number("a fraction", 100.0), default=0.10,
                     help="allowed RMSE growth over the lowest RTF")
    rtf.add_argument("--seeds", type=runs_value, default=3, help="runs per RTF (seeds 1..N)")
    rtf.add_argument("--out", type=output_folder, default=RUNS_DIR / "bench_rtf", help="folder for the runs")
    planner = names.add_parser("planner", parents=[common], help="Algorithm 1 and a reader round in a 30 x 30 m "
                                                                 "field at r = 2 cm")
    planner.add_argument("--plans", type=runs_value, default=200, help="random segments planned")
    partitions = names.add_parser("partitions", parents=[common], help="the navigations of paper 000 Figs. 12-14 "
                                                                       "in-process")
    partitions.add_argument("--runs", type=runs_value, default=250, help="runs per (read range, level)")
    partitions.add_argument("--methods", "--method", dest="methods", type=partition_methods,
                            default=["paper", "filter"],
                            help="comma-separated configurations (reproduce partitions' METHOD_FILES: paper, filter, "
                                 "filter_boom_spin), each over the whole grid; default paper,filter")
    add_engine_options(partitions)
    topological = names.add_parser("topological", parents=[common], help="paper 004: missions on the evaluation "
                                                                         "floors at 0/10/20/30 %% misses, both loops")
    topological.add_argument("--runs", type=runs_value, default=100, help="missions per (loop, miss rate)")
    add_engine_options(topological)
    scaling = names.add_parser("scaling", parents=[common], help="the same slice of a reproduction on local "
                                                                 "clusters of 1, 2, ... workers")
    scaling.add_argument("--experiment", choices=["partitions", "topological"], default="partitions")
    scaling.add_argument("--workers", type=worker_list, default=None,
                         help="comma-separated worker counts (default: 1, 2 and this machine's cores)")
    scaling.add_argument("--runs", type=runs_value, default=5,
                         help="runs per (read range, level, method) or missions per (loop, miss rate)")
    routes = names.add_parser("routes", parents=[common], help="paper 001's routes and long_legs in-process with "
                                                               "the shipped files, both controllers")
    routes.add_argument("--seeds", type=runs_value, default=3, help="runs per (route, controller): seeds 1..N")
    add_engine_options(routes)
    names.add_parser("reader", parents=[common], help="the reader simulator's round among 1k, 10k and 100k listed "
                                                      "ceiling tags")
    names.add_parser("fused", parents=[common], help="the fused localizer's update per round, per kind of evidence, "
                                                     "on one core")
    names.add_parser("location_server", parents=[common], help="paper 003's tier-one locate over DDS")
    survey = names.add_parser("survey", parents=[common], help="paper 003's robot survey over DDS beside the "
                                                               "in-process one: both radio maps, and missions on each")
    survey.add_argument("--seed", type=seed_value, default=1, help="the surveys' seed")
    survey.add_argument("--missions", type=runs_value, default=3,
                        help="two_tier_home runs over DDS on each radio map (seeds 1..N)")
    survey.add_argument("--out", type=output_folder, default=RUNS_DIR / "bench_survey", help="folder for the runs")
    names.add_parser("llrp", parents=[common], help="the llrp_reader driver against llrpkit's LLRP emulator "
                                                    "(latency, lossless rate)")
    return run_bench


def run_survey(args: argparse.Namespace) -> int:
    """The scenario loaded without its radio map if that is not written yet (this writes one), the survey planned
    (refusals in one line, the grid's unreachable points warned of on stderr), then run."""
    from rfidnav_common.progress import stage
    from rfidnav_experiments.runners.two_tier import plan_survey, survey, survey_warnings
    from rfidnav_localization.radio_map_file import write_radio_map
    from rfidnav_scenario.scenario import load_scenario

    scenario = load_scenario(args.scenario, radio_map_may_be_missing=True)
    if scenario.route_map is None:
        raise ConfigError(str(scenario.map_file), "", "a survey needs a route map with tag_groups (this is a "
                                                     "topological map)")
    grid = plan_survey(scenario.world, scenario.route_map, scenario.map_file, args.grid, scenario.robot[:2],
                       f"{scenario.path}: robot")
    for warning in survey_warnings(grid) if grid is not None else []:
        print(f"rfidnav survey: warning: {warning}", file=sys.stderr)
    with stage(f"survey {scenario.name}"):
        fingerprints, description = survey(scenario.world, scenario.route_map, grid, args.seed)
    write_radio_map(args.out, fingerprints, description)
    print(f"{len(fingerprints)} fingerprints ({description}) -> {args.out}")
    return 0


def run_bench(args: argparse.Namespace) -> int:
    """The benchmark ``args.name``; those without a pool of runs (which shows its own count) show a spinner."""
    from rfidnav_common.progress import stage

    if args.name == "rtf":
        return bench_rtf(args)
    if args.name == "partitions":
        with engine(args):
            return bench_partitions(args)
    if args.name == "topological":
        from rfidnav_experiments.bench.experiments import topological_benchmark

        with engine(args):
            figures = topological_benchmark(args.runs)
        print(json.dumps(figures) if args.json else
              f"{figures['missions']} missions on {figures['floor']} ({figures['runs']} per loop and miss rate) in "
              f"{figures['wall_s']:.0f} s on {figures['workers']} workers: {figures['missions_per_s']:.2f} per second")
        return 0
    if args.name == "scaling":
        from rfidnav_experiments.bench.experiments import scaling_benchmark, scaling_lines

        rows = scaling_benchmark(args.experiment, args.workers, args.runs)
        print(json.dumps(rows) if args.json else "\n".join(scaling_lines(rows)))
        return 0 if all(row["identical"] for row in rows) else 1
    if args.name == "survey":
        from rfidnav_experiments.bench.survey import print_figures, survey_benchmark

        print_figures(survey_benchmark(args.seed, args.missions, args.out), args.json)
        return 0
    if args.name == "routes":
        from rfidnav_experiments.bench.routes import bench_routes

        with engine(args):
            return bench_routes(args.seeds, args.json)
    with stage(f"bench {args.name}"):
        return timed_bench(args)


def timed_bench(args: argparse.Namespace) -> int:
    if args.name == "location_server":
        from rfidnav_experiments.bench.location_server import benchmark as location_benchmark

        figures = location_benchmark()
        print(json.dumps(figures) if args.json else
              f"tier-one locate over DDS, {figures['requests']} requests on a {figures['fingerprints']}-fingerprint "
              f"map: p50 {figures['p50_ms']:.2f} ms, p99 {figures['p99_ms']:.2f} ms (the matcher alone "
              f"{figures['matcher_ms']:.3f} ms)")
        return 0
    if args.name == "fused":
        from rfidnav_experiments.bench.fused import fused_benchmark, fused_lines

        fused_figures = fused_benchmark()
        print(json.dumps(fused_figures) if args.json else "\n".join(fused_lines(fused_figures)))
        return 0
    if args.name == "llrp":
        from rfidnav_experiments.bench.llrp import bench_llrp

        return bench_llrp(as_json=args.json)
    if args.name == "planner":
        return bench_partitions(args)
    if args.name == "reader":
        from rfidnav_experiments.bench.reader import TAG_COUNTS, listed_tags_benchmark

        figures = listed_tags_benchmark()
        print(json.dumps(figures) if args.json else
              "reader simulator round (reader_uhf_2ant, 2 m between ceiling tags): " + ", ".join(
                  f"{figures[f'round_us_{count}']:.0f} us at {count:,} tags ({figures[f'reads_per_round_{count}']:.0f}"
                  f" reads)" for count in TAG_COUNTS))
        return 0
    from rfidnav_experiments.bench.fuzzy import benchmark

    figures = benchmark(evaluations=args.evaluations)
    if args.json:
        print(json.dumps(figures))
    else:
        print(f"fuzzy controller per evaluation: scikit-fuzzy {figures['reference_us']:.1f} us, "
              f"fast path {figures['fast_us']:.2f} us, speed-up {figures['speedup']:.0f}x")
    return 0


def bench_partitions(args: argparse.Namespace) -> int:
    if args.name == "planner":
        from rfidnav_experiments.bench.planner import planning_benchmark, reader_round_benchmark

        figures: dict[str, Any] = {**planning_benchmark(plans=args.plans), **reader_round_benchmark()}
        summary = (f"Algorithm 1, {figures['field_m']:g} x {figures['field_m']:g} m at r = "
                   f"{figures['read_range_m'] * 100:g} cm ({figures['tags']} tags): {figures['mean_ms']:.1f} ms "
                   f"per plan on average, p99 {figures['p99_ms']:.1f} ms, {figures['mean_partitions']:.0f} partitions "
                   f"per plan; "
                   f"the reader simulator's round over the same floor: {figures['reader_round_us']:.0f} us")
    else:
        from rfidnav_experiments.reproduce.partitions import benchmark

        per_method = {method: benchmark(runs=args.runs, method=method) for method in args.methods}
        figures = {"methods": per_method, "wall_s": round(sum(f["wall_s"] for f in per_method.values()), 2),
                   "navigations": sum(f["navigations"] for f in per_method.values())}
        summary = "\n".join(
            [f"{f['navigations']} navigations ({method}) in {f['wall_s']:.0f} s on {f['workers']} workers: "
             f"{f['navigations_per_s']:.1f} per second, {f['success_pct']:.1f} % reached the goal's partition"
             for method, f in per_method.items()]
            + [f"all: {figures['navigations']} navigations in {figures['wall_s']:.0f} s"])
    print(json.dumps(figures) if args.json else summary)
    return 0


def bench_rtf(args: argparse.Namespace) -> int:
    from rfidnav_experiments.bench.rtf import highest_usable_rtf, report, sweep
    from rfidnav_scenario.scenario import load_scenario

    rows = sweep(load_scenario(args.scenario), args.rtfs, list(range(1, args.seeds + 1)), args.out, args.clock,
                 args.hogs)
    print(report(args.scenario, rows, args.tolerance, args.json))
    return 0 if highest_usable_rtf(rows, args.tolerance) else 1
