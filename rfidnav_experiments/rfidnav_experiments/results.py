"""Published figures: one committed results file per reproduction and benchmark, and the figures the docs quote.

``docs/results/NAME.json`` holds what a command measured: the command, the commit, its arguments, the evaluation
set, the wall time, the SHA-256 of every input it read (the rfidnav modules it ran and the configuration files it
opened), the rows (a reproduction's ``{"experiment", "setting", "metric", "ours", "paper"}``) or the figures (a
benchmark's JSON), and, for a reproduction, the rows of a small pinned subset that a slow-tier test runs again and
compares exactly (the runs are deterministic), so a change that moves a figure fails until its file is rewritten.

A figure quoted in README.md or docs/ is written with the place it comes from, as an HTML comment right after it
(invisible once rendered)::

    5.37<!--fig flc tracking_rmse_m scenario=line_follow_90 params=flc_paper x100-->

that is, the one row of docs/results/flc.json with metric ``tracking_rmse_m`` whose setting has those values
(``experiment=`` matches the row's experiment field instead; ``!key``: a setting without that key), its
``ours`` field (``paper``: its paper field) times 100, rounded to the decimals shown. A benchmark's figure names a
path into its JSON instead (``<!--fig bench_flc speedup-->``, ``<!--fig run_hallway metrics.rmse_m-->``), or, where
its JSON is a list of rows, a field of the one row with the given values (``<!--fig bench_routes search_s
scenario=long_legs params=flc_paper-->``); ``@KEY`` names the file's own record (``<!--fig flc @wall_s-->``).
``./rfidnav reproduce docs`` rewrites every quoted number from its file; ``test_results.py`` fails when one differs,
when a file is older than the inputs it recorded, or when the ledger's page is not current.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.evaluation import evaluation_set_dict
from rfidnav_experiments.reproduce.driver import Reproduction, reproductions

REPOSITORY = Path(__file__).resolve().parents[2]
RESULTS_DIR = REPOSITORY / "docs" / "results"
LEDGER_PAGE = RESULTS_DIR / "evaluation-ledger.md"
FORMAT = 1


# The reproductions registered in the ``rfidnav.reproductions`` entry-point group (rfidnav_experiments.reproduce.driver)
REPRODUCTIONS: dict[str, Reproduction] = reproductions()


@dataclass(frozen=True)
class Command:
    """A command other than a reproduction whose figures the docs quote: a benchmark (its ``--json`` output) or a
    mission over DDS (its run's summary.json)."""
    key: str                            # the results file's name
    argv: tuple[str, ...]               # after ./rfidnav
    output: Literal["json", "summary"]  # where its figures are: stdout's JSON, or the run's summary.json

    def command(self) -> str:
        return " ".join(("./rfidnav", *self.argv))


def _bench(name: str, *arguments: str) -> Command:
    return Command(f"bench_{name}", ("bench", name, *arguments, "--json"), "json")


def _run(label: str, scenario: str, *arguments: str) -> Command:
    return Command(f"run_{label}", ("run", scenario, *arguments, "--quiet"), "summary")


FILTER_PARAMS = ("--params", "partition_localizer=config/params/partition_localizer_filter.yaml",
                 "--params", "partition_navigator=config/params/partition_navigator_filter.yaml")


def _seeded_runs(scenario: str, *arguments: str, label: str = "", seeds: tuple[int, ...] = (1, 2, 3)) -> list[Command]:
    """A scenario over DDS at ``--rtf max`` on several seeds: ``run_SCENARIO[_LABEL]_sN``."""
    return [_run(f"{scenario}{'_' + label if label else ''}_s{seed}", scenario, "--rtf", "max", "--seed", str(seed),
                 *arguments) for seed in seeds]


COMMANDS: dict[str, Command] = {c.key: c for c in (
    _bench("flc"), _bench("reader"), _bench("planner"), _bench("fused"), _bench("location_server"), _bench("llrp"),
    _bench("routes", "--seeds", "3"), _bench("scaling", "--runs", "3"), _bench("survey"),
    Command("bench_rtf_hallway", ("bench", "rtf", "--scenario", "hallway", "--clock", "stepped", "--rtfs", "5,max",
                                  "--seeds", "1", "--json"), "json"),
    Command("bench_rtf_hallway_loaded", ("bench", "rtf", "--scenario", "hallway", "--clock", "stepped", "--rtfs",
                                         "5,max", "--hogs", "2", "--seeds", "1", "--json"), "json"),
    *(Command(f"bench_rtf_{scenario}", ("bench", "rtf", "--scenario", scenario, "--clock", "stepped", "--rtfs", "max",
                                        "--seeds", "1", "--json"), "json")
      for scenario in ("building_large", "two_tier_home", "mixed_floor_fused")),
    _run("long_legs", "long_legs", "--rtf", "max", "--seed", "1"),
    _run("mixed_floor_fused", "mixed_floor_fused", "--rtf", "max", "--seed", "1"),
    _run("partition_field_fused", "partition_field_fused", "--rtf", "max", "--seed", "1"),
    *_seeded_runs("partition_field"), *_seeded_runs("partition_field", *FILTER_PARAMS, label="filter"),
    *_seeded_runs("partition_corridor"), *_seeded_runs("partition_corridor", *FILTER_PARAMS, label="filter"),
    *_seeded_runs("two_tier_home"), *_seeded_runs("two_tier_flat"), *_seeded_runs("two_tier_corridor"),
    *_seeded_runs("building_ring_pair"), *_seeded_runs("two_tier_flat_pair"),
)}


class ResultsError(ConfigError):
    """A results file or a quoted figure that cannot be used: names the file and what is wrong."""


# ------------------------------------------------------------------------------------------- inputs

@contextlib.contextmanager
def recorded_inputs() -> Iterator[set[Path]]:
    """The repository's files this process opens meanwhile (an audit hook: every reader of the configuration,
    whoever calls it). Audit hooks cannot be removed, so one hook serves every use, on while a recording runs."""
    _install_hook()
    opened: set[Path] = set()
    _RECORDERS.append(opened)
    try:
        yield opened
    finally:
        _RECORDERS.remove(opened)


_RECORDERS: list[set[Path]] = []
_HOOKED = False


def _audit(event: str, arguments: tuple[Any, ...]) -> None:
    if event != "open" or not _RECORDERS or not isinstance(arguments[0], (str, os.PathLike)):
        return
    mode = arguments[1] if len(arguments) > 1 and isinstance(arguments[1], str) else "r"
    if "r" not in mode or "+" in mode:
        return
    path = Path(os.fspath(arguments[0]))
    if path.suffix in (".yaml", ".json"):
        path = path.resolve()           # the configuration is read through the venv's share/ links
        if REPOSITORY / "config" in path.parents:
            for recorder in _RECORDERS:
                recorder.add(path)


def _install_hook() -> None:
    global _HOOKED
    if not _HOOKED:
        sys.addaudithook(_audit)
        _HOOKED = True


def sha256_of(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def loaded_sources() -> set[Path]:
    """The rfidnav modules this process has imported (the code that made the figures; a local cluster's workers
    import the same modules, which the experiment's module imports at its top)."""
    sources = set()
    for module in list(sys.modules.values()):
        file = getattr(module, "__file__", None)
        if not file or not module.__name__.startswith("rfidnav_"):
            continue
        path = Path(file).resolve()
        if REPOSITORY in path.parents and path.suffix == ".py":
            sources.add(path)
    return sources


# the wrapper, the driver, the registrations and the command line: no figure depends on them
NOT_INPUTS = ("rfidnav_experiments/rfidnav_experiments/results.py", "rfidnav_experiments/rfidnav_experiments/verbs.py",
              "rfidnav_experiments/rfidnav_experiments/reproduce/driver.py",
              "rfidnav_experiments/rfidnav_experiments/reproduce/entries.py", "rfidnav_bringup/rfidnav_bringup/cli.py")


def input_hashes(paths: set[Path]) -> dict[str, str]:
    relative = {path.relative_to(REPOSITORY).as_posix(): path for path in paths}
    return {name: sha256_of(path) for name, path in sorted(relative.items()) if name not in NOT_INPUTS}


def stale_inputs(results: dict[str, Any]) -> list[str]:
    """The recorded inputs whose file changed or went since the results were written."""
    changed = []
    for name, digest in results.get("inputs", {}).items():
        path = REPOSITORY / name
        if not path.is_file():
            changed.append(f"{name} (gone)")
        elif sha256_of(path) != digest:
            changed.append(name)
    return changed


def commit() -> str:
    try:
        head = subprocess.run(["git", "-C", str(REPOSITORY), "rev-parse", "--short", "HEAD"], check=True,
                              capture_output=True, text=True).stdout.strip()
        # the docs are never an input: a tree dirty only there still ran the committed code
        dirty = subprocess.run(["git", "-C", str(REPOSITORY), "status", "--porcelain", "--untracked-files=no", "--",
                                ".", ":!docs", ":!README.md"],
                               check=True, capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return f"{head}{' (with uncommitted changes)' if dirty else ''}"


# -------------------------------------------------------------------------------------------- write

def rows_of(name: str, out_dir: Path) -> list[dict[str, Any]]:
    path = out_dir / f"{name}_rows.json"
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ResultsError(str(path), "", f"the reproduction wrote no readable rows: {error}") from error


def pinned_rows(name: str) -> list[dict[str, Any]]:
    """The pinned subset's rows, run now in this process (a test compares them with the file's)."""
    reproduction = REPRODUCTIONS[name]
    with tempfile.TemporaryDirectory(prefix=f"rfidnav-pinned-{name}-") as folder, \
            contextlib.redirect_stdout(sys.stderr):
        reproduction.run(Path(folder), as_json=False, **reproduction.pinned)
        return rows_of(name, Path(folder))


def publish_reproduction(name: str, out_dir: Path, results_dir: Path = RESULTS_DIR, count: int | None = None) -> int:
    """Run the reproduction at its published size (or ``count``) and its pinned subset; write NAME.json."""
    reproduction = REPRODUCTIONS[name]
    arguments = {reproduction.count: count or reproduction.default}
    with recorded_inputs() as opened:
        started = time.perf_counter()
        code = reproduction.run(out_dir, as_json=False, **arguments)
        wall_s = time.perf_counter() - started
        rows = rows_of(name, out_dir)
        pinned = pinned_rows(name)
    write_results(results_dir / f"{name}.json", {
        "name": name, "command": reproduction.command(arguments), "exit_code": code, "arguments": arguments,
        "evaluation_set": evaluation_set_dict(name), "wall_s": round(wall_s, 1), "machine": machine(),
        "rows": rows, "pinned": {"arguments": reproduction.pinned, "rows": pinned},
    }, opened | loaded_sources())
    return code


def publish_command(key: str, results_dir: Path = RESULTS_DIR) -> int:
    """Run the command in a child (its own process, as a user runs it) and write its figures."""
    published = COMMANDS[key]
    with tempfile.TemporaryDirectory(prefix=f"rfidnav-{key}-") as folder:
        argv = [*published.argv, *(("--out", folder) if published.output == "summary" else ())]
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", *argv], capture_output=True, text=True,
                              cwd=REPOSITORY)
        wall_s = time.perf_counter() - started
        if done.returncode not in (0, 1):
            raise ResultsError(published.command(), "", f"exited {done.returncode}: {done.stderr.strip()[-400:]}")
        figures = _figures(published, done.stdout, Path(folder))
    write_results(results_dir / f"{key}.json", {
        "name": key, "command": published.command(), "exit_code": done.returncode, "wall_s": round(wall_s, 1),
        "machine": machine(), "figures": figures}, set())
    return done.returncode


def _figures(published: Command, stdout: str, out_dir: Path) -> Any:
    if published.output == "summary":
        summaries = sorted(out_dir.glob("*/summary.json"))
        if len(summaries) != 1:
            raise ResultsError(published.command(), "", f"wrote {len(summaries)} summary.json files, expected one")
        text, source = summaries[0].read_text(), str(summaries[0])
    else:
        text, source = stdout, "its standard output"
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise ResultsError(published.command(), "", f"no JSON in {source}: {error}") from error


# The vector instructions that change floating-point results in their last bits (numpy's and the BLAS's kernels
# pick them at run time): a closed-loop run can diverge from such a bit, so the pinned rows are exact on machines
# with the same set only. The files published before this record differed here in 25 of flc's 211 pinned rows.
VECTOR_FLAGS = ("avx", "avx2", "fma", "avx512f", "avx512dq", "avx512bw", "avx512vl")


def vector_instructions(cpuinfo: Path = Path("/proc/cpuinfo")) -> list[str]:
    """Which of VECTOR_FLAGS this machine's processor has (empty where /proc/cpuinfo cannot be read)."""
    try:
        text = cpuinfo.read_text()
    except OSError:
        return []
    flags = next((line.split(":", 1)[1].split() for line in text.splitlines() if line.startswith("flags")), [])
    return [flag for flag in VECTOR_FLAGS if flag in flags]


def machine() -> dict[str, Any]:
    return {"cores": len(os.sched_getaffinity(0)), "load_1min": round(os.getloadavg()[0], 2),
            "python": sys.version.split()[0], "vector_instructions": vector_instructions()}


def numerics_differ(document: dict[str, Any]) -> str:
    """Why a results file's pinned rows may not be this machine's to the bit: a sentence naming the vector
    instructions it was published with and this machine's, or '' when they are the same."""
    published = document.get("machine", {}).get("vector_instructions")
    here = vector_instructions()
    if published == here:
        return ""
    then = "an unrecorded set" if published is None else (", ".join(published) or "none")
    return (f"; it was published on a processor with vector instructions {then}, this one has "
            f"{', '.join(here) or 'none'}: their floating-point results differ in the last bits, from which a "
            "closed-loop run may diverge; run ./rfidnav reproduce all on this machine")


def write_results(path: Path, content: dict[str, Any], inputs: set[Path]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    document = {"format": FORMAT, **content, "commit": commit(), "inputs": input_hashes(inputs)}
    path.write_text(json.dumps(document, indent=1, sort_keys=False) + "\n")


def read_results(path: Path) -> dict[str, Any]:
    try:
        document = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ResultsError(str(path), "", f"not a readable results file: {error}") from error
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise ResultsError(str(path), "format", f"expected results format {FORMAT}")
    return document


def estimated_minutes(names: list[str], results_dir: Path = RESULTS_DIR) -> float | None:
    """The wall time the last published runs took (None where a file is missing: no honest estimate)."""
    total = 0.0
    for name in names:
        path = results_dir / f"{name}.json"
        if not path.is_file():
            return None
        total += float(read_results(path).get("wall_s", 0.0))
    return total / 60.0


# -------------------------------------------------------------------------------------------- quote

# A quoted figure: a number (a sign, digits, decimals) right before its source comment; not an example of one in
# code (a backtick before it).
QUOTE = re.compile(r"(?<![`\d.])(?P<number>[+\-−]?\d+(?:\.\d+)?)<!--fig (?P<spec>[^>]*?)-->")


@dataclass(frozen=True)
class Quote:
    page: str
    line: int
    number: str
    spec: str

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"


def quoting_pages(root: Path = REPOSITORY) -> list[str]:
    """The pages that may quote a figure: the README and every page of docs/ (a new page needs no registering)."""
    return ["README.md", *(path.relative_to(root).as_posix() for path in sorted((root / "docs").glob("*.md")))]


def quotes(root: Path = REPOSITORY) -> list[Quote]:
    found = []
    for page in quoting_pages(root):
        path = root / page
        if not path.is_file():
            continue
        for number, text in enumerate(path.read_text().splitlines(), 1):
            found += [Quote(page, number, match["number"], match["spec"].strip()) for match in QUOTE.finditer(text)]
    return found


def _matches(setting: Any, key: str, value: str) -> bool:
    return isinstance(setting, dict) and key in setting and str(setting[key]) == value


def quoted_value(spec: str, results: dict[str, dict[str, Any]], where: str) -> float:
    """The value a quote's spec names, scaled."""
    words = spec.split()
    if not words:
        raise ResultsError(where, "fig", "an empty source")
    name, rest = words[0], words[1:]
    if name not in results:
        raise ResultsError(where, "fig", f"no results file docs/results/{name}.json")
    scale = 1.0
    column = "ours"
    selectors: list[str] = []
    for word in rest:
        if re.fullmatch(r"x[0-9.e+-]+", word):
            scale = float(word[1:])
        elif word == "paper":
            column = "paper"
        else:
            selectors.append(word)
    document = results[name]
    if selectors and selectors[0].startswith("@"):      # the file's own record: @wall_s, @machine.load_1min
        value: Any = document
        for step in selectors[0][1:].split("."):
            if not isinstance(value, dict) or step not in value:
                raise ResultsError(where, "fig", f"{spec!r}: no {step!r} in {name}.json")
            value = value[step]
    elif "rows" in document:
        if not selectors or "=" in selectors[0]:
            raise ResultsError(where, "fig", f"{spec!r}: name a metric after {name}")
        metric = selectors[0]
        absent = [word[1:] for word in selectors[1:] if word.startswith("!")]
        filters = [word.split("=", 1) for word in selectors[1:] if not word.startswith("!")]
        if any(len(pair) != 2 for pair in filters):
            raise ResultsError(where, "fig", f"{spec!r}: expected key=value or !key after the metric")
        rows = [row for row in document["rows"] if row.get("metric") == metric
                and all(str(row.get("experiment")) == value if key == "experiment" else
                        _matches(row.get("setting"), key, value) for key, value in filters)
                and not any(key in (row.get("setting") or {}) for key in absent)]
        if len(rows) != 1:
            raise ResultsError(where, "fig", f"{spec!r} selects {len(rows)} rows of {name}.json, expected one")
        value = rows[0].get(column)
    elif isinstance(document.get("figures"), list):       # a benchmark's rows: a field of the one row matching
        field_name, filters = selectors[0] if selectors else "", [word.split("=", 1) for word in selectors[1:]]
        rows = [row for row in document["figures"] if isinstance(row, dict)
                and all(len(pair) == 2 and _matches(row, *pair) for pair in filters)]
        if len(rows) != 1 or field_name not in rows[0]:
            raise ResultsError(where, "fig", f"{spec!r} selects {len(rows)} rows of {name}.json with a "
                                             f"{field_name!r}, expected one")
        value = rows[0][field_name]
    else:
        value = document.get("figures")
        for step in (selectors[0].split(".") if selectors else []):
            if isinstance(value, list) and step.isdigit() and int(step) < len(value):
                value = value[int(step)]
            elif isinstance(value, dict) and step in value:
                value = value[step]
            else:
                raise ResultsError(where, "fig", f"{spec!r}: no {step!r} in {name}.json's figures")
    if isinstance(value, bool):
        value = int(value)              # a success quoted as 1 or 0
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ResultsError(where, "fig", f"{spec!r} is {value!r}, not a number")
    return float(value) * scale


def shown(value: float, like: str) -> str:
    """``value`` written as ``like`` is: its decimals, its minus sign, a plus sign if it had one."""
    decimals = len(like.split(".", 1)[1]) if "." in like else 0
    text = f"{value:.{decimals}f}"
    if text.startswith("-"):
        text = ("−" if "−" in like else "-") + text[1:]
        if float(text.lstrip("−-")) == 0.0:
            text = text[1:]
    elif like[:1] == "+":
        text = "+" + text
    return text


def all_results(results_dir: Path = RESULTS_DIR) -> dict[str, dict[str, Any]]:
    return {path.stem: read_results(path) for path in sorted(results_dir.glob("*.json"))}


def quote_problems(root: Path = REPOSITORY, results_dir: Path = RESULTS_DIR) -> list[str]:
    """Every quoted figure that differs from its results file or cannot be read from it, one line each."""
    results = all_results(results_dir)
    problems = []
    for quote in quotes(root):
        try:
            expected = shown(quoted_value(quote.spec, results, quote.where), quote.number)
        except ResultsError as error:
            problems.append(str(error))
            continue
        if expected.replace("−", "-") != quote.number.replace("−", "-"):
            problems.append(f"{quote.where}: {quote.number} but {quote.spec.split()[0]}.json gives {expected} "
                            f"({quote.spec})")
    return problems


def _rendered(match: re.Match[str], results: dict[str, dict[str, Any]], where: str, problems: list[str]) -> str:
    """A quote with its number rewritten from its file (unchanged, and its problem noted, where it cannot be)."""
    try:
        text = shown(quoted_value(match["spec"].strip(), results, where), match["number"])
    except ResultsError as error:
        problems.append(str(error))
        return match[0]
    return f"{text}<!--fig {match['spec']}-->"


def render_quotes(root: Path = REPOSITORY, results_dir: Path = RESULTS_DIR) -> list[str]:
    """Rewrite every quoted number from its file; returns the problems of the quotes it could not render."""
    results = all_results(results_dir)
    problems: list[str] = []
    for page in quoting_pages(root):
        path = root / page
        if not path.is_file():
            continue
        lines = path.read_text().splitlines(keepends=True)
        new = [QUOTE.sub(functools.partial(_rendered, results=results, where=f"{page}:{n}", problems=problems), line)
               for n, line in enumerate(lines, 1)]
        if new != lines:
            path.write_text("".join(new))
    return problems
