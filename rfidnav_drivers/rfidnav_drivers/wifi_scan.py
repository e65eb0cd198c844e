"""What `iw dev IFACE scan` (and `scan dump`) prints, read into typed access points; its failures, one clear
error each. No rclpy: the wifi_scanner node runs this in a worker thread, the tests run it directly.

iw prints one block per BSS, a ``BSS aa:bb:cc:dd:ee:ff(on wlan0)`` line followed by indented fields, of which
three are read here::

    BSS 70:f0:96:d2:e0:62(on wlan0) -- associated
            freq: 2412                  (iw >= 6: ``freq: 2412.0``) [MHz]
            signal: -64.00 dBm
            SSID: WIFI_IUTB_IOT         (bytes other than printable ASCII escaped as \\xNN; empty when hidden)

A failed command prints ``command failed: <strerror> (<-errno>)`` on stderr and exits non-zero.
"""

from __future__ import annotations

import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

from rfidnav_drivers.errors import DriverError

SYS_CLASS_NET = Path("/sys/class/net")

_BSS_LINE = re.compile(r"^BSS ((?:[0-9A-Fa-f]{2}:){5}[0-9A-Fa-f]{2})")
_FREQ = re.compile(r"^freq:\s*(\d+(?:\.\d+)?)\s*$")
_SIGNAL_DBM = re.compile(r"^signal:\s*(-?\d+(?:\.\d+)?)\s*dBm\s*$")
_ESCAPED_BYTE = re.compile(r"\\x([0-9A-Fa-f]{2})")
_COMMAND_FAILED = re.compile(r"command failed: (.*) \((-\d+)\)")

ENODEV, EPERM, EBUSY, ENETDOWN = 19, 1, 16, 100


@dataclass(frozen=True)
class AccessPoint:
    bssid: str            # lower-case, colon separated
    ssid: str             # "" for a hidden network
    frequency_hz: float
    channel: int          # 0: not on a 2.4, 5 or 6 GHz WiFi channel
    rssi_dbm: float


# ------------------------------------------------------------------------------------------------ errors

class IwError(DriverError):
    """A scan failed. ``transient``: the next scan may well succeed, so the caller retries at its next period
    rather than giving up."""

    transient = False


class IwNotFound(IwError):
    pass


class InterfaceNotFound(IwError):
    """The interface is missing, or nl80211 does not know it (not a wireless interface)."""


class ScanNotPermitted(IwError):
    pass


class DeviceBusy(IwError):
    transient = True


class ScanTimedOut(IwError):
    transient = True


class ScanFailed(IwError):
    """Any other failure of iw (the interface down, an unexpected answer): reported and retried, since the
    system (NetworkManager, a replugged adapter) may mend it."""

    transient = True


# --------------------------------------------------------------------------------------------- channels

def channel_of(frequency_mhz: float) -> int:
    """The IEEE channel number of a 20 MHz channel's centre frequency; 0 for a frequency off the 2.4, 5 and
    6 GHz WiFi rasters (a 900 MHz S1G or 60 GHz BSS: reported with its frequency, but no channel number)."""
    if frequency_mhz != int(frequency_mhz):
        return 0                        # an S1G frequency with a kHz offset: no 2.4/5/6 GHz channel
    f = int(frequency_mhz)
    if f == 2484:
        return 14                       # Japan's channel 14 is off the 5 MHz raster of channels 1-13
    if 2412 <= f <= 2472 and (f - 2407) % 5 == 0:
        return (f - 2407) // 5
    if 5000 <= f < 5925 and f % 5 == 0:
        return (f - 5000) // 5
    if f == 5935:
        return 2                        # 6 GHz channel 2 is below channel 1 (5955 MHz), outside the formula
    if 5955 <= f <= 7115 and f % 5 == 0:
        return (f - 5950) // 5
    return 0


# ----------------------------------------------------------------------------------------------- parsing

def decode_ssid(escaped: str) -> str:
    """The SSID iw printed: ``\\xNN`` escapes back to bytes, then UTF-8 (most SSIDs), or Latin-1 for the
    byte strings that are not UTF-8 so that no SSID is lost. NUL bytes are dropped: hidden networks often
    announce an SSID of NULs, which is no name at all (and a ROS string cannot carry NUL)."""
    raw = bytearray()
    position = 0
    for match in _ESCAPED_BYTE.finditer(escaped):
        raw += escaped[position:match.start()].encode("utf-8")
        raw.append(int(match.group(1), 16))
        position = match.end()
    raw += escaped[position:].encode("utf-8")
    data = bytes(raw).replace(b"\x00", b"")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_scan(text: str) -> list[AccessPoint]:
    """The access points of iw's scan output, in its order. A BSS without a ``signal: ... dBm`` line is left
    out: some drivers report no signal, or only a 0-100 quality (``signal: 60/100``), and a scan message holds
    measured RSS only (an AP not heard is absent, never a placeholder). One without a frequency is left out
    too (iw always prints it; a truncated block is not a reading)."""
    access_points: list[AccessPoint] = []
    current: dict[str, object] | None = None

    def close() -> None:
        if current is not None and "frequency_mhz" in current and "rssi_dbm" in current:
            frequency_mhz = float(current["frequency_mhz"])
            access_points.append(AccessPoint(
                bssid=str(current["bssid"]), ssid=str(current.get("ssid", "")),
                frequency_hz=frequency_mhz * 1e6, channel=channel_of(frequency_mhz),
                rssi_dbm=float(current["rssi_dbm"])))

    for line in text.splitlines():
        bss = _BSS_LINE.match(line)
        if bss:
            close()
            current = {"bssid": bss.group(1).lower()}
            continue
        if current is None:
            continue
        # Fields are the BSS's indented lines; deeper lines (" * primary channel: 1", "center freq segment")
        # never start with these keys once stripped.
        field = line.strip()
        if field.startswith("freq:"):
            freq = _FREQ.match(field)
            if freq:
                current["frequency_mhz"] = float(freq.group(1))
        elif field.startswith("signal:"):
            signal = _SIGNAL_DBM.match(field)
            if signal:
                current["rssi_dbm"] = float(signal.group(1))
        elif field.startswith("SSID:") and "ssid" not in current:
            # iw escapes leading, trailing and non-printable bytes, so surrounding whitespace is not the SSID's.
            current["ssid"] = decode_ssid(field[len("SSID:"):].strip())
    close()
    return access_points


