"""./rfidnav echo: a topic's messages as YAML, typed from the graph, failing clearly without a publisher."""

from __future__ import annotations

import io
import threading

import pytest
import yaml
from geometry_msgs.msg import Twist

from rfidnav_bringup.echo import EchoError, echo
from rfidnav_common.ros import COMMAND_QOS, twist
from support.graph import Graph

pytestmark = pytest.mark.tier("node")


def test_echo_prints_the_messages_a_publisher_sends(graph: Graph, domain: int) -> None:
    publisher = graph.probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
    graph.probe.create_timer(0.05, lambda: publisher.publish(twist(0.2, -0.5)))
    out = io.StringIO()
    # echo spins its own context; the probe publishes from a thread meanwhile.
    spinning = threading.Event()

    def spin() -> None:
        while not spinning.is_set():
            graph.executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin)
    thread.start()
    try:
        assert echo("/cmd_vel", 2, wait_s=10.0, timeout_s=20.0, out=out, domain_id=domain) == 2
    finally:
        spinning.set()
        thread.join()
    documents = [d for d in yaml.safe_load_all(out.getvalue()) if d]
    assert len(documents) == 2
    assert documents[0]["linear"]["x"] == 0.2 and documents[0]["angular"]["z"] == -0.5


def test_echo_without_a_publisher_is_one_clear_error(domain: int) -> None:
    with pytest.raises(EchoError, match="/nothing: no publisher within 0.5 s"):
        echo("/nothing", 1, wait_s=0.5, timeout_s=1.0, domain_id=domain)
