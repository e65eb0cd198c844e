"""A robot base's safety conditions, as rfidnav_msgs/BaseEvent names them, and what a base does while they hold.

One set of rules for every base that publishes /base/event: the Create driver (its bumpers, cliff sensors and
wheel drops) and the simulated base (a bumper pressed against a wall), so a consumer of /base/event sees the
same events and the same refusals from either. No rclpy here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

# Names of the safety conditions, as rfidnav_msgs/BaseEvent's constants spell them.
BUMP_LEFT, BUMP_RIGHT = "bump_left", "bump_right"
CLIFF_LEFT, CLIFF_FRONT_LEFT = "cliff_left", "cliff_front_left"
CLIFF_FRONT_RIGHT, CLIFF_RIGHT = "cliff_front_right", "cliff_right"
WHEEL_DROP_LEFT, WHEEL_DROP_RIGHT = "wheel_drop_left", "wheel_drop_right"
WATCHDOG = "watchdog"
BUMPS = (BUMP_LEFT, BUMP_RIGHT)
HALTS = (CLIFF_LEFT, CLIFF_FRONT_LEFT, CLIFF_FRONT_RIGHT, CLIFF_RIGHT, WHEEL_DROP_LEFT, WHEEL_DROP_RIGHT)
CONDITIONS = BUMPS + HALTS
# What the base does while a condition holds (BaseEvent.action).
STOPPED, FORWARD_BLOCKED, ALL_MOTION_BLOCKED, RELEASED = "stopped", "forward_blocked", "all_motion_blocked", "released"


@dataclass(frozen=True)
class BaseEventRecord:
    """One /base/event: a condition that started (``active``) or cleared, and what the base did."""
    event: str
    active: bool
    action: str


def gate_motion(linear_mps: float, angular_radps: float, bumped: bool, halted: bool) -> tuple[float, float]:
    """The velocity a base lets through while safety conditions hold: nothing on a cliff or a wheel drop
    (any motion could drive a wheel over the edge), no forward part against a pressed bumper (turning away on
    the spot and backing up are what gets the robot free)."""
    if halted:
        return 0.0, 0.0
    if bumped and linear_mps > 0.0:
        return 0.0, angular_radps
    return linear_mps, angular_radps


def blocking_action(condition: str) -> str:
    """BaseEvent.action for a condition that started: what the base refuses while it holds."""
    return FORWARD_BLOCKED if condition in BUMPS else ALL_MOTION_BLOCKED


@dataclass
class ConditionTracker:
    """Edges of the safety conditions between readings: which started and which cleared. All start inactive,
    so a condition that holds at start-up (the robot lifted: wheels dropped) is reported at once."""
    active: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(CONDITIONS, False))

    def update(self, now: Mapping[str, bool]) -> tuple[list[str], list[str]]:
        """(rising, falling) condition names for the new reading (every condition: held or not), in CONDITIONS
        order."""
        rising = [name for name in CONDITIONS if now[name] and not self.active[name]]
        falling = [name for name in CONDITIONS if self.active[name] and not now[name]]
        self.active = {name: bool(now[name]) for name in CONDITIONS}
        return rising, falling

    def events(self, now: Mapping[str, bool]) -> list[BaseEventRecord]:
        """The /base/event messages for the new reading: each started condition with what it blocks, each
        cleared one released."""
        rising, falling = self.update(now)
        return ([BaseEventRecord(name, True, blocking_action(name)) for name in rising]
                + [BaseEventRecord(name, False, RELEASED) for name in falling])

    @property
    def bumped(self) -> bool:
        return any(self.active[name] for name in BUMPS)

    @property
    def halted(self) -> bool:
        return any(self.active[name] for name in HALTS)
