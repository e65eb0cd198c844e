"""The one driver of ``./rfidnav reproduce``: every reproduction runs through it.

A reproduction registers in the ``rfidnav.reproductions`` entry-point group (``setup.py``) with a light
:class:`ReproductionEntry`: its name, its help line, the count it takes (seeds, runs, missions), the count the
published figures use and its pinned subset. Its module (conditions, jobs, run, summary, plots) is imported only
when it runs, so ``./rfidnav --help`` stays fast. The driver owns what every reproduction shares: the options
``--out``, ``--json``, ``--resume``, ``--publish`` and the engine's, the engine and its tasks file
(``--out``/NAME_tasks.jsonl), the results file ``docs/results/NAME.json`` (:mod:`rfidnav_experiments.results`),
and ``reproduce all`` / ``reproduce docs``.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from rfidnav_scenario.cli_types import Handler

ENTRY_POINTS = "rfidnav.reproductions"


class Reproduction(Protocol):
    """What the driver needs of a reproduction: its name and count option, and a run that writes
    ``out_dir``/NAME_rows.json (the rows the results file keeps) and returns the exit code."""
    name: str
    help: str                           # the sub-command's help line
    count: str                          # the run's count argument (seeds, runs, missions)
    option: str                         # the command's option for it
    default: int                        # the count the published figures use
    pinned: dict[str, Any]              # the subset a slow-tier test runs again (<1 min)
    rank: int                           # its place in ``reproduce all`` and the listings (entry points are unordered)

    def add_arguments(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, out_dir: Path, as_json: bool, **arguments: Any) -> int: ...

    def command(self, arguments: dict[str, Any]) -> str: ...


@dataclass(frozen=True)
class ReproductionEntry:
    """A ``reproduce NAME`` experiment as registered: its function (imported when it runs), the count it takes,
    and its pinned subset."""
    name: str
    module: str
    function: str
    count: str                          # the function's count argument (seeds, runs, missions)
    option: str                         # the command's option for it
    default: int                        # the count the published figures use
    help: str                           # the sub-command's help line
    count_help: str                     # the count option's help
    rank: int                           # its place in ``reproduce all`` and the listings
    pinned: dict[str, Any] = field(default_factory=dict)   # the subset a test runs again (<1 min)

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        from rfidnav_experiments.verbs import runs_value

        parser.add_argument(self.option, type=runs_value, help=self.count_help)

    def run(self, out_dir: Path, as_json: bool, **arguments: Any) -> int:
        function: Callable[..., int] = getattr(importlib.import_module(self.module), self.function)
        return function(out_dir=out_dir, as_json=as_json, **arguments)

    def command(self, arguments: dict[str, Any]) -> str:
        return f"./rfidnav reproduce {self.name} {self.option} {arguments[self.count]}"


@functools.cache
def reproductions() -> dict[str, Reproduction]:
    """The registered reproductions by rank (the order ``reproduce all`` runs them): an entry-point group keeps no
    order of its own."""
    found: dict[str, Reproduction] = {}
    for point in entry_points(group=ENTRY_POINTS):
        reproduction = point.load()
        if reproduction.name != point.name:     # the results file, the tests and the command go by this name
            raise ValueError(f"entry point {point.name} = {point.value} registers a reproduction named "
                             f"{reproduction.name!r}")
        found[point.name] = reproduction
    return dict(sorted(found.items(), key=lambda item: (item[1].rank, item[0])))


def add_reproduce(verbs: argparse._SubParsersAction) -> Handler:
    # the command line's modules are imported here, not at the top: results.py (which a pinned run imports, and
    # whose imported modules are recorded as a results file's inputs) needs only the registry above
    from rfidnav_experiments.verbs import add_engine_options
    from rfidnav_scenario.cli_types import RUNS_DIR, output_folder

    reproduce = verbs.add_parser("reproduce", help="the papers' experiments in-process, beside the papers' figures")
    names = reproduce.add_subparsers(dest="name", required=True, metavar="EXPERIMENT")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--out", type=output_folder, default=RUNS_DIR / "reproduce",
                        help="folder for the rows, tables and plots")
    common.add_argument("--json", action="store_true", help="print the rows as JSON on stdout")
    add_engine_options(common)
    common.add_argument("--resume", action="store_true",
                        help="take the finished tasks from --out's tasks file (EXPERIMENT_tasks.jsonl) of an "
                             "interrupted run of the same experiment, arguments and code, and run only the rest")
    common.add_argument("--publish", action="store_true",
                        help="also write docs/results/EXPERIMENT.json (the figures the docs quote, with the command, "
                             "commit, inputs and the pinned subset's rows) and rewrite the quoted numbers")
    for reproduction in reproductions().values():
        reproduction.add_arguments(names.add_parser(reproduction.name, parents=[common],
                                                    help=reproduction.help))
    everything = names.add_parser("all", help="every reproduction, benchmark and mission the docs quote at "
                                              "its published size: rewrites docs/results/ and the quoted figures")
    everything.add_argument("--out", type=output_folder, default=RUNS_DIR / "reproduce",
                            help="folder for the rows, tables and plots")
    everything.add_argument("--only", type=published_names, default=None,
                            help="comma-separated reproductions, bench_NAME benchmarks or run_NAME missions "
                                 "(default: all)")
    add_engine_options(everything)
    names.add_parser("docs", help="rewrite every figure the README and docs/ quote from docs/results/, and the "
                                  "evaluation ledger's page; nothing runs")
    return run_reproduce


def published_names(text: str) -> list[str]:
    from rfidnav_experiments.results import COMMANDS, REPRODUCTIONS

    names = [part.strip() for part in text.split(",")]
    unknown = [name for name in names if name not in REPRODUCTIONS and name not in COMMANDS]
    if unknown:
        raise argparse.ArgumentTypeError(f"expected some of {', '.join([*REPRODUCTIONS, *COMMANDS])}, got {text!r}")
    return list(dict.fromkeys(names))


def run_reproduce(args: argparse.Namespace) -> int:
    """The reproduction on the command's engine, its tasks streamed to ``--out``/EXPERIMENT_tasks.jsonl."""
    from rfidnav_experiments import results
    from rfidnav_experiments.verbs import engine

    if args.name == "all":
        return reproduce_all(args)
    if args.name == "docs":
        return render_docs()
    reproduction = results.REPRODUCTIONS[args.name]
    count = getattr(args, reproduction.option.removeprefix("--"))
    arguments = {reproduction.count: count or reproduction.default}
    with engine(args, f"reproduce {args.name}", arguments, args.out / f"{args.name}_tasks.jsonl"):
        if not args.publish:
            return reproduction.run(args.out, args.json, **arguments)
        code = results.publish_reproduction(args.name, args.out, count=arguments[reproduction.count])
    if args.json:
        print(json.dumps(results.rows_of(args.name, args.out), indent=1))
    return max(code, render_docs())


