"""Full-graph tests: ./rfidnav run over real DDS, one process per node, recorded to MCAP.

One run of line_follow_90 is shared by the tests of this module (it takes ~40 s of wall time).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rfidnav_bag.bags import bag_info, read_messages
from rfidnav_bringup.partition import PROFILES_VARIABLE
from rfidnav_bringup.processes import DomainLease
from rfidnav_bringup.report import run_metrics
from rfidnav_common.frames import compose
from rfidnav_common.ros import odometry_pose
from support.domains import handed_domains
from support.frames import assert_same_pose, frame_tree
from support.runs import WORKSPACE, run_cli, run_killing_the_controller, run_scenario

pytestmark = pytest.mark.tier("graph")

# Issue 2: line_follow_90 over DDS at RTF >= 5 within the paper's RMSE.
GRAPH_TEST_RTF = 5.0
PAPER_RMSE_M = 0.034


@pytest.fixture(scope="module")
def line_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "line_follow_90", "--rtf", str(GRAPH_TEST_RTF), "--seed", "1",
                        "--params", f"heading_controller={WORKSPACE / 'config/params/flc_paper.yaml'}")


def test_mission_succeeds_within_paper_rmse(line_run: Path) -> None:
    summary = json.loads((line_run / "summary.json").read_text())
    assert summary["success"] is True
    assert summary["metrics"]["tags_reached"] == 2
    assert 0.0 < summary["metrics"]["tracking_rmse_m"] < PAPER_RMSE_M
    failed = {role: (line_run / "logs" / f"{role}.log").read_text()[-2000:]
              for role, node in summary["nodes"].items() if node["exit_code"] != 0}
    assert not failed, failed
    assert summary["sim_duration_s"] > 35.0   # 7 m at 0.2 m/s to the first tag alone


def test_navigation_nodes_never_subscribe_to_sim_topics(line_run: Path) -> None:
    graph = json.loads((line_run / "graph.json").read_text())
    assert "heading_controller" in graph["nodes"]
    assert "/rfid/reads" in graph["nodes"]["heading_controller"]["subscriptions"]
    for name, topics in graph["nodes"].items():
        if name in graph["simulator_nodes"] or name == "recorder":
            continue
        leaked = [t for t in topics["subscriptions"] if t.startswith("/sim/")]
        assert not leaked, f"{name} subscribes to ground truth {leaked}"
    params = (line_run / "params" / "heading_controller.yaml").read_text()
    assert "world_file" not in params


def test_recorder_lost_nothing(line_run: Path) -> None:
    topics = {t.name: t.count for t in bag_info(line_run / "bag").topics}
    # robot_sim publishes /clock, ground truth and /odom together at every sample: the three carry the same
    # sim times, without a gap. Only the very last sample may be cut, when the recording stops between two of
    # its three messages.
    stamps: dict[str, set[int]] = {"/clock": set(), "/sim/ground_truth": set(), "/odom": set()}
    for topic, _, message in read_messages(line_run / "bag", list(stamps)):
        stamp = message.clock if topic == "/clock" else message.header.stamp
        stamps[topic].add(stamp.sec * 1_000_000_000 + stamp.nanosec)
    last_common = min(max(times) for times in stamps.values())
    kept = [{time for time in times if time <= last_common} for times in stamps.values()]
    assert kept[0] == kept[1] == kept[2]
    assert all(len(times) - len(kept[0]) <= 1 for times in stamps.values())
    # The controller answers every reader round with a command until the mission ends; the reader goes on for the
    # steps until the clock source settles, as many as the machine's load lets through, so the rounds compared are
    # those up to the last command (bag log times are sim times).
    times: dict[str, list[int]] = {"/cmd_vel": [], "/rfid/reads": []}
    for topic, time, _ in read_messages(line_run / "bag", list(times)):
        times[topic].append(time)
    rounds = [time for time in times["/rfid/reads"] if time <= max(times["/cmd_vel"])]
    assert abs(len(times["/cmd_vel"]) - len(rounds)) <= 3
    assert topics["/sim/markers"] == 1


def test_third_party_readers_decode_every_message(line_run: Path) -> None:
    """Foxglove's readers (mcap + mcap_ros2) decode the bag with only the schemas it embeds."""
    mcap_file = next((line_run / "bag").glob("*.mcap"))
    counts: dict[str, int] = {}
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        schemas = {channel.topic: summary.schemas[channel.schema_id].name for channel in summary.channels.values()}
        # mcap_ros2 0.6 rejects type names with '_' (action-derived types such as
        # FollowTagRoute_FeedbackMessage); those are checked with rosbags below.
        decodable = [topic for topic, schema in schemas.items() if "_" not in schema.split("/")[-1]]
        for _, channel, _, decoded in reader.iter_decoded_messages(topics=decodable):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/rfid/reads":
                for reading in decoded.readings:
                    assert 0.0 <= reading.phase_rad < 6.2832
                    assert reading.frequency_hz > 9e8
    assert counts["/rfid/reads"] > 1000 and counts["/sim/ground_truth"] > 2000
    feedback = [m for _, _, m in read_messages(line_run / "bag", ["/follow_tag_route/_action/feedback"])]
    assert {m.feedback.target_tag_id for m in feedback} == {"C1", "C2"}


