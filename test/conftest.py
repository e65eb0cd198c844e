"""Test-wide ROS environment: a private DDS domain, localhost-only discovery, strict message field checks.

Set at import, before any test initialises rclpy, so parallel or concurrent runs never hear each other."""

from __future__ import annotations

import os

os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 50))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_PYTHON_CHECK_FIELDS"] = "1"


from collections.abc import Iterator  # noqa: E402
from typing import TYPE_CHECKING  # noqa: E402

import pytest  # noqa: E402

from rfidnav_bringup.processes import DomainLease  # noqa: E402

if TYPE_CHECKING:
    from test_nodes import Graph


@pytest.fixture
def domain():
    """A DDS domain leased for one test (as ./rfidnav run leases one), so concurrent sessions never cross-talk."""
    lease = DomainLease()
    try:
        yield lease.domain_id
    finally:
        lease.close()


@pytest.fixture
def graph(domain: int) -> Iterator["Graph"]:
    """Nodes under test and a probe on one private context and executor (test_nodes.Graph), closed after."""
    from test_nodes import Graph    # here, not at the top: the environment above must be set before rclpy loads

    graph = Graph(domain)
    try:
        yield graph
    finally:
        graph.close()
