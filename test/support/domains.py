"""The DDS domains the tests take for themselves, apart from the runs' own leases (51 and up):

* 1-39, the sessions' own: conftest gives each pytest process (each xdist worker) one for the nodes it makes;
* 40-50, the domains a test leases and then hands to a run or a node (``--domain N``). A lease is let go before the
  hand-over, so two xdist workers could pick the same one in between: each worker takes its own share of them."""

from __future__ import annotations

import os

SESSION_DOMAINS = range(1, 40)
HANDED_DOMAINS = range(40, 51)


def session_domain(pid: int, worker: str) -> int:
    """The session's domain: from the pid (two concurrent sessions rarely meet), the next one for each worker."""
    index = int(worker.removeprefix("gw")) if worker else 0
    return SESSION_DOMAINS[(pid + index) % len(SESSION_DOMAINS)]


def handed_domains() -> range:
    """This pytest process's share of HANDED_DOMAINS: all of them without xdist, else a slice per worker."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if not worker:
        return HANDED_DOMAINS
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    size = max(2, len(HANDED_DOMAINS) // workers)
    start = HANDED_DOMAINS.start + int(worker.removeprefix("gw")) * size % len(HANDED_DOMAINS)
    return range(start, min(start + size, HANDED_DOMAINS.stop))
