"""The signals an rfidnav process acts on, shared by the nodes (rfidnav_common.ros) and the orchestrator that sends
them (rfidnav_bringup). Pure module: no ROS."""

from __future__ import annotations

import signal

# Each ends a node, or a run, as Ctrl-C does.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

# A node writes every thread's Python stack to its log (stderr) on this signal: the orchestrator sends it to a
# node that did not stop within its grace period, before SIGKILL, so that the log says where it hung.
STACK_DUMP_SIGNAL = signal.SIGUSR1
