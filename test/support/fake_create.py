"""A fake iRobot Create 2 on the master side of a pseudo-terminal, for create_base's tests.

The node opens ``slave_path`` as it would /dev/ttyUSB0. A thread reads the master side, parses the Open Interface
opcodes create_base uses (Start, Safe, Full, Stop, Drive Direct, Query List; and Sensors), records every command,
integrates the wheel encoders from the last Drive Direct speeds over real (monotonic) time with the Create 2's
constants, and answers Query List from its state. Tests set the bumper, cliff and wheel-drop bits, and can make it
answer short (or not at all). Like the real base in Safe mode, a cliff or a wheel drop stops it and drops it to
Passive mode, where Drive Direct is ignored until Safe or Full comes again.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
import tty
from dataclasses import dataclass

from rfidnav_common import base_safety as safety
from rfidnav_drivers import create_oi as oi

ARGUMENT_BYTES = {oi.START: 0, oi.SAFE: 0, oi.FULL: 0, oi.STOP: 0, oi.DRIVE_DIRECT: 4, oi.SENSORS: 1}
MODES = {oi.START: "passive", oi.SAFE: "safe", oi.FULL: "full", oi.STOP: "off"}


@dataclass(frozen=True)
class Command:
    opcode: int
    args: tuple[int, ...]        # raw argument bytes


class FakeCreate:
    def __init__(self, left_count: int = 0, right_count: int = 0,
                 geometry: oi.WheelGeometry = oi.WheelGeometry()) -> None:
        self.master_fd, self.slave_fd = os.openpty()
        tty.setraw(self.master_fd)
        tty.setraw(self.slave_fd)
        self.slave_path = os.ttyname(self.slave_fd)
        self.geometry = geometry
        self.lock = threading.Lock()
        self.commands: list[Command] = []
        self.unknown_bytes: list[int] = []
        self.mode = "off"
        self.bits = dict.fromkeys(safety.CONDITIONS, False)
        self.left_counts = float(left_count)       # unwrapped; reported modulo 2^16
        self.right_counts = float(right_count)
        self.left_mm_s = self.right_mm_s = 0
        self.updated_s = time.monotonic()
        self.reply_bytes: int | None = None        # answer only this many bytes of a reply (0: stay silent)
        self.queries = 0
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self.run, name="fake_create", daemon=True)
        self.thread.start()

    # ------------------------------------------------------------------------------------------ for the test
    def set(self, **bits: bool) -> None:
        """Set condition bits by their BaseEvent names (bump_left=True, cliff_right=False, ...)."""
        with self.lock:
            for name, value in bits.items():
                if name not in self.bits:
                    raise KeyError(name)
                self.bits[name] = value
            if self.mode == "safe" and any(self.bits[n] for n in safety.HALTS):
                self.integrate()
                self.left_mm_s = self.right_mm_s = 0
                self.mode = "passive"

    def received(self) -> list[Command]:
        with self.lock:
            return list(self.commands)

    def opcodes(self) -> list[int]:
        return [command.opcode for command in self.received()]

    def drives(self, since: int = 0) -> list[tuple[int, int]]:
        """(right, left) mm/s of every Drive Direct received, from command index ``since`` on."""
        return [struct.unpack(">hh", bytes(c.args)) for c in self.received()[since:] if c.opcode == oi.DRIVE_DIRECT]

    def speeds(self) -> tuple[int, int]:
        """(right, left) mm/s the wheels turn at now."""
        with self.lock:
            return self.right_mm_s, self.left_mm_s

    def close(self) -> None:
        self.stopping.set()
        self.thread.join(timeout=2.0)
        os.close(self.master_fd)
        os.close(self.slave_fd)

    # ------------------------------------------------------------------------------------------ the base
    def integrate(self) -> None:
        """Advance the encoders to now at the current wheel speeds (call with the lock held)."""
        now = time.monotonic()
        per_mm = 1.0 / (self.geometry.metres_per_count * 1000.0)
        self.left_counts += self.left_mm_s * (now - self.updated_s) * per_mm
        self.right_counts += self.right_mm_s * (now - self.updated_s) * per_mm
        self.updated_s = now

    def run(self) -> None:
        buffer = bytearray()
        while not self.stopping.is_set():
            ready, _, _ = select.select([self.master_fd], [], [], 0.05)
            if not ready:
                continue
            try:
                buffer += os.read(self.master_fd, 1024)
            except OSError:          # EIO: no process has the slave open at the moment
                time.sleep(0.01)
                continue
            while buffer:
                used = self.execute(buffer)
                if used == 0:
                    break            # an incomplete command: wait for the rest
                del buffer[:used]

    def execute(self, buffer: bytearray) -> int:
        """Run the command at the start of ``buffer``; the bytes it took (0: incomplete)."""
        opcode = buffer[0]
        if opcode == oi.QUERY_LIST:
            if len(buffer) < 2 or len(buffer) < 2 + buffer[1]:
                return 0
            size = 2 + buffer[1]
        elif opcode in ARGUMENT_BYTES:
            size = 1 + ARGUMENT_BYTES[opcode]
            if len(buffer) < size:
                return 0
        else:
            with self.lock:
                self.unknown_bytes.append(opcode)
            return 1
        args = tuple(buffer[1:size])
        reply = b""
        with self.lock:
            self.commands.append(Command(opcode, args))
            self.integrate()
            if opcode in MODES:
                self.mode = MODES[opcode]
                if opcode == oi.STOP:
                    self.left_mm_s = self.right_mm_s = 0
            elif opcode == oi.DRIVE_DIRECT and self.mode in ("safe", "full"):
                self.right_mm_s, self.left_mm_s = struct.unpack(">hh", bytes(args))
            elif opcode in (oi.QUERY_LIST, oi.SENSORS):
                self.queries += 1
                reply = b"".join(self.packet(packet) for packet in (args[1:] if opcode == oi.QUERY_LIST else args))
                if self.reply_bytes is not None:
                    reply = reply[:self.reply_bytes]
        if reply:
            os.write(self.master_fd, reply)
        return size

    def packet(self, packet: int) -> bytes:
        b = self.bits
        if packet == oi.BUMPS_AND_WHEEL_DROPS:
            return bytes([b[safety.BUMP_RIGHT] | b[safety.BUMP_LEFT] << 1 | b[safety.WHEEL_DROP_RIGHT] << 2
                          | b[safety.WHEEL_DROP_LEFT] << 3])
        cliffs = {oi.CLIFF_LEFT: safety.CLIFF_LEFT, oi.CLIFF_FRONT_LEFT: safety.CLIFF_FRONT_LEFT,
                  oi.CLIFF_FRONT_RIGHT: safety.CLIFF_FRONT_RIGHT, oi.CLIFF_RIGHT: safety.CLIFF_RIGHT}
        if packet in cliffs:
            return bytes([b[cliffs[packet]]])
        if packet in (oi.LEFT_ENCODER, oi.RIGHT_ENCODER):
            counts = self.left_counts if packet == oi.LEFT_ENCODER else self.right_counts
            return struct.pack(">H", round(counts) % oi.ENCODER_MODULUS)
        raise ValueError(f"the fake Create does not know packet {packet}")
