"""``./rfidnav VERB``: the command line (the entry script has already run the set-up).

The verbs of this package run and inspect node graphs. Packages above it add their own verbs (the experiments'
``reproduce``, ``bench`` and ``survey``) through the ``rfidnav.verbs`` entry-point group, as ros2cli's
extensions do, so that this package never imports one above it: each entry point names a function
``add_verb(verbs) -> handler`` that adds its sub-parser to ``verbs`` and returns the function that runs it.
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import re
import signal
import subprocess
import sys
import typing
from importlib.metadata import entry_points
from pathlib import Path

from rfidnav_common.errors import ConfigError, RfidnavError
from rfidnav_common.step_ledger import CLOCKS
from rfidnav_scenario.cli_types import (
    MAX_DOMAIN_ID,
    RUNS_DIR,
    WORKSPACE,
    Handler,
    checked_number,
    count_value,
    domain_id,
    key_value,
    option_rate,
    option_seconds,
    output_file,
    output_folder,
    port_number,
    rtf_value,
    seconds_value,
    seed_value,
    start_seconds,
    topic_name,
    unwritable,
)

DEMO_SCENARIO = "hallway"
DEMO_RTF = 3.0
VERB_ENTRY_POINTS = "rfidnav.verbs"
LIVE_PORT = 8765   # Foxglove's default WebSocket port
MAX_ECHO_COUNT = 1_000_000

# test --under-load: 0 (the default, an idle machine) to 64 busy loops.
BUSY_LOOPS_VALUE = checked_number(int, "a whole number", lambda count: 0 <= count <= 64,
                                  lambda text: f"expected a whole number 0-64, got {text}")


def bag_size_value(text: str) -> int:
    """``--max-bag-size``: 0 (one file) or at least the smallest split size rosbag2's MCAP plugin takes."""
    from rfidnav_bag.writer import MIN_SPLIT_SIZE  # here, not at the top: it loads mcap (~0.2 s) for every verb

    parse = checked_number(int, "a number of bytes", lambda size: size == 0 or size >= MIN_SPLIT_SIZE,
                           lambda text: f"expected 0 (one file) or at least {MIN_SPLIT_SIZE} bytes, got {int(text)}")
    return parse(text)


SPLIT_RUN_PARTS = ("robot", "station")   # rfidnav_bringup.run_plan.PARTS (not imported: 0.8 s of the CLI's start)
PARTITION_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")


def discovery_server_address(text: str) -> tuple[str, int]:
    from rfidnav_bringup.discovery_server import server_address

    try:
        return server_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def partition_name(text: str) -> str:
    """--partition: a DDS partition name of letters, digits, '_', '.' and '-' (at most 64)."""
    if not PARTITION_NAME.fullmatch(text):
        raise argparse.ArgumentTypeError(f"expected 1-64 letters, digits, '_', '.' or '-', got '{text}'")
    return text


def add_graph_options(parser: argparse.ArgumentParser, what: str, default_domain: str,
                      default_discovery: str | None = "localhost") -> None:
    """--domain and --discovery: which DDS graph ``what`` joins."""
    parser.add_argument("--domain", type=domain_id, metavar="N",
                        help=f"the ROS domain of the {what} (0-{MAX_DOMAIN_ID}); default: {default_domain}")
    parser.add_argument("--discovery", choices=("localhost", "subnet"), default=default_discovery,
                        help=f"ROS_AUTOMATIC_DISCOVERY_RANGE of the {what}: localhost "
                             f"({'default; ' if default_discovery == 'localhost' else ''}graphs never mix across "
                             "machines) or subnet (drivers or a viewer on another machine)"
                             + ("" if default_discovery else "; default: $ROS_AUTOMATIC_DISCOVERY_RANGE, else "
                                "localhost"))