def test_report_recomputes_the_summary_metrics(line_run: Path) -> None:
    summary = json.loads((line_run / "summary.json").read_text())
    assert run_metrics(line_run) == summary["metrics"]
    result = run_cli("report", str(line_run), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert all(Path(p).stat().st_size > 10_000 for p in report["plots"])


@contextlib.contextmanager
def read_only(folder: Path) -> Iterator[None]:
    """The folder read-only for this user: a read-only bind mount for root (whom permission bits do not stop, as
    a run folder on a read-only disk or share would), its permission bits for anyone else."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            yield
        finally:
            folder.chmod(0o755)
        return
    for command in (["mount", "--bind", str(folder), str(folder)],
                    ["mount", "-o", "remount,bind,ro", str(folder), str(folder)]):
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            subprocess.run(["umount", str(folder)], capture_output=True)
            pytest.skip(f"cannot make a read-only bind mount here: {done.stderr.strip()}")
    try:
        yield
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def test_report_of_a_read_only_run_folder_is_refused_in_one_line_and_writes_its_plots_to_out(
        line_run: Path, tmp_path: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(line_run, run, ignore=shutil.ignore_patterns("*.png"))
    with read_only(run):
        refused = run_cli("report", str(run))
        plots = tmp_path / "plots"
        written = run_cli("report", str(run), "--json", "--out", str(plots))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    lines = [line for line in refused.stderr.splitlines() if line.startswith("rfidnav report:")]
    assert len(lines) == 1 and str(run) in lines[0] and "--out" in lines[0], refused.stderr
    assert written.returncode == 0, written.stderr
    assert {Path(p).parent for p in json.loads(written.stdout)["plots"]} == {plots}
    assert not list(run.glob("*.png"))


def test_missing_and_truncated_bags_are_clear_errors(line_run: Path, tmp_path: Path) -> None:
    result = run_cli("bag", "info", str(tmp_path / "nothing_here"))
    assert result.returncode != 0 and "nothing_here" in result.stderr and "Traceback" not in result.stderr
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "metadata.yaml").write_bytes((line_run / "bag" / "metadata.yaml").read_bytes())
    mcap_file = next((line_run / "bag").glob("*.mcap"))
    # Cut to its magic: nothing is readable (a bag cut further on is read up to the cut: test_bag_damage.py)
    (broken / mcap_file.name).write_bytes(mcap_file.read_bytes()[:8])
    for verb in (["report", str(broken)], ["bag", "info", str(broken)], ["replay", str(broken)]):
        result = run_cli(*verb)
        assert result.returncode != 0, verb
        assert "Traceback" not in result.stderr and "broken" in result.stderr, (verb, result.stderr)


def test_a_killed_controller_is_respawned_and_given_the_mission_again(tmp_path: Path) -> None:
    """heading_controller is `respawn: true`: killed mid-mission, it is restarted, the goal is sent again and
    the mission still succeeds, with the restart counted in summary.json."""
    out = tmp_path / "runs"
    with DomainLease(handed_domains()) as free:     # a domain of this worker's share, free now
        domain = free.domain_id
    returncode, output = run_killing_the_controller(out, "line_follow_90", "--rtf", str(GRAPH_TEST_RTF),
                                                    "--domain", str(domain))
    assert returncode == 0, output
    assert "re-sending the goal to the restarted heading_controller" in output
    # --quiet still says how to reach the graph
    reach = next(line for line in output.splitlines() if line.startswith("graph on "))
    assert f"to join it: ROS_DOMAIN_ID={domain} ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST" in reach
    assert f"{PROFILES_VARIABLE}={os.environ[PROFILES_VARIABLE]} ./rfidnav echo /odom" in reach   # the session's
    summary = json.loads(next(out.glob("*/summary.json")).read_text())
    assert summary["success"] is True and summary["ros_domain"]["id"] == domain
    assert summary["nodes"]["heading_controller"]["restarts"] == 1


def test_the_antennas_hang_under_base_link_and_odom_sits_in_the_map_at_the_start(line_run: Path) -> None:
    """The tf tree of a run without a localizer: the reader's antennas on /tf_static, odom -> base_link from the
    simulator's odometry on /tf, map -> odom at the start pose. So the tree starts the base where ground truth is,
    and then follows /odom (dead reckoning: this scenario's odometry drifts)."""
    tree = frame_tree(line_run)
    assert {tree.root_of(f"rfid_antenna_{port}") for port in (1, 2, 3)} == {"map"}
    assert tree.parents["rfid_antenna_1"] == "base_link"
    reads_frames = {m.header.frame_id for _, _, m in read_messages(line_run / "bag", ["/rfid/reads"])}
    assert reads_frames == {"base_link"}
    _, start_ns, start = next(read_messages(line_run / "bag", ["/sim/ground_truth"]))
    assert_same_pose(tree.base_in_map(start_ns), odometry_pose(start), 1e-6, 1e-6)
    odometry = [(t, m) for _, t, m in read_messages(line_run / "bag", ["/odom"])]
    start_pose = tree.pose_at("odom", start_ns)
    for stamp_ns, message in odometry[:: max(1, len(odometry) // 50)]:
        assert_same_pose(tree.base_in_map(stamp_ns), compose(start_pose, odometry_pose(message)), 1e-6, 1e-6)


def test_a_domain_given_with_domain_that_another_run_holds_is_refused_before_anything_starts(tmp_path: Path) -> None:
    with DomainLease(handed_domains()) as held:
        result = run_cli("run", "line_follow_90", "--domain", str(held.domain_id), "--no-record", "--out",
                         str(tmp_path))
    assert result.returncode == 2, result.stdout + result.stderr
    assert f"ROS domain {held.domain_id} is in use by another rfidnav run" in result.stderr
    assert not list(tmp_path.glob("*/logs/*.log"))          # no node was started


# Run in a process of its own: a run in process sets ROS_DOMAIN_ID in os.environ, which this worker's tests use.
IN_PROCESS_RUN = """
import json, sys
from pathlib import Path
from rfidnav_bringup.api import Orchestrator, RunOptions
from rfidnav_bringup.processes import nodes_in_domain
from rfidnav_scenario.scenario import load_scenario

domain, out = int(sys.argv[1]), Path(sys.argv[2])
orchestrator = Orchestrator(load_scenario("line_follow_90"),
                            RunOptions(rtf=float("inf"), seed=1, out_dir=out, record=False, quiet=True, domain=domain))
summary = orchestrator.run()   # the orchestrator object stays referenced: what it leaves behind stays too
print(json.dumps({"success": summary.document["success"], "left": nodes_in_domain(domain, 3.0)}))
"""


def test_a_run_in_process_leaves_no_node_in_its_domain_for_the_next_run_in_that_process(tmp_path: Path) -> None:
    """bench rtf and sweeps run one run after another in one process: the second run met the first's
    /rfidnav_orchestrator in the domain ("another graph joined ROS domain 51: two nodes named
    /rfidnav_orchestrator"), kept there by a cycle between the node and its action client."""
    with DomainLease(handed_domains()) as free:     # a domain of this worker's share, free now
        domain = free.domain_id
    result = subprocess.run([sys.executable, "-c", IN_PROCESS_RUN, str(domain), str(tmp_path)], cwd=WORKSPACE,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.splitlines()[-1]) == {"success": True, "left": []}, result.stderr[-2000:]

