"""The experiments' verbs, added to ``./rfidnav`` through the ``rfidnav.verbs`` entry points (see
:mod:`rfidnav_bringup.cli`): ``reproduce``, ``survey`` and ``bench``. Each ``add_*`` adds its sub-parser and
returns its handler; the heavy modules are imported only when a verb runs."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from rfidnav_bringup.cli import RUNS_DIR, Handler
from rfidnav_common.errors import ConfigError


def rtf_list(text: str) -> list[float]:
    """``--rtfs``: comma-separated positive numbers, ``max`` among them (infinite: the stepped clock unbounded)."""
    from rfidnav_bringup.cli import rtf_value

    values = [rtf_value(part) for part in text.split(",")]
    if not all(value > 0 for value in values):
        raise argparse.ArgumentTypeError(f"expected positive numbers or max, got '{text}'")
    return values


def float_list(text: str) -> list[float]:
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got '{text}'") from None
    if not all(math.isfinite(value) and value > 0 for value in values):
        raise argparse.ArgumentTypeError(f"expected positive numbers, got '{text}'")
    return values


def add_reproduce(verbs: argparse._SubParsersAction) -> Handler:
    reproduce = verbs.add_parser("reproduce", help="the papers' experiments in-process, beside the papers' figures")
    reproduce.add_argument("name", choices=["flc", "partitions", "two_tier", "topological"],
                           help="flc: paper 001 sec. V; partitions: paper 000 sec. 6; two_tier: paper 003 sec. 4.2; "
                                "topological: paper 004 sec. 5 and missions under read failures")
    reproduce.add_argument("--seeds", type=int, default=10, help="flc: seeds per setting")
    reproduce.add_argument("--runs", type=int, help="partitions: runs per (read range, level, method), default 250; "
                                                    "two_tier: runs per route, default 20; topological: missions "
                                                    "per miss rate, default 100")
    reproduce.add_argument("--out", type=Path, default=RUNS_DIR / "reproduce")
    reproduce.add_argument("--json", action="store_true")
    return run_reproduce


def add_calibrate(verbs: argparse._SubParsersAction) -> Handler:
    calibrate = verbs.add_parser("calibrate", help="fit a paper's unstated settings to its first experiment only")
    calibrate.add_argument("name", choices=["flc"], help="flc: paper 001's phase noise and output range, fitted "
                                                         "to Figs. 8/9 (the line experiments)")
    calibrate.add_argument("--out", type=Path, help="the parameter file to write (default: the shipped one, "
                                                    "config/params/flc_paper_calibrated.yaml)")
    calibrate.add_argument("--json", action="store_true")
    return run_calibrate


def run_calibrate(args: argparse.Namespace) -> int:
    from rfidnav_experiments.calibrate.flc import CALIBRATED_FILE, calibrate_flc

    return calibrate_flc(out=args.out or CALIBRATED_FILE, as_json=args.json)


def add_survey(verbs: argparse._SubParsersAction) -> Handler:
    survey = verbs.add_parser("survey", help="paper 003: build a radio map file for a scenario's world (in-process)")
    survey.add_argument("scenario", help="a scenario name or file; its world has the access points")
    how = survey.add_mutually_exclusive_group(required=True)
    how.add_argument("--grid", type=float, metavar="SPACING_M",
                     help="a site survey at known positions on a grid this many metres apart")
    how.add_argument("--robot", action="store_true",
                     help="the robot's own survey: it visits the map's landmarks and scans near its tag fixes")
    survey.add_argument("--seed", type=int, default=1)
    survey.add_argument("--out", type=Path, required=True, help="the radio map file to write (YAML)")
    return run_survey


def add_bench(verbs: argparse._SubParsersAction) -> Handler:
    bench = verbs.add_parser("bench", help="performance benchmarks (JSON figures)")
    bench.add_argument("name", choices=["flc", "rtf", "planner", "partitions", "location_server", "llrp"],
                       help="flc: fuzzy fast path vs scikit-fuzzy; rtf: a scenario over DDS at rising RTF; "
                            "planner: Algorithm 1 and a reader round in a 30 x 30 m field at r = 2 cm; "
                            "partitions: the navigations of paper 000 Figs. 12-14 in-process; "
                            "location_server: paper 003's tier-one locate over DDS; "
                            "llrp: the llrp_reader driver against llrpkit's LLRP emulator (latency, lossless rate)")
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--evaluations", type=int, default=2000, help="flc: evaluations per timing")
    bench.add_argument("--plans", type=int, default=200, help="planner: random segments planned")
    bench.add_argument("--runs", type=int, default=250, help="partitions: runs per (read range, level)")
    bench.add_argument("--method", choices=["paper", "filter", "filter_boom_spin"], default="paper",
                       help="partitions: the configuration (reproduce partitions' METHOD_FILES)")
    bench.add_argument("--scenario", default="hallway", help="rtf: the scenario to run")
    bench.add_argument("--rtfs", type=rtf_list, default=[1.0, 3.0, 5.0, 8.0, 12.0],
                       help="rtf: e.g. 1,2,5 or 1,5,max; the lowest is the reference")
    bench.add_argument("--clock", choices=("free", "stepped"), default="free",
                       help="rtf: the clock of the runs (free: how high an RTF the free-running clock stands; "
                            "stepped: whether the figures follow the seed at every RTF)")
    bench.add_argument("--hogs", type=int, default=0,
                       help="rtf: busy-loop processes kept running through the sweep (a loaded machine)")
    bench.add_argument("--tolerance", type=float, default=0.10, help="rtf: allowed RMSE growth over RTF 1")
    bench.add_argument("--seeds", type=int, default=3, help="rtf: runs per RTF (seeds 1..N)")
    bench.add_argument("--out", type=Path, default=RUNS_DIR / "bench_rtf")
    return run_bench


def run_reproduce(args: argparse.Namespace) -> int:
    if args.name == "partitions":
        from rfidnav_experiments.reproduce.partitions import RUNS_PER_CURVE, reproduce_partitions

        return reproduce_partitions(runs=args.runs or RUNS_PER_CURVE, out_dir=args.out, as_json=args.json)
    if args.name == "topological":
        from rfidnav_experiments.reproduce.topological import MISSIONS, reproduce_topological

        return reproduce_topological(missions=args.runs or MISSIONS, out_dir=args.out, as_json=args.json)
    if args.name == "two_tier":
        from rfidnav_experiments.reproduce.two_tier import RUNS, reproduce_two_tier

        return reproduce_two_tier(runs=args.runs or RUNS, out_dir=args.out, as_json=args.json)
    from rfidnav_experiments.reproduce.flc import reproduce_flc

    return reproduce_flc(seeds=args.seeds, out_dir=args.out, as_json=args.json)


def run_survey(args: argparse.Namespace) -> int:
    from rfidnav_bringup.scenario import load_scenario
    from rfidnav_experiments.runners.two_tier import survey
    from rfidnav_localization.radio_map_file import write_radio_map

    scenario = load_scenario(args.scenario)
    if scenario.route_map is None:
        raise ConfigError(str(scenario.map_file), "", "a survey needs a route map with tag_groups (this is a "
                                                     "topological map)")
    fingerprints, description = survey(scenario.world, scenario.route_map, args.grid, args.seed)
    write_radio_map(args.out, fingerprints, description)
    print(f"{len(fingerprints)} fingerprints ({description}) -> {args.out}")
    return 0


def run_bench(args: argparse.Namespace) -> int:
    if args.name == "rtf":
        return bench_rtf(args)
    if args.name == "location_server":
        from rfidnav_experiments.bench.location_server import benchmark as location_benchmark

        figures = location_benchmark()
        print(json.dumps(figures) if args.json else
              f"tier-one locate over DDS, {figures['requests']} requests on a {figures['fingerprints']}-fingerprint "
              f"map: p50 {figures['p50_ms']:.2f} ms, p99 {figures['p99_ms']:.2f} ms (the matcher alone "
              f"{figures['matcher_ms']:.3f} ms)")
        return 0
    if args.name == "llrp":
        from rfidnav_experiments.bench.llrp import bench_llrp

        return bench_llrp(as_json=args.json)
    if args.name in ("planner", "partitions"):
        return bench_partitions(args)
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

        figures = {**planning_benchmark(plans=args.plans), **reader_round_benchmark()}
        summary = (f"Algorithm 1, {figures['field_m']:g} x {figures['field_m']:g} m at r = "
                   f"{figures['read_range_m'] * 100:g} cm ({figures['tags']} tags): {figures['mean_ms']:.1f} ms "
                   f"per plan on average, p99 {figures['p99_ms']:.1f} ms, {figures['mean_partitions']:.0f} partitions "
                   f"per plan; "
                   f"the reader simulator's round over the same floor: {figures['reader_round_us']:.0f} us")
    else:
        from rfidnav_experiments.reproduce.partitions import benchmark

        figures = benchmark(runs=args.runs, method=args.method)
        summary = (f"{figures['navigations']} navigations ({args.method}) in {figures['wall_s']:.0f} s on "
                   f"{figures['workers']} workers: {figures['navigations_per_s']:.1f} per second, "
                   f"{figures['success_pct']:.1f} % reached the goal's partition")
    print(json.dumps(figures) if args.json else summary)
    return 0


def bench_rtf(args: argparse.Namespace) -> int:
    from rfidnav_bringup.scenario import load_scenario
    from rfidnav_experiments.bench.rtf import highest_usable_rtf, report, sweep

    rows = sweep(load_scenario(args.scenario), args.rtfs, list(range(1, args.seeds + 1)), args.out, args.clock,
                 args.hogs)
    print(report(args.scenario, rows, args.tolerance, args.json))
    return 0 if highest_usable_rtf(rows, args.tolerance) else 1
