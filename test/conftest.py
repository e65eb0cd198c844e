"""Test-wide ROS environment: a private DDS domain, localhost-only discovery, strict message field checks.

Set at import, before any test initialises rclpy, so parallel or concurrent runs never hear each other."""

from __future__ import annotations

import os

os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 50))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_PYTHON_CHECK_FIELDS"] = "1"