def add_run_options(parser: argparse.ArgumentParser, default_rtf: float) -> None:
    parser.add_argument("--rtf", type=rtf_value, default=default_rtf,
                        help="real-time factor (sim s per wall s): a ceiling with the stepped clock, which 'max' "
                             "lifts; the rate itself with --clock free")
    parser.add_argument("--clock", choices=CLOCKS, default="stepped",
                        help="stepped (default): the simulator waits for our nodes to answer each step, so a run "
                             "follows its seed, not the machine's load; free: free-running at the RTF")
    parser.add_argument("--seed", type=seed_value, default=1, help="run seed (every node derives its own)")
    parser.add_argument("--out", type=output_folder, default=RUNS_DIR, help="folder for the run folder")
    parser.add_argument("--robot", metavar="PROFILE",
                        help="run the roles a robot profile (config/robots/PROFILE.yaml) names with its drivers")
    parser.add_argument("--swap", type=key_value, action="append", default=[], metavar="ROLE=CMD",
                        help="replace a role: ROLE=pkg:executable or ROLE='command line'")
    parser.add_argument("--params", type=key_value, action="append", default=[], metavar="ROLE=FILE",
                        help="replace a role's parameter file")
    parser.add_argument("--no-record", action="store_true", help="do not record a bag")
    parser.add_argument("--quiet", action="store_true",
                        help="print only the summary (and the line that says how to reach the graph)")
    add_graph_options(parser, "run", "the first free one of 51-101")
    parser.add_argument("--compress", action="store_true",
                        help="compress the bag's MCAP chunks with zstd (rosbag2's MCAP 'compression: Zstd')")
    parser.add_argument("--max-bag-size", type=bag_size_value, default=0, metavar="BYTES",
                        help="split the bag into files bag_0.mcap, bag_1.mcap, ... of about BYTES (0: one file)")
    parser.add_argument("--max-bag-duration", type=seconds_value, default=0.0, metavar="SECONDS",
                        help="split the bag into files of SECONDS of bag time (sim time when simulated; 0: no)")
    parser.add_argument("--live", nargs="?", type=port_number, const=LIVE_PORT, metavar="PORT",
                        help=f"serve the running graph to Foxglove over its WebSocket protocol (port {LIVE_PORT})")


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser, a bad option told in one line (``rfidnav run: error: argument --out: ...``) rather than
    after the verb's usage, which ``--help`` shows; its sub-parsers (every verb's) are of this class too."""

    def error(self, message: str) -> typing.NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def parser() -> tuple[argparse.ArgumentParser, dict[str, Handler]]:
    """The command line and the handler of each verb, this package's and those the entry points add."""
    top = OneLineParser(prog="rfidnav", description="RFID navigation for ROS 2 Jazzy (see README.md)")
    verbs = top.add_subparsers(dest="verb", required=True)
    verbs.add_parser("setup", help="create/refresh .venv, build rfidnav_msgs, install packages")
    demo = verbs.add_parser("demo", help=f"the {DEMO_SCENARIO} scenario over DDS, about a minute")
    add_run_options(demo, DEMO_RTF)
    test = verbs.add_parser("test", help="ruff, mypy and the test suite (-m unit: the fast tier)")
    test.add_argument("--no-lint", action="store_true", help="skip ruff and mypy")
    test.add_argument("--under-load", type=BUSY_LOOPS_VALUE, default=0, metavar="N",
                      help="keep N busy loops running beside the tests (a loaded machine: "
                           "./rfidnav test --under-load 2 -m 'node or graph'); pytest's --durations=30 lists the "
                           "slowest tests")
    # One more than the cores: a graph test spends much of its wall time waiting (a paced clock, nodes starting),
    # which a third process on two cores fills (docs/install.md has the figures).
    test.add_argument("--workers", type=count_value(64), default=(os.cpu_count() or 1) + 1, metavar="N",
                      help="pytest processes (pytest-xdist), each taking whole modules, so that a module's shared "
                           "run is made once; default: one per core and one more (%(default)s here); 1: in this "
                           "process")
    test.add_argument("pytest_args", nargs=argparse.REMAINDER, help="passed to pytest, e.g. -m unit or a test file")
    run = verbs.add_parser("run", help="one mission through the real node graph")
    run.add_argument("scenario", help="scenario name (config/scenarios/NAME.yaml) or path")
    run.add_argument("--goal", help="mission goal as YAML, replacing the scenario's, e.g. '{tag_ids: [C1]}'")
    run.add_argument("--part", choices=SPLIT_RUN_PARTS,
                     help="start only this computer's part of a graph split between two (README, \"One run on two "
                          "computers\"): robot (simulators and drivers) or station (the rest, the mission and the "
                          "bag); needs --domain and --partition, the same on both")
    run.add_argument("--partition", type=partition_name, metavar="NAME",
                     help="the run's DDS partition, instead of an unguessable one: what both parts of a split run "
                          "share")
    run.add_argument("--discovery-server", type=discovery_server_address, metavar="ADDRESS[:PORT]",
                     help="find the graph through this Fast DDS Discovery Server (./rfidnav discovery-server), not by "
                          "multicast; implies --discovery subnet")
    add_run_options(run, 1.0)
    replay = verbs.add_parser("replay", help="republish a bag")
    replay.add_argument("bag", type=Path)
    replay.add_argument("--rate", type=option_rate, default=1.0, help="playback speed (1: as recorded)")
    replay.add_argument("--topics", nargs="+", type=topic_name, default=[], help="republish only these topics")
    replay.add_argument("--loop", action="store_true")
    replay.add_argument("--clock", action="store_true", help="publish /clock from the bag's time")
    replay.add_argument("--start", type=start_seconds, default=0.0, help="skip the first S seconds")
    add_graph_options(replay, "replay", "a free one of 51-101, leased as a run leases one")
    bag = verbs.add_parser("bag", help="bag tools")
    bag_verbs = bag.add_subparsers(dest="bag_verb", required=True)
    info = bag_verbs.add_parser("info", help="topics, types, counts, duration (of an unfinished bag: what was lost)")
    info.add_argument("bag", type=Path, metavar="RUN_OR_BAG")
    info.add_argument("--json", action="store_true")
    recover = bag_verbs.add_parser("recover", help="a finalised copy of a bag that was not closed or is damaged")
    recover.add_argument("bag", type=Path, metavar="RUN_OR_BAG")
    recover.add_argument("--out", type=Path, help="the bag folder to write (default: beside it, BAG_recovered)")
    map_parser = verbs.add_parser("map", help="paper 004: topological map tools")
    map_verbs = map_parser.add_subparsers(dest="map_verb", required=True)
    check = map_verbs.add_parser("check", help="every problem of a topological map, one line each: its own rules "
                                               "and the world generator's (python -m rfidnav_sim.building)")
    check.add_argument("map", type=Path)
    check.add_argument("--robot-only", action="store_true",
                       help="only the map's own rules: the map of a floor drawn by hand, not generated from it "
                            "(building_eval)")
    draw = map_verbs.add_parser("draw", help="a PNG of a topological map: compass-placed edges and tag ids")
    draw.add_argument("map", type=Path)
    draw.add_argument("--out", type=output_file, help="the PNG to write (default: beside the map, .png)")
    echo = verbs.add_parser("echo", help="print a topic's messages as YAML (checking a driver alone)")
    echo.add_argument("topic", type=topic_name)
    echo.add_argument("--count", type=count_value(MAX_ECHO_COUNT), default=5, help="messages to print, then exit 0")
    echo.add_argument("--wait", type=option_seconds, default=10.0, help="seconds to wait for a publisher")
    echo.add_argument("--timeout", type=option_seconds, default=30.0,
                      help="seconds to wait for the messages (else exit 2)")
    add_graph_options(echo, "graph to listen to", "$ROS_DOMAIN_ID, else 0", default_discovery=None)
    server = verbs.add_parser("discovery-server", help="a Fast DDS Discovery Server for a graph split between "
                                                       "computers (run --discovery-server)")
    server.add_argument("--listen", type=discovery_server_address, required=True, metavar="ADDRESS[:PORT]",
                        help="this computer's address the parts reach it at (port default 11811)")
    view = verbs.add_parser("view", help="serve a recorded run to Foxglove with its timeline (WebSocket)")
    view.add_argument("bag", type=Path, metavar="RUN_OR_BAG")
    view.add_argument("--port", type=lambda text: port_number(text, lowest=0), default=LIVE_PORT,
                      help=f"TCP port (default {LIVE_PORT}; 0: any free port)")
    view.add_argument("--rate", type=option_rate, default=1.0, help="playback speed until Foxglove sets its own")
    report = verbs.add_parser("report", help="plots and recomputed metrics of a run")
    report.add_argument("run", type=Path)
    report.add_argument("--json", action="store_true")
    report.add_argument("--out", type=output_folder,
                        help="folder for the plots (created if missing; default: the run folder)")
    handlers = dict(VERBS)
    for extension in entry_points(group=VERB_ENTRY_POINTS):
        handlers[extension.name] = extension.load()(verbs)
    return top, handlers


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, ending a verb as Ctrl-C (KeyboardInterrupt) does."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def stop_verb(signum: int, _frame: object) -> None:
    raise Stopped(signum)


