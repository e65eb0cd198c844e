"""Which messages of one publisher a stepped participant has had, by their DDS publication sequence numbers, so
that messages sent again after a lost DDS match fill exactly the holes and are handled in the order they were
published (pure, no rclpy; rfidnav_common.stepped_node feeds it).

DDS numbers each writer's samples from 1 and delivers a reliable writer's samples in order and never twice. A
hole in the numbers is therefore a message lost: the match was dropped (a participant paused past its lease) and
found again between two of them. A message after a hole is held until the hole is filled, so a consumer handles
the publisher's messages in the order they went out, whether they came then or were sent again; a number at or
below one already had comes from a new writer (the producer was restarted), unless it is a resend's duplicate.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

# Holes wider than this are not waited for: more than a producer keeps to send again (stepped_node.RESEND_DEPTH).
WIDEST_HOLE = 100


@dataclass
class InOrder:
    """One subscription's numbers from its single publisher. :meth:`arrived` and :meth:`resent` return the
    messages to handle now, oldest first."""
    newest: int = 0                                         # the highest number had (handled or held); 0: none yet
    missing: set[int] = field(default_factory=set)          # numbers below ``newest`` that never came
    held: dict[int, Any] = field(default_factory=dict)      # messages after a hole, by number
    taken_again: set[int] = field(default_factory=set)      # numbers had from a resend: the original is a duplicate

    def arrived(self, number: int, message: Any) -> list[Any]:
        """A message from DDS with its publication sequence number."""
        if number == self.newest + 1 and not self.held and not self.taken_again:   # the usual case, first
            self.newest = number
            return [message]
        if number in self.taken_again:
            self.taken_again.discard(number)
            return []
        if self.newest == 0 or number <= self.newest or number - self.newest > WIDEST_HOLE:
            # The first; a new writer (a restarted producer starts again at 1), what the old one left being moot; or
            # a hole wider than any producer keeps to send again, never to be filled.
            released = [self.held[n] for n in sorted(self.held)]
            self.reset(number)
            return [*released, message]
        self.missing.update(range(self.newest + 1, number))
        self.newest = number
        self.held[number] = message
        return self.release()

    def resent(self, number: int, message: Any, lost_since: bool) -> list[Any]:
        """A message sent again. One in a hole is lost for certain; one after the newest had only if the match was
        lost since (``lost_since``), or it may still be coming (a consumer merely slow)."""
        if number in self.missing:
            self.missing.discard(number)
        elif number > self.newest and lost_since:
            if self.newest:
                self.missing.update(range(self.newest + 1, number))
            self.newest = number
        else:
            return []
        self.taken_again.add(number)
        self.held[number] = message
        return self.release()

    def lacks(self) -> bool:
        """Whether a hole holds messages back."""
        return bool(self.missing)

    def release(self) -> list[Any]:
        first_missing = min(self.missing, default=self.newest + 1)
        ready = sorted(n for n in self.held if n < first_missing)
        return [self.held.pop(n) for n in ready]

    def reset(self, number: int) -> None:
        self.newest = number
        self.missing.clear()
        self.held.clear()
        self.taken_again.clear()
