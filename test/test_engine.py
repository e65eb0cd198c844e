"""The Dask engine of the in-process experiments (rfidnav_experiments.engine) and its tasks file: the same rows on
1 and 2 workers and on a cluster started by its command lines, a killed worker's task run again, ``--resume``
running only what the file does not hold, and the codec giving back what it was given."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_experiments import results
from rfidnav_experiments.engine import Engine, EngineError, EngineOptions, engine_for, run_tasks
from rfidnav_experiments.reproduce.partitions.jobs import navigation_jobs, run_navigation_job
from rfidnav_experiments.reproduce.partitions.settings import FILTER, PAPER
from rfidnav_experiments.reproduce.topological import EVALUATION, missions_chunk
from rfidnav_experiments.runners.partitions import RobotSpeeds
from rfidnav_experiments.runners.topological import MissionRun
from rfidnav_experiments.task_rows import Header, TaskRows, canonical, decode, encode, task_key
from support.engine_tasks import logged_square, square_killing_its_worker_once
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")

# A small grid of two experiments: navigations of both paper 000 methods, missions of both paper 004 loops.
NAVIGATIONS = navigation_jobs(4, methods=(PAPER, FILTER), ranges=(0.02,), levels=(1, 6))
MISSIONS = [(EVALUATION, method, 0.2, 0, 2) for method in ("paper", "ours")]


def rows_of(engine: Engine) -> list[str]:
    return [canonical(result) for result in engine.map(run_navigation_job, NAVIGATIONS, "navigations")
            + engine.map(missions_chunk, MISSIONS, "missions")]


def test_a_small_grid_gives_the_same_rows_to_the_bit_on_one_worker_two_workers_and_in_this_process() -> None:
    here = [canonical(encode_decoded(run_navigation_job(job))) for job in NAVIGATIONS] + \
           [canonical(encode_decoded(missions_chunk(job))) for job in MISSIONS]
    with Engine(EngineOptions(workers=1)) as one:
        on_one = rows_of(one)
    with Engine(EngineOptions(workers=2)) as two:
        assert two.workers() == 2
        on_two = rows_of(two)
    assert on_one == on_two == here
    assert len(set(on_one)) == len(on_one)          # every task its own result, none mixed up


def encode_decoded(value: object) -> object:
    return decode(encode(value))


def test_a_worker_killed_in_the_middle_of_a_task_has_that_task_run_again_and_the_run_completes(
        tmp_path: Path) -> None:
    jobs = [(str(tmp_path), value, 5) for value in range(12)]
    with Engine(EngineOptions(workers=2)) as engine:
        pids_before = set(engine.client.run(os.getpid).values())
        results = engine.map(square_killing_its_worker_once, jobs, "squares")
        pids_after = set(engine.client.run(os.getpid).values())
    assert results == [value * value for value in range(12)]
    killed = int((tmp_path / "killed").read_text())
    assert killed in pids_before and killed not in pids_after      # the nanny started a new worker in its place


def test_resume_runs_only_the_tasks_the_file_does_not_hold_and_gives_the_rows_of_an_uninterrupted_run(
        tmp_path: Path) -> None:
    jobs = [(str(tmp_path), value) for value in range(10)]
    tasks = tmp_path / "squares_tasks.jsonl"
    options = EngineOptions(workers=2, tasks_file=tasks, experiment="squares", arguments={"n": 10})
    (tmp_path / "fail-6").touch()
    with pytest.raises(EngineError, match=r"told to fail at 6"):
        with engine_for(options):
            run_tasks(logged_square, jobs, "squares")
    held = {json.loads(line)["job"]["__tuple__"][1] for line in tasks.read_text().splitlines()[1:]}
    assert 6 not in held and held                           # what finished before the failure, and only that
    (tmp_path / "fail-6").unlink()
    (tmp_path / "log").unlink()
    with engine_for(EngineOptions(**{**options.__dict__, "resume": True})) as engine:
        assert run_tasks(logged_square, jobs, "squares") == [value * value for value in range(10)]
        assert engine.resumed == len(held)
    ran_again = {int(line) for line in (tmp_path / "log").read_text().split()}
    assert ran_again == set(range(10)) - held
    assert len(tasks.read_text().splitlines()) == 1 + 10


@pytest.mark.tier("unit")
def test_a_task_row_cut_short_by_the_interruption_is_dropped_and_its_task_run_again(tmp_path: Path) -> None:
    tasks = tmp_path / "t.jsonl"
    header = Header("squares", {"n": 3}, "code")
    rows = TaskRows(tasks, header, resume=False)
    rows.append("squares", "k1", 1, encode(1))
    rows.append("squares", "k2", 2, encode(4))
    rows.close()
    tasks.write_text(tasks.read_text()[:-9])                 # the last line half-written
    resumed = TaskRows(tasks, header, resume=True)
    assert resumed.dropped_line
    assert dict(resumed.finished_in("squares")) == {"k1": 1}
    resumed.append("squares", "k2", 2, encode(4))
    resumed.close()
    assert dict(TaskRows(tasks, header, resume=True).finished_in("squares")) == {"k1": 1, "k2": 4}


@pytest.mark.tier("unit")
def test_resume_refuses_the_tasks_file_of_other_arguments_or_other_code_naming_what_differs(tmp_path: Path) -> None:
    tasks = tmp_path / "t.jsonl"
    TaskRows(tasks, Header("reproduce partitions", {"runs": 250}, "abc"), resume=False).close()
    with pytest.raises(ConfigError, match=r"t\.jsonl: line 1: .*arguments: \{'runs': 250\} in the file, "
                                          r"\{'runs': 5\} now"):
        TaskRows(tasks, Header("reproduce partitions", {"runs": 5}, "abc"), resume=True)
    with pytest.raises(ConfigError, match=r"code: 'abc' in the file, 'def' now"):
        TaskRows(tasks, Header("reproduce partitions", {"runs": 250}, "def"), resume=True)
    tasks.write_text("{}\n{\"batch\": 1}\n")
    with pytest.raises(ConfigError, match=r"line 1: not an rfidnav tasks file header"):
        TaskRows(tasks, Header("reproduce partitions", {"runs": 250}, "abc"), resume=True)


@pytest.mark.tier("unit")
def test_the_codec_gives_back_dataclasses_tuples_arrays_odd_keys_and_every_float_to_the_bit() -> None:
    run = MissionRun(True, "arrived", 12.25, 10.0, 1, 2, ("a", "b"), 31.5, (1.0, -2.0), (("a", "left"),),
                     goal_distance_m=math.nan)
    value = {"run": run, "speeds": RobotSpeeds(0.2, 0.5), (0.02, 3): [np.arange(6.0).reshape(2, 3) / 7.0],
             "tiny": 5e-324, "inf": -math.inf, "count": np.int64(7), "tags": frozenset({(1, 2), (3, 4)})}
    back = decode(json.loads(json.dumps(encode(value))))
    assert back["run"].nodes_visited == ("a", "b") and math.isnan(back["run"].goal_distance_m)
    assert back["speeds"] == RobotSpeeds(0.2, 0.5)
    assert np.array_equal(back[(0.02, 3)][0], value[(0.02, 3)][0]) and back[(0.02, 3)][0].dtype == np.float64
    assert back["tiny"] == 5e-324 and back["inf"] == -math.inf and back["tags"] == value["tags"]
    assert back["count"] == 7 and isinstance(back["count"], np.int64)
    with pytest.raises(TypeError, match="cannot hold a object"):
        encode(object())


@pytest.mark.tier("unit")
def test_a_tasks_identity_is_its_batch_and_job_and_nothing_else() -> None:
    job = NAVIGATIONS[0]
    assert task_key("reproduce partitions: navigations", job) == task_key("reproduce partitions: navigations", job)
    assert task_key("reproduce partitions: navigations", job).startswith("reproduce-partitions-navigations-")
    assert task_key("a", job) != task_key("b", job)
    assert task_key("a", job) != task_key("a", NAVIGATIONS[1])


@pytest.mark.tier("graph")
def test_the_same_rows_come_from_a_cluster_started_by_the_documented_dask_scheduler_and_worker_commands(
        tmp_path: Path) -> None:
    dask = Path(sys.executable).parent / "dask"
    scheduler_file = tmp_path / "scheduler.json"
    logs = (tmp_path / "scheduler.log").open("w"), (tmp_path / "worker.log").open("w")
    scheduler = subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                  "--scheduler-file", str(scheduler_file)], stdout=logs[0], stderr=subprocess.STDOUT,
                                 cwd=WORKSPACE)
    worker = None
    try:
        worker = subprocess.Popen([str(dask), "worker", "--scheduler-file", str(scheduler_file), "--nworkers", "2",
                                   "--nthreads", "1", "--no-dashboard"], stdout=logs[1], stderr=subprocess.STDOUT,
                                  cwd=WORKSPACE, env={**os.environ, "PYTHONPATH": ""})
        address = wait_for_address(scheduler_file, scheduler)
        with Engine(EngineOptions(scheduler=address)) as engine:
            engine.client.wait_for_workers(2, timeout=120)
            on_cluster = rows_of(engine)
        with Engine(EngineOptions(workers=1)) as local:
            assert on_cluster == rows_of(local)
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.terminate()
                process.wait(timeout=60)
        for log in logs:
            log.close()


def wait_for_address(scheduler_file: Path, scheduler: subprocess.Popen) -> str:
    """The scheduler's address from the file it writes once it listens (the wait is on that file, bounded by the
    scheduler exiting)."""
    import time

    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and scheduler.poll() is None:
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (FileNotFoundError, json.JSONDecodeError, KeyError):
            time.sleep(0.1)
    raise AssertionError(f"the scheduler wrote no address (exit {scheduler.poll()})")


def test_an_address_where_no_scheduler_listens_is_one_error_naming_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import socket

    monkeypatch.setattr("rfidnav_experiments.engine.CONNECT_TIMEOUT_S", 3.0)
    with socket.socket() as unused:
        unused.bind(("127.0.0.1", 0))
        port = unused.getsockname()[1]
    with pytest.raises(EngineError, match=rf"--scheduler tcp://127.0.0.1:{port}: no scheduler answered within 3 s"):
        Engine(EngineOptions(scheduler=f"tcp://127.0.0.1:{port}")).__enter__()


@pytest.mark.tier("graph")
def test_a_reproduction_stopped_by_sigterm_resumes_and_prints_what_an_uninterrupted_run_prints(
        tmp_path: Path) -> None:
    """``reproduce partitions --runs 5`` is partitions' pinned subset: what an uninterrupted run of it gives is the
    results file's pinned rows (test_results runs it again and compares), so the resumed run is compared with them
    instead of with a third run of its own."""
    import signal
    import time

    interrupted = tmp_path / "interrupted"
    tasks = interrupted / "partitions_tasks.jsonl"
    assert results.REPRODUCTIONS["partitions"].pinned == {"runs": 5}
    command = [sys.executable, "-m", "rfidnav_bringup.cli", "reproduce", "partitions", "--runs", "5", "--json"]
    stopped = subprocess.Popen([*command, "--workers", "2", "--out", str(interrupted)], cwd=WORKSPACE,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    # Stopped once a fifth of its tasks have their rows (a wait on the file, bounded by the command ending).
    while stopped.poll() is None and (not tasks.exists() or len(tasks.read_text().splitlines()) < 1 + 40):
        time.sleep(0.1)
    stopped.send_signal(signal.SIGTERM)
    _, err = stopped.communicate(timeout=120)
    assert stopped.returncode == 128 + signal.SIGTERM, err
    held = len(tasks.read_text().splitlines()) - 1
    assert 40 <= held < 195
    resumed = subprocess.run([*command, "--workers", "1", "--out", str(interrupted), "--resume"], cwd=WORKSPACE,
                             capture_output=True, text=True, timeout=900)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{held} of 195 tasks taken from {tasks}" in resumed.stderr
    published = results.read_results(results.RESULTS_DIR / "partitions.json")
    assert json.loads(resumed.stdout) == published["pinned"]["rows"], results.numerics_differ(published)