def main(argv: list[str] | None = None) -> int:
    # SIGTERM and SIGHUP end every verb as Ctrl-C does (run and replay handle all three themselves while they run).
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, stop_verb)
    command_line, handlers = parser()
    args, extra = command_line.parse_known_args(argv)
    if extra and args.verb != "test":
        command_line.error(f"unrecognized arguments: {' '.join(extra)}")
    if args.verb == "test":
        args.pytest_args = [*extra, *args.pytest_args]   # pytest options such as -q or -k pass through
    try:
        return handlers[args.verb](args)
    except (RfidnavError, ConfigError) as error:
        print(f"rfidnav {args.verb}: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as interrupt:
        return 128 + getattr(interrupt, "signum", signal.SIGINT)


def verb_setup(_args) -> int:
    print("rfidnav setup: ready")
    return 0


def verb_run(args, scenario_name: str | None = None) -> int:
    from rfidnav_bringup.orchestrator import Orchestrator
    from rfidnav_bringup.run_plan import RunOptions
    from rfidnav_bringup.summary import print_summary
    from rfidnav_common.config import load_yaml_text
    from rfidnav_scenario.scenario import load_scenario

    goal = None
    if getattr(args, "goal", None):
        goal = load_yaml_text(args.goal, "--goal")
        if not isinstance(goal, dict):
            raise ConfigError("--goal", "", "expected a YAML mapping of goal fields")
    scenario = load_scenario(scenario_name or args.scenario, swaps=dict(args.swap),
                             param_files={role: Path(file) for role, file in args.params}, goal=goal,
                             robot_profile_name=getattr(args, "robot", None))
    for warning in scenario.warnings:
        print(f"rfidnav {args.verb}: warning: {warning}", file=sys.stderr)
    options = RunOptions(rtf=args.rtf, clock=args.clock, seed=args.seed, out_dir=args.out,
                         record=not args.no_record, live_port=args.live, quiet=args.quiet, domain=args.domain,
                         discovery="subnet" if getattr(args, "discovery_server", None) else args.discovery,
                         compress=args.compress, max_bag_size=args.max_bag_size,
                         max_bag_duration_s=args.max_bag_duration, part=getattr(args, "part", None),
                         partition=getattr(args, "partition", None),
                         discovery_server=getattr(args, "discovery_server", None))
    if options.part is not None and options.domain is None:
        raise ConfigError("--part", "", "a split run's two parts meet in one ROS domain: give it with --domain")
    orchestrator = Orchestrator(scenario, options)
    summary = orchestrator.run()
    if not orchestrator.terminal_lost:
        print_summary(summary)
    return orchestrator.exit_code


def verb_demo(args) -> int:
    code = verb_run(args, DEMO_SCENARIO)
    runs = sorted(p for p in args.out.glob(f"*_{DEMO_SCENARIO}*") if (p / "summary.json").exists())
    if runs and (runs[-1] / "bag").exists():
        from rfidnav_bringup.report import write_report

        _, plots = write_report(runs[-1])
        print("plots:", *plots, sep="\n  ")
        print(f"open the .mcap files of {runs[-1] / 'bag'} in Foxglove, or serve it: ./rfidnav view {runs[-1]}")
    return code


LINTERS = (("ruff", ["-m", "ruff", "check", "--quiet", "."]), ("mypy", ["-m", "mypy"]))   # ruff.toml, mypy.ini


def pytest_command(pytest_args: list[str], cwd: Path, workers: int = 1) -> list[str]:
    """pytest on exactly what it is given, from the workspace (so that pytest.ini's ``testpaths``, the whole of
    test/, applies when no file or id is given); a file or id that exists from ``cwd`` is made absolute. With
    ``workers`` above 1, pytest-xdist's processes take one module at a time (``loadscope``): a module's shared
    run (a module-scoped fixture) is then made once, not once per worker."""
    def absolute(arg: str) -> str:
        path = arg.split("::", 1)[0]
        return str(cwd / arg) if not arg.startswith("-") and path and (cwd / path).exists() else arg

    parallel = ["-n", str(workers), "--dist", "loadscope"] if workers > 1 else []
    return [sys.executable, "-m", "pytest", *parallel, *(absolute(arg) for arg in pytest_args)]


def verb_test(args) -> int:
    """ruff and mypy on the workspace (unless --no-lint), then pytest (the tiers: ``-m unit`` and the like, see
    test/conftest.py)."""
    if not (WORKSPACE / "test").is_dir():
        print(f"rfidnav test: no test/ beside {WORKSPACE}: the suite runs from the source tree (./rfidnav test), "
              "or from a colcon workspace with colcon test", file=sys.stderr)
        return 2
    if not args.no_lint:
        for name, command in LINTERS:
            code = subprocess.call([sys.executable, *command], cwd=WORKSPACE)
            if code != 0:
                print(f"rfidnav test: {name} found problems (exit {code}); nothing tested", file=sys.stderr)
                return code
    from rfidnav_bringup.processes import cpu_hogs

    # The busy loops are said to the tests too: one that sets up a loaded machine of its own adds only what is missing.
    env = dict(os.environ, ROS_PYTHON_CHECK_FIELDS="1", PYTHONDONTWRITEBYTECODE="1",
               RFIDNAV_TEST_BUSY_LOOPS=str(args.under_load))
    with cpu_hogs(args.under_load):
        return subprocess.call(pytest_command(args.pytest_args, Path.cwd(), args.workers), env=env, cwd=WORKSPACE)


def verb_replay(args) -> int:
    from rfidnav_bag.bags import bag_info
    from rfidnav_bringup.processes import RUN_DOMAINS, DomainLease, child_environment, reach_text, run_supervised
    from rfidnav_bringup.report import locate_run

    _, bag = locate_run(args.bag)
    # Fails early, with one clear message, on a missing or truncated bag or a topic it does not hold.
    bag_info(bag).selected(args.topics, "--topics", "")
    # A leased domain on this machine by default: a replay republishes the recorded /cmd_vel, which must reach no
    # robot and no other run.
    with DomainLease(RUN_DOMAINS if args.domain is None else range(args.domain, args.domain + 1)) as lease:
        print(f"replaying {bag} on {reach_text(lease.domain_id, args.discovery)}", file=sys.stderr, flush=True)
        return run_supervised(player_command(bag, args), child_environment(lease.domain_id, args.discovery),
                              lease.handle)


def verb_discovery_server(args) -> int:
    from rfidnav_bringup.discovery_server import server_command
    from rfidnav_bringup.processes import run_supervised

    command, env = server_command(*args.listen)
    print(f"discovery server on {args.listen[0]}:{args.listen[1]}: run each part with --discovery-server "
          f"{args.listen[0]}:{args.listen[1]}", file=sys.stderr, flush=True)
    return run_supervised(command, env)


def player_command(bag: Path, args: argparse.Namespace) -> list[str]:
    from rfidnav_common.install import resolve_executable

    command = resolve_executable("rfidnav_bag", "player") + [
        "--ros-args", "-p", f"bag:={bag.resolve()}", "-p", f"rate:={float(args.rate)}",
        "-p", f"loop:={str(args.loop).lower()}", "-p", f"clock:={str(args.clock).lower()}",
        "-p", f"start_s:={float(args.start)}"]
    if args.topics:
        command += ["-p", f"topics:={json.dumps(args.topics)}"]
    return command


def verb_bag(args) -> int:
    from rfidnav_bag.bags import bag_info, format_bag_info
    from rfidnav_bringup.report import locate_run

    _, bag = locate_run(args.bag)
    if args.bag_verb == "recover":
        return bag_recover(bag, args.out)
    info = bag_info(bag)
    for note in info.notes:   # a bag that was not finalised or is damaged: what was lost, one line each
        print(f"rfidnav bag info: {bag}: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps({"path": str(info.path), "storage": info.storage, "duration_s": info.duration_s,
                          "message_count": info.message_count, "compression": info.compression,
                          "files": [{"path": str(f.path), "message_count": f.message_count,
                                     "duration_s": f.duration_s, "size_bytes": f.size_bytes,
                                     "compression": f.compression} for f in info.files],
                          "topics": [{"name": t.name, "type": t.msgtype, "count": t.count} for t in info.topics],
                          "notes": list(info.notes)}))
    else:
        print(format_bag_info(info))
    return 0


