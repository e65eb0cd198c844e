"""A run's DDS partition (rfidnav_bringup/partition.py): a foreign graph in the run's domain -- an orphan of an
earlier run with the run's controller's name and action, publishing commands and NaN odometry -- is neither heard
nor recorded and takes no goal (issue 34: the orphan took the run's goal; 13 of a foreign node's /cmd_vel were
recorded as the run's own)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from rfidnav_bag.bags import read_messages
from rfidnav_bringup.errors import LaunchError
from rfidnav_bringup.partition import PROFILES_VARIABLE, partition_in, with_partition
from rfidnav_bringup.processes import DomainLease
from support.domains import handed_domains
from support.runs import WORKSPACE, one_run, run_cli

FOREIGN_SPEED = 1.25     # m/s: no command of line_follow_90's controller (0.2 m/s at most)

# The run's controller, as a killed run leaves it: its name, its action, its topics -- in the domain's default
# partition, or in another run's (the same to this run: not its own).
FOREIGN_GRAPH = f"""
import math, sys
import rclpy
from rclpy.action import ActionServer, GoalResponse
from rclpy.node import Node
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rfidnav_msgs.action import FollowTagRoute

rclpy.init(domain_id=int(sys.argv[1]))
node = Node("heading_controller")

def offered(_goal):
    print("goal offered", flush=True)
    return GoalResponse.ACCEPT

def execute(goal_handle):
    goal_handle.abort()
    return FollowTagRoute.Result()

ActionServer(node, FollowTagRoute, "/follow_tag_route", execute, goal_callback=offered)
commands = node.create_publisher(Twist, "/cmd_vel", 10)
odometry = node.create_publisher(Odometry, "/odom", 10)

def publish():
    command = Twist()
    command.linear.x = {FOREIGN_SPEED}
    commands.publish(command)
    pose = Odometry()
    pose.header.frame_id, pose.child_frame_id = "odom", "base_link"
    pose.pose.pose.position.x = math.nan
    odometry.publish(pose)

node.create_timer(0.05, publish)
print("up", flush=True)
rclpy.spin(node)
"""


def without_session_partition() -> dict[str, str]:
    env = dict(os.environ)
    env.pop(PROFILES_VARIABLE, None)
    env.pop("ROS_DOMAIN_ID", None)
    return env


@contextmanager
def foreign_graph(domain: int) -> Iterator[subprocess.Popen]:
    with subprocess.Popen([sys.executable, "-c", FOREIGN_GRAPH, str(domain)], stdout=subprocess.PIPE, text=True,
                          env=without_session_partition()) as foreign:
        try:
            assert foreign.stdout is not None and foreign.stdout.readline() == "up\n"
            yield foreign
        finally:
            foreign.kill()


def free_domain() -> int:
    with DomainLease(handed_domains()) as free:     # a domain of this worker's share, free now
        return free.domain_id


@pytest.mark.tier("graph")
def test_a_run_in_a_domain_with_a_foreign_controller_neither_hears_nor_records_it_and_sends_it_no_goal(
        tmp_path: Path) -> None:
    domain = free_domain()
    out = tmp_path / "runs"
    with foreign_graph(domain) as foreign:
        # Without the test session's partition: the run makes its own, as ./rfidnav run does from a shell.
        # At RTF 5, for the seconds it takes to call a publisher that stays nameless one outside the partition.
        result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "run", "line_follow_90", "--rtf", "5",
                                 "--seed", "1", "--domain", str(domain), "--out", str(out), "--quiet"],
                                cwd=WORKSPACE, env=without_session_partition(), capture_output=True, text=True,
                                timeout=600)
        foreign.kill()
        offered = foreign.communicate()[0]
    assert result.returncode == 0, result.stdout + result.stderr
    assert "goal offered" not in offered
    run = one_run(out)
    summary = json.loads((run / "summary.json").read_text())
    partition = summary["ros_domain"]["partition"]
    assert summary["ros_domain"]["id"] == domain and partition.startswith("rfidnav-")
    assert f"DDS partition {partition}" in result.stdout
    # Counted and said, not taken: the foreign node's topics, one publisher each.
    kept_out = summary["ros_domain"]["kept_out"]
    assert kept_out["/cmd_vel"] == 1 and kept_out["/odom"] == 1, kept_out
    assert f"a publisher on /cmd_vel not of this run is in ROS domain {domain}: kept out" in result.stdout
    bag = run / "bag"
    speeds = [message.linear.x for _, _, message in read_messages(bag, ["/cmd_vel"])]
    assert speeds and FOREIGN_SPEED not in speeds
    xs = [message.pose.pose.position.x for _, _, message in read_messages(bag, ["/odom"])]
    assert xs and not any(math.isnan(x) for x in xs)
    # The run's profile lived as long as the run: nothing of it is left for a later process to join.
    profile = result.stdout.split(f"{PROFILES_VARIABLE}=")[1].split()[0]
    assert not Path(profile).exists()


@pytest.mark.tier("graph")
def test_echo_of_a_topic_published_only_outside_its_partition_says_how_to_join_a_run(tmp_path: Path) -> None:
    domain = free_domain()
    with foreign_graph(domain):
        result = run_cli("echo", "/cmd_vel", "--domain", str(domain), "--count", "1", "--timeout", "2")
    assert result.returncode == 2, result.stdout + result.stderr
    assert "/cmd_vel: 0 of 1 messages within 2 s; its publishers are outside this process's DDS partition" \
        in result.stderr
    assert f"join it with the {PROFILES_VARIABLE}" in result.stderr


PROFILES = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
SHORT_LEASE = f"""<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="{PROFILES}"><profiles>
  <participant profile_name="short_lease" is_default_profile="true"><rtps><builtin><discovery_config>
    <leaseDuration><sec>2</sec></leaseDuration>
  </discovery_config></builtin></rtps></participant>
  <publisher profile_name="mine" is_default_profile="true"><qos><durability><kind>VOLATILE</kind></durability></qos>
  </publisher>
</profiles></dds>
"""


@pytest.mark.tier("unit")
def test_a_users_profile_keeps_its_settings_and_gains_the_partition_in_its_own_and_a_new_default_profile() -> None:
    root = with_partition(ElementTree.fromstring(SHORT_LEASE), "rfidnav-abc")
    assert partition_in(root) == "rfidnav-abc"
    namespace = f"{{{PROFILES}}}"
    publishers = root.findall(f".//{namespace}publisher")
    assert [p.get("profile_name") for p in publishers] == ["mine"]        # the user's default profile, not a second
    assert publishers[0].find(f".//{namespace}durability") is not None    # with what it said before
    subscriber = root.find(f".//{namespace}subscriber")
    assert subscriber is not None and subscriber.findtext(f".//{namespace}name") == "rfidnav-abc"
    assert root.findtext(f".//{namespace}leaseDuration/{namespace}sec") == "2"


@pytest.mark.tier("unit")
def test_a_profile_that_is_not_fast_dds_xml_is_named_in_one_line(tmp_path: Path) -> None:
    from rfidnav_bringup.partition import parse_profiles

    broken = tmp_path / "profiles.xml"
    broken.write_text("<dds><profiles>")
    with pytest.raises(LaunchError, match=f"{PROFILES_VARIABLE}={broken}: not Fast DDS profiles XML"):
        parse_profiles(broken)
    with pytest.raises(LaunchError, match="cannot read it"):
        parse_profiles(tmp_path / "missing.xml")
