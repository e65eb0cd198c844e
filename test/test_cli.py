"""The command line's basics, as a ROS 2 user types them first: help at every level, ``test`` running just what
pytest is given, and progress on stderr that leaves stdout to the figures."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from rfidnav_bringup import cli
from rfidnav_common.progress import StatusLine, progress, stage

WORKSPACE = Path(__file__).resolve().parents[1]


def every_command(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every verb and sub-verb of the command line, as the words that name it."""
    commands = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                commands.append((*prefix, name))
                commands += every_command(sub, (*prefix, name))
    return commands


@pytest.mark.tier("graph")
@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_the_entry_script_lists_every_verb_and_exits_0_on_help(flag: str) -> None:
    result = subprocess.run([str(WORKSPACE / "rfidnav"), flag], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    for verb in ("setup", "run", "replay", "bag", "echo", "test", "reproduce", "bench", "calibrate", "survey"):
        assert verb in result.stdout


@pytest.mark.tier("graph")
def test_setup_help_prints_its_help_and_sets_nothing_up() -> None:
    result = subprocess.run([str(WORKSPACE / "rfidnav"), "setup", "--help"], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: rfidnav setup")
    assert "ready" not in result.stdout + result.stderr


@pytest.mark.tier("unit")
def test_setup_refuses_an_unknown_option_before_setting_anything_up() -> None:
    result = subprocess.run([sys.executable, str(WORKSPACE / "rfidnav_bringup/rfidnav_bringup/environment.py"),
                             "/nonexistent-workspace", "setup", "--bogus"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "--bogus" in result.stderr


@pytest.mark.tier("unit")
def test_every_verb_and_sub_verb_shows_its_help_and_runs_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    top, _ = cli.parser()
    commands = every_command(top)
    assert {("bench", "rtf"), ("reproduce", "topological"), ("calibrate", "flc"), ("bag", "info")} <= set(commands)
    for command in commands:
        with pytest.raises(SystemExit) as exit_info:   # argparse exits while parsing, before any handler runs
            cli.main([*command, "--help"])
        assert exit_info.value.code == 0, command
        assert capsys.readouterr().out.startswith(f"usage: rfidnav {' '.join(command)}"), command


@pytest.mark.tier("unit")
def test_a_sub_verb_has_its_own_options_and_refuses_another_ones(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["bench", "flc", "--rtfs", "1,2"])          # --rtfs belongs to bench rtf
    assert exit_info.value.code == 2
    assert "--rtfs" in capsys.readouterr().err


@pytest.mark.tier("unit")
def test_test_passes_pytest_exactly_what_it_is_given(tmp_path: Path) -> None:
    (tmp_path / "test_here.py").write_text("")
    command = cli.pytest_command(["-q", "test_here.py::test_x", "-m", "unit", "not_a_file.py"], tmp_path)
    assert command[:3] == [sys.executable, "-m", "pytest"]
    assert command[3:] == ["-q", str(tmp_path / "test_here.py::test_x"), "-m", "unit", "not_a_file.py"]
    assert cli.pytest_command([], tmp_path)[3:] == []     # nothing given: pytest.ini's testpaths, the whole test/


@pytest.mark.tier("unit")
def test_test_with_workers_gives_each_pytest_xdist_worker_whole_modules(tmp_path: Path) -> None:
    assert cli.pytest_command(["-m", "unit"], tmp_path, workers=2)[3:] == [
        "-n", "2", "--dist", "loadscope", "-m", "unit"]
    args, extra = cli.parser()[0].parse_known_args(["test", "--workers", "1", "--under-load", "0", "-m", "unit"])
    assert args.under_load == 0 and args.workers == 1
    assert cli.pytest_command([*extra, *args.pytest_args], tmp_path, args.workers)[3:] == ["-m", "unit"]


@pytest.mark.tier("unit")
def test_progress_in_a_log_prints_a_line_at_every_tenth_and_one_at_the_end(
        capsys: pytest.CaptureFixture[str]) -> None:
    with progress("counting", 40) as advance:
        for _ in range(40):
            advance(1)
    captured = capsys.readouterr()
    assert captured.out == ""                               # stdout stays free for --json figures
    lines = captured.err.splitlines()
    assert lines[:-1] == [f"counting: {done}/40" for done in range(4, 40, 4)]
    assert lines[-1].startswith("counting: 40/40 in ")


@pytest.mark.tier("unit")
def test_a_stage_says_when_it_starts_and_how_long_it_took(capsys: pytest.CaptureFixture[str]) -> None:
    with stage("one benchmark"):
        print("figures")
    captured = capsys.readouterr()
    assert captured.out == "figures\n"
    assert captured.err.splitlines()[0] == "one benchmark ..."
    assert captured.err.splitlines()[1].startswith("one benchmark: done in ")


@pytest.mark.tier("unit")
def test_a_status_line_in_a_log_prints_only_its_milestones(capsys: pytest.CaptureFixture[str]) -> None:
    status = StatusLine()
    for index in range(5):
        status.show(f"target {index // 2}", milestone=index % 2 == 0)
    status.done()
    StatusLine(quiet=True).show("never", milestone=True)
    assert capsys.readouterr().err.splitlines() == ["target 0", "target 1", "target 2"]