def bag_recover(bag: Path, out: Path | None) -> int:
    from rfidnav_bag.recover import recover_bag

    recovery = recover_bag(bag, out)
    for note in recovery.source.notes:
        print(f"rfidnav bag recover: {bag}: {note}", file=sys.stderr)
    print(f"{bag} -> {recovery.output}: {recovery.message_count:,} messages on {recovery.topic_count} topics, "
          f"{recovery.source.duration_s:.1f} s of bag time")
    return 0


def verb_view(args) -> int:
    from rfidnav_bag.bag_view import serve_bag
    from rfidnav_bringup.report import locate_run

    _, bag = locate_run(args.bag)
    return serve_bag(bag, args.port, speed=args.rate, announce=lambda line: print(line, flush=True))


def verb_echo(args) -> int:
    from rfidnav_bringup.echo import echo

    domain = args.domain if args.domain is not None else int(os.environ.get("ROS_DOMAIN_ID") or 0)
    discovery = args.discovery or os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST").lower()
    if discovery not in ("localhost", "subnet"):
        raise ConfigError("ROS_AUTOMATIC_DISCOVERY_RANGE", "", f"echo listens on LOCALHOST or SUBNET, not {discovery}")
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = discovery.upper()
    print(f"listening to {args.topic} on ROS domain {domain} ({discovery})", file=sys.stderr, flush=True)
    try:
        echo(args.topic, args.count, args.wait, args.timeout, domain_id=domain)
    except BrokenPipeError:
        # The reader went away (``echo /odom | head``): that is the end of the output, not an error.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