def render_docs() -> int:
    """The quoted figures and the ledger's page from docs/results/; 1 with a line per quote it could not render."""
    from rfidnav_experiments import results
    from rfidnav_experiments.evaluation import ledger_markdown

    results.LEDGER_PAGE.parent.mkdir(parents=True, exist_ok=True)
    results.LEDGER_PAGE.write_text(ledger_markdown())
    problems = results.render_quotes()
    for problem in problems:
        print(f"rfidnav reproduce: {problem}", file=sys.stderr)
    return 1 if problems else 0


def reproduce_all(args: argparse.Namespace) -> int:
    """Every reproduction and benchmark (or ``--only``'s), at its published size, then the docs."""
    from rfidnav_common.progress import stage
    from rfidnav_experiments import results
    from rfidnav_experiments.verbs import engine

    names = args.only or [*results.REPRODUCTIONS, *results.COMMANDS]
    minutes = results.estimated_minutes(names)
    print("reproduce all: " + ", ".join(names) + (
        f"; the last published runs of these took {minutes:.0f} min" if minutes is not None else
        "; no estimate (a results file is missing)"), file=sys.stderr)
    codes = []
    for name in names:
        if name in results.COMMANDS:
            try:
                with stage(results.COMMANDS[name].command()):
                    codes.append(results.publish_command(name))
            except results.ResultsError as error:     # one command's failure: said, and the others still run
                print(f"rfidnav reproduce: {error}", file=sys.stderr)
                codes.append(1)
            continue
        reproduction = results.REPRODUCTIONS[name]
        arguments = {reproduction.count: reproduction.default}
        with engine(args, f"reproduce {name}", arguments, args.out / f"{name}_tasks.jsonl"):
            codes.append(results.publish_reproduction(name, args.out))
    failed = [name for name, code in zip(names, codes) if code]
    if failed:
        print(f"reproduce all: exit code 1 from {', '.join(failed)} (their figures are written all the same)",
              file=sys.stderr)
    return max([render_docs(), *(1 for _ in failed)])
