"""Which topics the orchestrator waits for the recorder to cover before starting the clock: only the ones the
recorder will record. Waiting for an excluded topic or one of a type it cannot store would time out every run."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_bringup.graph_watch import recordable_type, topics_to_record
from rfidnav_bringup.orchestrator import Orchestrator
from rfidnav_bringup.run_plan import RunOptions
from rfidnav_scenario.scenario import load_scenario

pytestmark = pytest.mark.tier("unit")

PUBLISHED = [
    ("/rfid/reads", ["rfidnav_msgs/msg/TagReadArray"]),
    ("/clock", ["rosgraph_msgs/msg/Clock"]),
    ("/parameter_events", ["rcl_interfaces/msg/ParameterEvent"]),
    ("/vendor/status", ["vendor_msgs/msg/Status"]),
    ("/mixed", ["std_msgs/msg/String", "vendor_msgs/msg/Status"]),
]


def test_excluded_and_unrecordable_topics_are_not_waited_for():
    recordable = {"rfidnav_msgs/msg/TagReadArray", "rosgraph_msgs/msg/Clock", "rcl_interfaces/msg/ParameterEvent",
                  "std_msgs/msg/String"}
    topics = topics_to_record(PUBLISHED, exclude={"/parameter_events"}, recordable=recordable.__contains__)
    assert topics == ["/clock", "/mixed", "/rfid/reads"]


def test_nothing_excluded_and_everything_recordable_waits_for_every_topic():
    assert topics_to_record(PUBLISHED, exclude=(), recordable=lambda _: True) == sorted(t for t, _ in PUBLISHED)


def test_a_topic_is_judged_by_its_first_type_as_the_recorder_records_it():
    assert topics_to_record(PUBLISHED, (), lambda msgtype: msgtype == "vendor_msgs/msg/Status") == ["/vendor/status"]


@pytest.mark.parametrize("msgtype, expected", [
    ("rfidnav_msgs/msg/TagReadArray", True),
    ("rosgraph_msgs/msg/Clock", True),
    ("rfidnav_msgs/action/FollowTagRoute_FeedbackMessage", True),   # hidden action topic
    ("action_msgs/msg/GoalStatusArray", True),
    ("vendor_msgs/msg/Status", False),                               # package not installed
    ("std_msgs/msg/NoSuchMessage", False),                           # package installed, type unknown
    ("not_a_type", False),
])
def test_recordable_type_matches_what_the_recorder_can_store(msgtype: str, expected: bool):
    assert recordable_type(msgtype) is expected


@pytest.mark.tier("graph")
def test_the_recorder_is_told_the_topics_the_wait_leaves_out(tmp_path: Path):
    scenario = load_scenario("line_follow_90")
    options = RunOptions(out_dir=tmp_path, record_exclude=("/parameter_events", "/rosout"))
    orchestrator = Orchestrator(scenario, options)
    orchestrator.prepare(env={})
    recorder = orchestrator.processes["recorder"].command
    # With the stepped clock (the default) its answers on /sim/step_ack and its resends are left out too.
    assert ('exclude_topics:=["/parameter_events", "/rosout", "/sim/step_ack", "/stepped_clock/resend_request", '
            '"/stepped_clock/resend"]') in recorder
    # Node commands start with the executable load_scenario resolved.
    resolved = list(scenario.nodes["heading_controller"].command)
    assert orchestrator.processes["heading_controller"].command[:len(resolved)] == resolved


@pytest.mark.tier("graph")
def test_the_recorder_is_given_the_run_s_storage_options(tmp_path: Path):
    options = RunOptions(out_dir=tmp_path, compress=True, max_bag_size=1_000_000, max_bag_duration_s=30.0)
    orchestrator = Orchestrator(load_scenario("line_follow_90"), options)
    orchestrator.prepare(env={})
    recorder = orchestrator.processes["recorder"].command
    assert "compression:=zstd" in recorder
    assert "max_bag_size:=1000000" in recorder and "max_bag_duration_s:=30.0" in recorder