def verb_report(args) -> int:
    from rfidnav_bringup.report import locate_run, write_report
    from rfidnav_common.progress import stage

    if args.out is None:
        run_dir, _ = locate_run(args.run)
        if (problem := unwritable(run_dir)) is not None:
            raise ConfigError(str(args.run), "", f"{problem}: give --out FOLDER for the plots")
    with stage(f"report {args.run}"):
        metrics, plots = write_report(args.run, args.out)
    if args.json:
        print(json.dumps({"metrics": metrics, "plots": [str(p) for p in plots]}))
    else:
        # A run of several robots: each robot's metrics under its name, then what they did together.
        rows = [(f"{name} {key}", value) for name, values in metrics.items() if isinstance(values, dict)
                for key, value in values.items()]
        rows += [(key, value) for key, value in metrics.items() if not isinstance(value, dict)]
        for key, value in rows:
            print(f"  {key:22s} {value:.4f}" if isinstance(value, float) else f"  {key:22s} {value}")
        print("plots:", *plots, sep="\n  ")
    return 0


def verb_map(args) -> int:
    from rfidnav_bringup.report import draw_map
    from rfidnav_common.floor_plan import check_floor_map
    from rfidnav_common.topological_map import check_map, load_topological_map

    floor = args.map_verb == "check" and not args.robot_only
    problems = check_floor_map(args.map) if floor else check_map(args.map)
    for problem in problems:
        print(problem, file=sys.stderr)
    if args.map_verb == "check":
        if not problems:
            print(f"{args.map}: no problems")
        return 2 if problems else 0
    if problems:
        return 2
    out = args.out or args.map.with_suffix(".png")
    draw_map(load_topological_map(args.map), out)
    print(f"{args.map} -> {out}")
    return 0


