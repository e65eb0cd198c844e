"""./rfidnav echo: a topic's messages as YAML, typed from the graph, failing clearly without a publisher."""

from __future__ import annotations

import io
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
import yaml
from geometry_msgs.msg import Twist
from rclpy.qos import QoSProfile, ReliabilityPolicy

from rfidnav_bringup.echo import EchoError, echo
from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, twist
from support.graph import Graph
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")


@contextmanager
def spinning(graph: Graph) -> Iterator[None]:
    """The probe's executor spun from a thread while echo spins its own context."""
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            graph.executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def test_echo_prints_the_messages_a_publisher_sends(graph: Graph, domain: int) -> None:
    publisher = graph.probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
    graph.probe.create_timer(0.05, lambda: publisher.publish(twist(0.2, -0.5)))
    out = io.StringIO()
    with spinning(graph):
        assert echo("/cmd_vel", 2, wait_s=10.0, timeout_s=20.0, out=out, domain_id=domain) == 2
    documents = [d for d in yaml.safe_load_all(out.getvalue()) if d]
    assert len(documents) == 2
    assert documents[0]["linear"]["x"] == 0.2 and documents[0]["angular"]["z"] == -0.5


def test_echo_gets_the_one_message_a_latched_publisher_sent_before_it_started(graph: Graph, domain: int) -> None:
    graph.probe.create_publisher(Twist, "/latched", LATCHED_QOS).publish(twist(0.1, 0.0))
    out = io.StringIO()
    with spinning(graph):
        assert echo("/latched", 1, wait_s=10.0, timeout_s=20.0, out=out, domain_id=domain) == 1
    assert yaml.safe_load(out.getvalue().split("---")[0])["linear"]["x"] == 0.1


def test_echo_hears_a_best_effort_publisher_without_being_told(graph: Graph, domain: int) -> None:
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    publisher = graph.probe.create_publisher(Twist, "/best_effort", best_effort)
    graph.probe.create_timer(0.05, lambda: publisher.publish(twist(0.3, 0.0)))
    with spinning(graph):
        assert echo("/best_effort", 2, wait_s=10.0, timeout_s=20.0, out=io.StringIO(), domain_id=domain) == 2


def test_echo_without_a_publisher_is_one_clear_error(domain: int) -> None:
    with pytest.raises(EchoError, match="/nothing: no publisher within 0.5 s"):
        echo("/nothing", 1, wait_s=0.5, timeout_s=1.0, domain_id=domain)


def test_echo_into_a_reader_that_goes_away_ends_quietly_and_says_where_it_listened(graph: Graph, domain: int) -> None:
    """``./rfidnav echo /cmd_vel | head -1``: the closed pipe is the end of the output, not a traceback."""
    publisher = graph.probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
    graph.probe.create_timer(0.05, lambda: publisher.publish(twist(0.2, -0.5)))
    with spinning(graph), subprocess.Popen(
            [sys.executable, "-m", "rfidnav_bringup.cli", "echo", "/cmd_vel", "--count", "1000", "--domain",
             str(domain)], cwd=WORKSPACE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as cli:
        assert cli.stdout.readline() == "linear:\n"
        cli.stdout.close()              # as head does after its first line
        errors = cli.stderr.read()
        cli.wait(timeout=60)
    assert cli.returncode == 0, errors
    assert "Traceback" not in errors
    assert f"listening to /cmd_vel on ROS domain {domain} (localhost)" in errors
