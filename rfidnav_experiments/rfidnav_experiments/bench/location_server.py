"""``./rfidnav bench location_server``: tier-one latency of paper 003 over DDS.

The location server runs in its own process (as in a run) on a leased domain, its database filled from the
two_tier_home map (96 grid fingerprints, 12 tag groups); this process sends it scans the WiFi simulator takes at
random points of the flat, one request at a time, and times each service round trip. Beside it, the matcher
alone in-process, so the DDS share is visible.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from rfidnav_bringup.api import DomainLease, ReadinessError, child_environment
from rfidnav_common.frames import WIFI_FRAME
from rfidnav_common.robot_map import load_route_map
from rfidnav_experiments.runners.two_tier import floor_extent, wifi_model
from rfidnav_localization.fingerprint import RadioMap
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_msgs.msg import AccessPointRss, WifiScan
from rfidnav_msgs.srv import Locate
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.world import load_world

MAP_FILE = CONFIG_DIR / "maps" / "two_tier_home.yaml"
WORLD_FILE = CONFIG_DIR / "worlds" / "two_tier_home.yaml"
READY_TIMEOUT_S = 30.0
ANSWER_TIMEOUT_S = 10.0
WARM_UP_RETRY_S = 2.0    # an untimed first call unanswered this long is sent again (its answer may have been lost)


def scans(count: int, seed: int) -> list[dict[str, float]]:
    world = load_world(WORLD_FILE)
    wifi = wifi_model(world)
    x_min, y_min, x_max, y_max = floor_extent(world)
    rng = np.random.default_rng(seed)
    points = rng.uniform((x_min + 0.2, y_min + 0.2), (x_max - 0.2, y_max - 0.2), (count, 2))
    return [{r.bssid: r.rssi_dbm for r in wifi.scan(float(x), float(y), rng)} for x, y in points]


def benchmark(requests: int = 500, seed: int = 1) -> dict[str, float]:
    samples = scans(requests, seed)
    radio_map = RadioMap(load_radio_map(load_route_map(MAP_FILE).radio_map_file))
    started = time.perf_counter()
    for scan in samples:
        radio_map.locate(scan)
    matcher_ms = 1e3 * (time.perf_counter() - started) / requests
    lease = DomainLease()
    with tempfile.TemporaryDirectory() as folder:
        server = subprocess.Popen(
            [sys.executable, "-m", "rfidnav_localization.location_server_node", "--ros-args",
             "-p", f"database_file:={Path(folder) / 'location.db'}", "-p", "create_database:=true",
             "-p", f"map_file:={MAP_FILE}"], env=child_environment(lease.domain_id),
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        context = Context()
        rclpy.init(context=context, domain_id=lease.domain_id)
        node = Node("bench_location_client", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            round_trips_ms = _round_trips(node, executor, server, samples)
        finally:
            node.destroy_node()
            executor.shutdown()
            context.try_shutdown()
            server.terminate()
            server.wait(timeout=10)
            lease.close()
    trips = np.array(round_trips_ms)
    return {"requests": requests, "fingerprints": len(radio_map), "p50_ms": round(float(np.percentile(trips, 50)), 3),
            "p99_ms": round(float(np.percentile(trips, 99)), 3), "max_ms": round(float(trips.max()), 3),
            "matcher_ms": round(matcher_ms, 3)}


def _round_trips(node: Node, executor: SingleThreadedExecutor, server: subprocess.Popen,
                 samples: list[dict[str, float]]) -> list[float]:
    client = node.create_client(Locate, "/location_server/locate")
    deadline = time.monotonic() + READY_TIMEOUT_S
    requests = [locate_request(scan) for scan in samples]
    answered = False
    # Ready, and then one untimed call answered: the service is "ready" once the server's request reader has matched,
    # but Fast DDS drops a response sent before its writer has matched our response reader (on a loaded machine, the
    # first one), so the first call is sent again until an answer proves the way back.
    while not answered:
        if server.poll() is not None:
            raise ReadinessError(f"location_server exited ({server.returncode}): {server.stderr.read().strip()}")
        if time.monotonic() > deadline:
            raise ReadinessError(f"location_server: no answer from /location_server/locate after "
                                 f"{READY_TIMEOUT_S:g} s")
        if not client.service_is_ready():
            executor.spin_once(timeout_sec=0.1)
            continue
        future = client.call_async(requests[0])
        retry_at = time.monotonic() + WARM_UP_RETRY_S
        while not future.done() and time.monotonic() < retry_at:
            executor.spin_once(timeout_sec=0.05)
        answered = future.done()
        if not answered:
            client.remove_pending_request(future)
    round_trips = []
    for request in requests:
        started = time.perf_counter()
        future = client.call_async(request)
        while not future.done():
            if time.perf_counter() - started > ANSWER_TIMEOUT_S:
                raise ReadinessError(f"location_server: no answer in {ANSWER_TIMEOUT_S:g} s")
            executor.spin_once(timeout_sec=0.05)
        round_trips.append(1e3 * (time.perf_counter() - started))
        if not future.result().success:
            raise ReadinessError(f"location_server: locate failed: {future.result().message}")
    return round_trips


def locate_request(scan: dict[str, float]) -> Locate.Request:
    points = [AccessPointRss(bssid=bssid, rssi_dbm=rssi) for bssid, rssi in scan.items()]
    request = Locate.Request(scan=WifiScan(access_points=points))
    request.scan.header.frame_id = WIFI_FRAME
    return request
