"""Test-wide ROS environment: a private DDS domain, localhost-only discovery, strict message field checks. Set at
import, before any test initialises rclpy, so parallel or concurrent runs never hear each other.

And the tiers: every test has exactly one, declared as ``pytest.mark.tier(NAME)`` on its module (``pytestmark``) or,
where a module spans tiers, on the test itself (the closer one wins). The hook below turns it into the plain marker
NAME, so ``./rfidnav test -m unit`` selects a tier:

* ``unit``: pure code (no rclpy, no processes), seconds in all;
* ``slow``: pure code too, but whole in-process missions, reproductions or comparisons against scikit-fuzzy;
* ``node``: real nodes in this process on a private context and executor (``support.graph.Graph``);
* ``graph``: node processes over DDS, the CLI, the recorder and player, LLRP and serial peers.

Under ``colcon test`` pytest runs in a package's folder, whose ``test`` links here: this file is then loaded as
``<package>/test/conftest.py`` and collects only the modules that belong to that package (support/packages.py).
"""

from __future__ import annotations

import os

from support.domains import session_domain  # os only: nothing of ROS is loaded yet

# The session's own domain, 1-39 (support/domains.py): the next one after the controller's for each pytest-xdist
# worker, or two workers' tests would hear each other's nodes (a player's /clock, a recorder's topics). A session
# that a test starts (colcon test) inherits a worker's variables but is no worker of this controller: its own pid.
WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")   # gw0, gw1, ...; empty without workers
CONTROLLER = os.environ.get("RFIDNAV_TEST_CONTROLLER_PID", "")
if WORKER and CONTROLLER == str(os.getppid()):
    os.environ["ROS_DOMAIN_ID"] = str(session_domain(int(CONTROLLER), WORKER))
else:
    os.environ["RFIDNAV_TEST_CONTROLLER_PID"] = str(os.getpid())
    os.environ["ROS_DOMAIN_ID"] = str(session_domain(os.getpid(), ""))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_PYTHON_CHECK_FIELDS"] = "1"


import tempfile  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

from rfidnav_bringup.partition import join_process_partition  # noqa: E402  # XML only: nothing of ROS either

# The session's DDS partition, joined before anything of ROS as a run's orchestrator joins its own: the workers and
# the runs the tests start inherit it (a profile naming a partition is kept), so a test's nodes hear a run's graph.
# A test of the partition itself starts its run without it.
join_process_partition(Path(tempfile.gettempdir()))
from typing import TYPE_CHECKING  # noqa: E402

import pytest  # noqa: E402

from support.packages import owner  # noqa: E402

if TYPE_CHECKING:
    from support.graph import Graph

TIERS = ("unit", "slow", "node", "graph")
# The package colcon tests, when this file is loaded through its link (the path is not resolved); None from test/.
HERE = Path(__file__).parent
COLCON_PACKAGE = HERE.parent.name if (HERE.parent / "package.xml").is_file() else None


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """Under colcon test, skip (without importing them) the test modules of the other packages."""
    if COLCON_PACKAGE and collection_path.suffix == ".py" and collection_path.name.startswith("test_"):
        return owner(collection_path.resolve()) != COLCON_PACKAGE or None
    return None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    untiered = []
    for item in items:
        declared = item.get_closest_marker("tier")
        if declared is None or declared.args[0] not in TIERS:
            untiered.append(item.nodeid)
            continue
        item.add_marker(declared.args[0])
    if untiered:
        raise pytest.UsageError(f"tests without a tier (pytest.mark.tier, one of {', '.join(TIERS)}): "
                                + ", ".join(untiered[:10]) + (" ..." if len(untiered) > 10 else ""))


@pytest.fixture(scope="session")
def domain():
    """A DDS domain leased for this pytest process's session (as ./rfidnav run leases one), so that concurrent
    sessions, pytest-xdist's other worker and the runs the tests start never cross-talk with the nodes the tests
    make in this process. Held to the end, not per test: rclpy destroys a context's participant only once nothing
    refers to it any more, so a test's nodes can still be heard after it ended, and a run leasing the domain
    then would meet them ("another graph joined ROS domain 51: two nodes named /robot_sim"). Held past the session
    too, until this process ends: pytest-xdist lets a worker out of tests wait for the others, and a run of theirs
    leasing the domain then met its nodes still heard (a publisher in another DDS partition, reported kept out)."""
    # Imported here, not at the top: only the tests taking this fixture need rfidnav_bringup (support/packages.py).
    from rfidnav_bringup.processes import DomainLease

    lease = DomainLease()
    _HELD_TO_EXIT.append(lease)
    return lease.domain_id


_HELD_TO_EXIT: list[object] = []   # the session's domain lease, let go when the process ends (its lock's descriptor)


@pytest.fixture
def graph(domain: int) -> Iterator[Graph]:
    """Nodes under test and a probe on one private context and executor (support.graph.Graph), closed after."""
    # Imported here, not at the top: the environment above must be set before rclpy loads.
    from support.graph import Graph

    graph = Graph(domain)
    try:
        yield graph
    finally:
        graph.close()