# ------------------------------------------------------------------------------------------------ running

def network_interfaces(sys_class_net: Path = SYS_CLASS_NET) -> list[str]:
    try:
        return sorted(entry.name for entry in sys_class_net.iterdir())
    except OSError:
        return []


def check_interface(interface: str, sys_class_net: Path = SYS_CLASS_NET) -> None:
    """DriverError naming ``interface`` and listing those that exist (wireless ones marked) when it is
    missing."""
    if (sys_class_net / interface).exists():
        return
    present = network_interfaces(sys_class_net)
    wireless = [name for name in present if (sys_class_net / name / "wireless").exists()
                or (sys_class_net / name / "phy80211").exists()]
    listed = ", ".join(f"{name} (wireless)" if name in wireless else name for name in present) or "none"
    raise InterfaceNotFound(f"network interface '{interface}' not found (no {sys_class_net / interface}); "
                            f"interfaces here: {listed}. Set the interface parameter (see `iw dev`).")


def scan_command(iw_path: str, interface: str, trigger: bool) -> list[str]:
    return [iw_path, "dev", interface, "scan"] if trigger else [iw_path, "dev", interface, "scan", "dump"]


def classify_failure(interface: str, command: list[str], returncode: int, output: str) -> IwError:
    """One clear error for a failed iw run, from its ``command failed: ... (-errno)`` line."""
    shown = " ".join(command)
    failed = _COMMAND_FAILED.search(output)
    if failed is None:
        last = output.strip().splitlines()[-1] if output.strip() else "no message"
        return ScanFailed(f"{interface}: `{shown}` failed (exit status {returncode}): {last}")
    detail = failed.group(0)
    errno = -int(failed.group(2))
    if errno == ENODEV:
        present = ", ".join(network_interfaces()) or "none"
        return InterfaceNotFound(
            f"{interface}: iw knows no such wireless device ({detail}): the interface has gone (adapter "
            f"unplugged, driver reloaded, renamed) or is not a wireless interface; interfaces now: {present}")
    if errno == EPERM:
        return ScanNotPermitted(
            f"{interface}: not permitted to scan ({detail}): triggering a scan needs CAP_NET_ADMIN. Grant it "
            f"to iw with `sudo setcap cap_net_admin+ep $(which iw)`, or set `trigger: false` to read the "
            f"system's last scan (`iw dev {interface} scan dump`), which needs no privilege")
    if errno == EBUSY:
        return DeviceBusy(
            f"{interface}: device busy ({detail}): another scan or a connection attempt (NetworkManager, "
            f"wpa_supplicant) is in progress; retry at the next period")
    if errno == ENETDOWN:
        return ScanFailed(f"{interface}: the interface is down ({detail}): bring it up "
                          f"(`sudo ip link set {interface} up`) or let the network manager do it")
    return ScanFailed(f"{interface}: `{shown}` failed: {detail}")


def run_scan(iw_path: str, interface: str, trigger: bool, timeout_s: float) -> list[AccessPoint]:
    """Run iw once and return what it heard; an IwError (see ``transient``) when it fails."""
    command = scan_command(iw_path, interface, trigger)
    # The C locale: iw's isprint() then escapes every non-ASCII byte, whatever the robot's locale, so
    # decode_ssid always sees the same form.
    environment = dict(os.environ, LC_ALL="C")
    try:
        done = subprocess.run(command, capture_output=True, text=True, errors="replace", timeout=timeout_s,
                              env=environment, check=False)
    except FileNotFoundError:
        raise IwNotFound(f"iw not found ('{iw_path}'): install it (`sudo apt install iw`) or set iw_path "
                         f"to the program") from None
    except PermissionError:
        raise IwNotFound(f"'{iw_path}' cannot be executed (permission denied): set iw_path to the iw "
                         f"program") from None
    except subprocess.TimeoutExpired:
        raise ScanTimedOut(f"{interface}: `{' '.join(command)}` gave no answer within {timeout_s:g} s; "
                           f"retrying at the next period") from None
    if done.returncode != 0:
        raise classify_failure(interface, command, done.returncode, done.stderr + done.stdout)
    return parse_scan(done.stdout)
