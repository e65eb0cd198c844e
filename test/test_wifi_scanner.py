"""wifi_scanner: `iw` scan output read into access points (recorded real outputs, test/data/iw/README.md), the
failures of iw classified, and the node running a fake `iw` (a script printing a recorded output) through its
real subprocess path."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rcl_interfaces.msg import Log
from rclpy.parameter import Parameter

from rfidnav_common.ros import SENSOR_QOS
from rfidnav_drivers.errors import DriverError
from rfidnav_drivers.wifi_scan import (
    AccessPoint,
    DeviceBusy,
    InterfaceNotFound,
    IwNotFound,
    ScanFailed,
    ScanNotPermitted,
    ScanTimedOut,
    channel_of,
    check_interface,
    classify_failure,
    decode_ssid,
    parse_scan,
    run_scan,
)
from rfidnav_drivers.wifi_scanner_node import (
    FAILED_EXIT_CODE,
    WifiScannerNode,
    spin_until_failed,
)
from rfidnav_msgs.msg import WifiScan
from support.graph import Graph

pytestmark = pytest.mark.tier("unit")

DATA = Path(__file__).resolve().parent / "data/iw"
RPI_SCAN = DATA / "raspberrypi_wlan0_scan.txt"
OPENWRT_SCAN = DATA / "openwrt_ax6000_sta0_scan_filtered.txt"
FAILURES = {  # file, iw's exit status (err & 0xff), the error, transient, words the message must have
    "no_such_device": ("failure_no_such_device.txt", 237, InterfaceNotFound, False, ["No such device (-19)",
                                                                                    "not a wireless"]),
    "not_permitted": ("failure_not_permitted.txt", 255, ScanNotPermitted, False, [
        "Operation not permitted (-1)", "CAP_NET_ADMIN", "sudo setcap cap_net_admin+ep $(which iw)",
        "trigger: false"]),
    "busy": ("failure_busy.txt", 240, DeviceBusy, True, ["Device or resource busy (-16)", "retry"]),
}


# ------------------------------------------------------------------------------------------------ parser

def test_an_older_iw_scan_with_integer_frequencies() -> None:
    aps = parse_scan(RPI_SCAN.read_text())
    assert len(aps) == 4
    assert aps[0] == AccessPoint(bssid="70:f0:96:d2:e0:62", ssid="WIFI_IUTB_IOT", frequency_hz=2412e6, channel=1,
                                 rssi_dbm=-64.0)
    assert aps[1] == AccessPoint(bssid="cc:db:93:d1:06:c0", ssid="eduroam", frequency_hz=2412e6, channel=1,
                                 rssi_dbm=-83.0)
    assert (aps[2].bssid, aps[2].frequency_hz, aps[2].channel, aps[2].rssi_dbm) == ("5c:e1:76:7d:f7:82", 2437e6,
                                                                                   6, -74.0)
    assert aps[3] == AccessPoint(bssid="70:f0:96:d2:d8:01", ssid="UM-net", frequency_hz=2462e6, channel=11,
                                 rssi_dbm=-84.0)


def test_a_newer_iw_scan_with_fractional_frequencies_5_ghz_and_escaped_ssids() -> None:
    aps = {ap.bssid: ap for ap in parse_scan(OPENWRT_SCAN.read_text())}
    assert len(aps) == 16
    assert aps["c6:07:78:ae:2a:01"] == AccessPoint(bssid="c6:07:78:ae:2a:01", ssid="南京美女龙虾总店",
                                                   frequency_hz=5220e6, channel=44, rssi_dbm=-77.0)
    assert aps["dc:16:b2:15:2f:24"] == AccessPoint(bssid="dc:16:b2:15:2f:24", ssid="HUAWEI-601",
                                                   frequency_hz=5745e6, channel=149, rssi_dbm=-71.0)
    assert aps["dc:16:b2:15:2f:20"] == AccessPoint(bssid="dc:16:b2:15:2f:20", ssid="HUAWEI-601",
                                                   frequency_hz=2412e6, channel=1, rssi_dbm=-64.0)
    assert (aps["a4:39:b3:d1:46:69"].channel, aps["a4:39:b3:d1:46:69"].rssi_dbm) == (169, 6.0)
    assert (aps["a4:39:b3:d1:46:6a"].ssid, aps["a4:39:b3:d1:46:6a"].rssi_dbm) == ("NETGEAR51-Open", 24.0)
    hidden = sorted(bssid for bssid, ap in aps.items() if ap.ssid == "")
    assert hidden == ["2a:77:77:b0:23:0d", "82:ae:54:5e:87:dd", "8a:a0:be:05:e0:f7", "c6:07:78:8e:2a:01",
                      "c6:07:78:be:2a:01", "dc:16:b2:15:2f:26"]
    assert aps["8a:a0:be:05:e0:f7"].channel == 36 and aps["82:ae:54:5e:87:dd"].channel == 11


def test_hidden_ssids_escaped_bytes_and_entries_without_a_signal_in_dbm() -> None:
    text = "\n".join([
        "BSS AA:BB:CC:DD:EE:01(on wlan0) -- associated",     # upper case, associated: still one BSS
        "\tfreq: 5955.0", "\tsignal: -52.00 dBm", "\tSSID: ",
        "BSS aa:bb:cc:dd:ee:02 (on wlan0)",                   # old iw: a space before "(on"
        "\tfreq: 2437", "\tsignal: -61.50 dBm", "\tSSID: \\x00\\x00\\x00\\x00",
        "BSS aa:bb:cc:dd:ee:03(on wlan0)",
        "\tfreq: 2437", "\tSSID: no signal line",             # no signal: left out
        "BSS aa:bb:cc:dd:ee:04(on wlan0)",
        "\tfreq: 2462", "\tsignal: 60/100", "\tSSID: quality only",  # not dBm: left out
        "BSS aa:bb:cc:dd:ee:05(on wlan0)",
        "\tfreq: 5180.0", "\tsignal: -70.00 dBm", "\tSSID: \\x20caf\\xe9 \\x5cbar\\x20",
        "\tHT operation:", "\t\t * primary channel: 36", "\t\t * center freq segment 1: 42",
    ])
    aps = parse_scan(text)
    assert [ap.bssid for ap in aps] == ["aa:bb:cc:dd:ee:01", "aa:bb:cc:dd:ee:02", "aa:bb:cc:dd:ee:05"]
    assert (aps[0].ssid, aps[0].channel, aps[0].frequency_hz, aps[0].rssi_dbm) == ("", 1, 5955e6, -52.0)
    assert (aps[1].ssid, aps[1].rssi_dbm) == ("", -61.5)
    assert (aps[2].ssid, aps[2].channel) == (" café \\bar ", 36)     # Latin-1 byte, escaped spaces and backslash
    assert decode_ssid("Kim\\xe2\\x80\\x99s iPhone") == "Kim\u2019s iPhone"
    assert parse_scan("") == []


@pytest.mark.parametrize("mhz, channel", [
    (2412, 1), (2437, 6), (2472, 13), (2484, 14),                            # 2.4 GHz, 14 off the raster
    (5180, 36), (5500, 100), (5745, 149), (5825, 165), (5885, 177),          # 5 GHz
    (5935, 2), (5955, 1), (6115, 33), (7115, 233),                          # 6 GHz
    (2437.0, 6), (902.5, 0), (2400, 0), (58320, 0)])                         # iw >= 6 floats; not WiFi 2.4/5/6
def test_channel_numbers_of_the_three_bands(mhz: float, channel: int) -> None:
    assert channel_of(mhz) == channel


# ------------------------------------------------------------------------------------------------ failures

def fake_iw(tmp_path: Path, body: str) -> Path:
    """An executable `iw` stand-in that logs its arguments (one line per call) and runs ``body``."""
    script = tmp_path / "iw"
    script.write_text(f'#!/bin/sh\necho "$@" >> "{tmp_path / "calls"}"\n{body}')
    script.chmod(0o755)
    return script


def calls(tmp_path: Path) -> list[str]:
    path = tmp_path / "calls"
    return path.read_text().splitlines() if path.exists() else []


@pytest.mark.parametrize("case", sorted(FAILURES))
def test_each_failure_of_iw_is_one_clear_error(tmp_path: Path, case: str) -> None:
    name, status, kind, transient, words = FAILURES[case]
    iw = fake_iw(tmp_path, f'cat "{DATA / name}" >&2\nexit {status}\n')
    with pytest.raises(kind) as raised:
        run_scan(str(iw), "wlan0", trigger=True, timeout_s=10.0)
    error = raised.value
    assert isinstance(error, DriverError) and error.transient is transient
    for word in ["wlan0", *words]:
        assert word in str(error), (word, str(error))
    assert calls(tmp_path) == ["dev wlan0 scan"]
    # The same from the recorded text alone.
    assert type(classify_failure("wlan0", ["iw", "dev", "wlan0", "scan"], status, (DATA / name).read_text())) \
        is kind


def test_iw_not_installed_a_timeout_and_an_unknown_failure(tmp_path: Path) -> None:
    with pytest.raises(IwNotFound, match="apt install iw"):
        run_scan(str(tmp_path / "no-such-iw"), "wlan0", trigger=True, timeout_s=1.0)
    sleeper = fake_iw(tmp_path, "exec sleep 5\n")
    with pytest.raises(ScanTimedOut, match="within 0.3 s") as raised:
        run_scan(str(sleeper), "wlan0", trigger=False, timeout_s=0.3)
    assert raised.value.transient and calls(tmp_path) == ["dev wlan0 scan dump"]
    down = classify_failure("wlan0", ["iw"], 156, "command failed: Network is down (-100)\n")
    assert isinstance(down, ScanFailed) and down.transient and "ip link set wlan0 up" in str(down)
    usage = classify_failure("wlan0", ["iw", "dev", "wlan0", "scan"], 1, "Usage:\tiw [options] command\n")
    assert isinstance(usage, ScanFailed) and "exit status 1" in str(usage)


def test_a_missing_interface_is_named_with_those_that_exist(tmp_path: Path) -> None:
    net = tmp_path / "net"
    for name in ("lo", "eth0", "wlan1"):
        (net / name).mkdir(parents=True)
    (net / "wlan1" / "wireless").mkdir()
    check_interface("eth0", net)
    with pytest.raises(InterfaceNotFound) as raised:
        check_interface("wlan0", net)
    assert "'wlan0' not found" in str(raised.value)
    assert "interfaces here: eth0, lo, wlan1 (wireless)" in str(raised.value)


# ---------------------------------------------------------------------------------------------------- node

def scanner(graph: Graph, iw: Path, **overrides: object) -> WifiScannerNode:
    parameters = {"interface": "lo", "iw_path": str(iw), "period_s": 0.2, **overrides}
    return graph.add(WifiScannerNode(context=graph.context, parameter_overrides=[
        Parameter(name, value=value) for name, value in parameters.items()]))


def listen(graph: Graph) -> list[WifiScan]:
    scans: list[WifiScan] = []
    graph.probe.create_subscription(WifiScan, "/wifi/scan", scans.append, SENSOR_QOS)
    return scans


def errors_logged(graph: Graph) -> list[str]:
    return [log.msg for log in graph.logs if log.name == "wifi_scanner" and log.level == Log.ERROR]


@pytest.mark.tier("node")
def test_the_node_publishes_what_a_real_scan_printed(graph: Graph, tmp_path: Path) -> None:
    iw = fake_iw(tmp_path, f'cat "{RPI_SCAN}"\n')
    scans = listen(graph)
    before_s = time.time()
    node = scanner(graph, iw, frame_id="wifi_antenna")
    graph.spin_until(lambda: len(scans) >= 2, "two scans on /wifi/scan")
    msg = scans[0]
    assert (msg.interface, msg.header.frame_id) == ("lo", "wifi_antenna")
    assert before_s - 1.0 <= msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 <= time.time()
    assert [(ap.bssid, ap.ssid, ap.channel, ap.frequency_hz, ap.rssi_dbm) for ap in msg.access_points] == [
        ("70:f0:96:d2:e0:62", "WIFI_IUTB_IOT", 1, 2412e6, -64.0), ("cc:db:93:d1:06:c0", "eduroam", 1, 2412e6, -83.0),
        ("5c:e1:76:7d:f7:82", "WIFI_IUTB_IOT", 6, 2437e6, -74.0), ("70:f0:96:d2:d8:01", "UM-net", 11, 2462e6, -84.0)]
    assert set(calls(tmp_path)) == {"dev lo scan"} and node.failed is None


@pytest.mark.tier("node")
def test_trigger_false_reads_the_last_scan_with_scan_dump(graph: Graph, tmp_path: Path) -> None:
    iw = fake_iw(tmp_path, f'cat "{OPENWRT_SCAN}"\n')
    scans = listen(graph)
    scanner(graph, iw, trigger=False)
    graph.spin_until(lambda: scans, "a scan on /wifi/scan")
    assert len(scans[0].access_points) == 16
    assert calls(tmp_path)[0] == "dev lo scan dump"


@pytest.mark.tier("node")
def test_a_busy_device_is_a_warning_and_the_next_period_scans_again(graph: Graph, tmp_path: Path) -> None:
    name, status, *_ = FAILURES["busy"]
    iw = fake_iw(tmp_path, f'if [ "$(wc -l < "{tmp_path / "calls"}")" -le 1 ]; then\n'
                           f'  cat "{DATA / name}" >&2; exit {status}\nfi\ncat "{RPI_SCAN}"\n')
    scans = listen(graph)
    node = scanner(graph, iw)
    graph.spin_until(lambda: scans, "a scan after the busy one")
    graph.spin_until(lambda: graph.logged("wifi_scanner", "Device or resource busy (-16)", "retry"),
                     "the warning about the busy device")
    assert node.failed is None and not errors_logged(graph) and len(scans[0].access_points) == 4


@pytest.mark.tier("node")
def test_no_permission_logs_one_error_and_stops_the_node_with_exit_code_2(graph: Graph, tmp_path: Path) -> None:
    name, status, *_ = FAILURES["not_permitted"]
    iw = fake_iw(tmp_path, f'cat "{DATA / name}" >&2\nexit {status}\n')
    scans = listen(graph)
    node = scanner(graph, iw)
    graph.spin_until(lambda: node.failed is not None and errors_logged(graph), "the scanner to fail")
    graph.spin_until(lambda: not node._worker.is_alive(), "the scan thread to end")
    for _ in range(10):                                  # several periods: no more scans, no more errors
        graph.executor.spin_once(timeout_sec=0.05)
    assert isinstance(node.failed, ScanNotPermitted)
    assert len(errors_logged(graph)) == 1 and "sudo setcap cap_net_admin+ep $(which iw)" in errors_logged(graph)[0]
    assert calls(tmp_path) == ["dev lo scan"] and scans == []
    assert spin_until_failed(graph.executor, node) == FAILED_EXIT_CODE


@pytest.mark.tier("graph")
def test_main_exits_2_when_not_permitted(tmp_path: Path, domain: int) -> None:
    name, status, *_ = FAILURES["not_permitted"]
    iw = fake_iw(tmp_path, f'cat "{DATA / name}" >&2\nexit {status}\n')
    done = subprocess.run(
        [sys.executable, "-c", "from rfidnav_drivers.wifi_scanner_node import main; raise SystemExit(main())",
         "--ros-args", "-p", "interface:=lo", "-p", f"iw_path:={iw}"],
        capture_output=True, text=True, timeout=60, env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
    assert done.returncode == FAILED_EXIT_CODE, done.stderr
    assert "CAP_NET_ADMIN" in done.stderr + done.stdout


@pytest.mark.tier("node")
def test_a_missing_interface_or_iw_fails_at_construction(graph: Graph, tmp_path: Path) -> None:
    iw = fake_iw(tmp_path, f'cat "{RPI_SCAN}"\n')
    with pytest.raises(DriverError) as raised:
        WifiScannerNode(context=graph.context, parameter_overrides=[
            Parameter("interface", value="nosuchwlan9"), Parameter("iw_path", value=str(iw))])
    assert "'nosuchwlan9' not found" in str(raised.value) and "lo" in str(raised.value)
    with pytest.raises(IwNotFound, match="apt install iw"):
        WifiScannerNode(context=graph.context, parameter_overrides=[
            Parameter("interface", value="lo"), Parameter("iw_path", value=str(tmp_path / "no-iw"))])
    assert calls(tmp_path) == []
