"""Every reader opens a recorded run.

One real run of line_follow_90 to its first tag (``./rfidnav run`` over DDS, one process per node, ``--rtf max``),
recorded with ``--compress --max-bag-size``, so its bag is split into several zstd-compressed files. Then:

* rosbags' AnyReader decodes every message of every connection, the action's feedback and status included.
  It parses each schema text the bag embeds and checks it against the RIHS01 hash in metadata.yaml, so a
  definition that names a type wrongly fails here;
* mcap + mcap_ros2 (Foxglove's Python path) decode every topic of every file except the action feedback:
  mcap_ros2 0.6 rejects the type name rosidl gives it (``X_FeedbackMessage``; it knows ``_Feedback`` only);
* ``rosbags-convert`` turns the bag into a ROS 1 bag that AnyReader opens and decodes in full, all but the
  action feedback: its nested types live in ``rfidnav_msgs/action/``, a namespace ROS 1 does not have, and
  rosbags' ROS 1 writer takes nested types from ``msg/`` only;
* ``./rfidnav bag info`` and the report's metrics read it as they read a one-file bag.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from rfidnav_bag.bags import bag_info
from rfidnav_bringup.report import run_metrics
from support.runs import run_cli, run_scenario

pytestmark = pytest.mark.tier("graph")

MAX_BAG_SIZE = 128 * 1024   # the run's ~0.6 MB of compressed chunks in several files
FEEDBACK = "/follow_tag_route/_action/feedback"
STATUS = "/follow_tag_route/_action/status"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "line_follow_90", "--goal", "{tag_ids: [C1]}",
                        "--rtf", "max", "--compress", "--max-bag-size", str(MAX_BAG_SIZE))


def recorded_counts(bag: Path) -> dict[str, int]:
    return {t.name: t.count for t in bag_info(bag).topics if t.count}


def test_the_run_is_split_into_compressed_files(run: Path) -> None:
    info = bag_info(run / "bag")
    assert len(info.files) >= 2, info.files
    assert [f.path.name for f in info.files] == [f"bag_{i}.mcap" for i in range(len(info.files))]
    assert {f.compression for f in info.files} == {"zstd"}
    assert sum(f.message_count for f in info.files) == info.message_count
    assert info.ros_distro == "jazzy"


def test_anyreader_decodes_every_message_of_the_run(run: Path) -> None:
    counts: Counter[str] = Counter()
    targets = set()
    with AnyReader([run / "bag"]) as reader:
        for connection, _, data in reader.messages():
            message = reader.deserialize(data, connection.msgtype)
            counts[connection.topic] += 1
            if connection.topic == FEEDBACK:
                targets.add(message.feedback.target_tag_id)
    assert dict(counts) == recorded_counts(run / "bag")
    assert counts[FEEDBACK] > 0 and counts[STATUS] > 0 and counts["/rfid/reads"] > 500
    assert targets == {"C1"}


def test_mcap_ros2_decodes_every_topic_but_the_action_feedback_in_every_file(run: Path) -> None:
    counts: Counter[str] = Counter()
    for mcap_file in sorted((run / "bag").glob("*.mcap")):
        with mcap_file.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            topics = [c.topic for c in reader.get_summary().channels.values() if c.topic != FEEDBACK]
            for _, channel, _, decoded in reader.iter_decoded_messages(topics=topics):
                counts[channel.topic] += 1
                if channel.topic == STATUS:
                    assert all(0 <= s.status <= 6 for s in decoded.status_list)
    expected = recorded_counts(run / "bag")
    expected.pop(FEEDBACK)
    assert dict(counts) == expected
    assert counts[STATUS] > 0


def test_rosbags_convert_makes_a_ros1_bag_of_the_run(run: Path, tmp_path: Path) -> None:
    """Every topic but the action feedback, whose nested types ROS 1 cannot name (no action namespace)."""
    ros1 = tmp_path / "run.bag"
    result = subprocess.run([str(Path(sys.prefix) / "bin" / "rosbags-convert"), "--src", str(run / "bag"),
                             "--dst", str(ros1), "--exclude-topic", FEEDBACK],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    counts: Counter[str] = Counter()
    with AnyReader([ros1]) as reader:
        assert not reader.is2
        for connection, _, data in reader.messages():
            reader.deserialize(data, connection.msgtype)
            counts[connection.topic] += 1
    expected = recorded_counts(run / "bag")
    expected.pop(FEEDBACK)
    assert dict(counts) == expected
    assert counts[STATUS] > 0


def test_bag_info_and_the_report_read_the_split_run(run: Path) -> None:
    result = run_cli("bag", "info", str(run), "--json")
    assert result.returncode == 0, result.stderr
    info = json.loads(result.stdout)
    assert info["compression"] == "zstd" and len(info["files"]) >= 2
    assert sum(f["message_count"] for f in info["files"]) == info["message_count"]
    summary = json.loads((run / "summary.json").read_text())
    assert summary["success"] is True
    metrics = run_metrics(run)   # what ./rfidnav report prints, without drawing the plots
    assert metrics == summary["metrics"]
    # the whole approach to C1 (~7 m from the start) is in the bag, not one file's share of it
    assert metrics["tags_reached"] == 1 and metrics["path_length_m"] > 6.0


@pytest.mark.parametrize("option, value, complaint", [
    ("--max-bag-size", "100", "at least 1024 bytes"),
    ("--max-bag-size", "1MB", "expected a number of bytes"),
    ("--max-bag-duration", "-5", "seconds >= 0"),
])
def test_bad_split_options_are_refused_before_anything_runs(tmp_path: Path, option: str, value: str,
                                                            complaint: str) -> None:
    result = run_cli("run", "line_follow_90", option, value, "--out", str(tmp_path))
    assert result.returncode == 2
    assert option in result.stderr and complaint in result.stderr and "Traceback" not in result.stderr
    assert not any(tmp_path.iterdir())