VERBS: dict[str, Handler] = {"setup": verb_setup, "demo": verb_demo, "test": verb_test, "run": verb_run,
                             "replay": verb_replay, "bag": verb_bag, "report": verb_report, "map": verb_map,
                             "echo": verb_echo, "view": verb_view, "discovery-server": verb_discovery_server}


def exit_without_teardown(code: int) -> typing.NoReturn:
    """End the process once everything is written: the exit handlers run (the run's partition profile is removed)
    and the standard streams are flushed, but the interpreter does not free, one by one, the modules rclpy, numpy
    and the verb loaded: that took a third of a second idle and over a second beside busy processes, a wait added
    to every Ctrl-C of ``run``. Only for a process whose DDS participants are destroyed already: one destroyed by
    the teardown would otherwise stay in the domain until its lease ended, without a word to the others."""
    atexit._run_exitfuncs()      # what the interpreter's own exit runs first (private, but multiprocessing's way too)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except OSError:          # the terminal hung up (SIGHUP) or the pipe's reader left: nothing to write to
            pass
    os._exit(code)


# The verbs that destroy every DDS participant they made before they return (the orchestrator destroys its
# context): they may end without the teardown, which for the others would leave a participant to end with it.
ENDS_WITHOUT_TEARDOWN = ("run", "demo")

if __name__ == "__main__":
    exit_code = main()
    if sys.argv[1:2] and sys.argv[1] in ENDS_WITHOUT_TEARDOWN:
        exit_without_teardown(exit_code)
    sys.exit(exit_code)
