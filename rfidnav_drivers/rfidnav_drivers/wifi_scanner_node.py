"""wifi_scanner: the robot's WiFi interface scanned with `iw`, publishing /wifi/scan (WifiScan) as wifi_sim does.

A scan takes seconds, so it runs in a worker thread (every ``period_s`` of wall time, the first at once) and never
blocks the executor: the thread runs ``iw dev IFACE scan`` (``trigger: true``; needs CAP_NET_ADMIN) or
``iw dev IFACE scan dump`` (the system's last results, no privilege), reads it with rfidnav_drivers.wifi_scan and
hands the result to the executor through a guard condition; the executor thread publishes it.

A busy device, a timeout or another passing failure is a warning and the next period scans again. No permission
to scan, a vanished interface or no iw is logged once as an error and the node stops: ``failed`` holds the error
and main() exits 2.
"""

from __future__ import annotations

import shutil
import threading
import time
from typing import Any

import rclpy
from builtin_interfaces.msg import Time
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, run_node, stop_requested
from rfidnav_drivers.errors import DriverError
from rfidnav_drivers.parameters import WifiScannerParameters
from rfidnav_drivers.wifi_scan import AccessPoint, IwError, IwNotFound, check_interface, run_scan, scan_command
from rfidnav_msgs.msg import AccessPointRss, WifiScan

FAILED_EXIT_CODE = 2


class WifiScannerNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests.

        Raises DriverError when the interface or iw is not there."""
        super().__init__("wifi_scanner", **node_options)
        self.params: WifiScannerParameters = declare_parameters(self, WifiScannerParameters)
        try:
            check_interface(self.params.interface)
            if shutil.which(self.params.iw_path) is None:
                raise IwNotFound(f"iw not found ('{self.params.iw_path}' is not a program): install it "
                                 f"(`sudo apt install iw`) or set iw_path")
        except DriverError:
            super().destroy_node()      # nothing of a node that cannot scan outlives its construction
            raise
        self.failed: IwError | None = None     # the error that stopped scanning
        self.scans_published = 0
        self.publisher = self.create_publisher(WifiScan, "wifi/scan", SENSOR_QOS)
        # Outcomes of the worker's scans, oldest first: (finish stamp, access points) or the error.
        self._outcomes: list[tuple[Time, list[AccessPoint]] | IwError] = []
        self._lock = threading.Lock()           # guards _outcomes and, with _stopping, the guard condition
        self._stopping = threading.Event()
        self._wake = self.create_guard_condition(self._take_outcomes)
        self._worker = threading.Thread(target=self._scan_loop, name="wifi_scanner-iw", daemon=True)
        command = " ".join(scan_command(self.params.iw_path, self.params.interface, self.params.trigger))
        self.get_logger().info(f"`{command}` every {self.params.period_s:g} s")
        self._worker.start()

    # ------------------------------------------------------------------------------------- worker thread
    def _scan_loop(self) -> None:
        while not self._stopping.is_set():
            started = time.monotonic()
            outcome: tuple[Time, list[AccessPoint]] | IwError
            try:
                access_points = run_scan(self.params.iw_path, self.params.interface, self.params.trigger,
                                         self.params.timeout_s)
            except IwError as error:
                outcome = error
            else:
                outcome = (self.get_clock().now().to_msg(), access_points)
            with self._lock:
                # destroy_node sets _stopping under this lock: past this check the guard condition still exists.
                if self._stopping.is_set():
                    return
                self._outcomes.append(outcome)
                self._wake.trigger()
            if isinstance(outcome, IwError) and not outcome.transient:
                return
            # Wall time: the scan itself is wall-clock bound, whatever the ROS clock does.
            self._stopping.wait(max(0.0, self.params.period_s - (time.monotonic() - started)))

    # ----------------------------------------------------------------------------------- executor thread
    def _take_outcomes(self) -> None:
        with self._lock:
            outcomes, self._outcomes = self._outcomes, []
        for outcome in outcomes:
            if isinstance(outcome, IwError):
                self._on_error(outcome)
            else:
                self._publish(*outcome)

    def _on_error(self, error: IwError) -> None:
        if error.transient:
            self.get_logger().warning(str(error))
            return
        if self.failed is None:
            self.failed = error
            self.get_logger().error(f"{error} -- stopping")
            self._stopping.set()

    def _publish(self, stamp: Time, access_points: list[AccessPoint]) -> None:
        msg = WifiScan(interface=self.params.interface, access_points=[
            AccessPointRss(bssid=ap.bssid, ssid=ap.ssid, channel=ap.channel, frequency_hz=ap.frequency_hz,
                           rssi_dbm=ap.rssi_dbm) for ap in access_points])
        msg.header.stamp = stamp
        msg.header.frame_id = self.params.frame_id
        self.publisher.publish(msg)
        self.scans_published += 1

    def destroy_node(self) -> None:
        with self._lock:
            self._stopping.set()
        # A scan in progress finishes on its own (bounded by timeout_s) and the daemon thread then exits.
        self._worker.join(timeout=0.2)
        super().destroy_node()


def spin_until_failed(executor: Executor, node: Node) -> int:
    """run_node's spin: until shutdown (0) or until the scanner has failed (FAILED_EXIT_CODE)."""
    while rclpy.ok(context=node.context) and not stop_requested() and getattr(node, "failed", None) is None:
        # Bounded waits: Python signal handlers run only when control returns from the executor.
        executor.spin_once(timeout_sec=0.1)
    return FAILED_EXIT_CODE if getattr(node, "failed", None) is not None else 0


def main(args: list[str] | None = None) -> int:
    # SingleThreadedExecutor: the worker wakes the executor with a guard condition, which rclpy's
    # EventsExecutor does not support; one wake-up per scan costs nothing.
    return run_node(WifiScannerNode, args, make_executor=SingleThreadedExecutor, spin=spin_until_failed)


if __name__ == "__main__":
    raise SystemExit(main())
