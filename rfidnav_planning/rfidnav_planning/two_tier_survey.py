"""Paper 003's automatic radio map construction: the robot's own survey.

Docked on a landmark of its map (a known start: the radio map is still empty, so tier one cannot place it), the
robot drives to each other landmark in turn with the two-tier navigator and scans WiFi every ``spacing_m`` metres
driven while its position is fresh from a tag fix (within ``fresh_m`` of odometry since it), recording each scan
at the position it believes, never the true one; the location server adds it to the radio map at once, so the
tier-one checks of the later legs use the map built so far. A leg that reached its landmark gives the next one a
known start there; after one that did not, the next starts from tier one.

:class:`RobotSurvey` sequences the legs and :class:`SurveyRule` says when to scan: the in-process runner
(rfidnav_experiments.runners.two_tier.robot_survey) and two_tier_navigator's ``/survey`` action both use them.

Pure module: no ROS.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from rfidnav_common.tag_groups import HF_READ_RANGE_M, TagGroup
from rfidnav_localization.dead_reckoning import TIER_TAG, DeadReckoningEstimate, Fix

SURVEY_FRESH_M = 2.0          # survey only within this odometry distance of a tag fix (sd ~ 10 cm at 5 % drift)
SURVEY_SPACING_M = 0.5        # a scan every this many metres driven, while fresh


@dataclass
class SurveyRule:
    """When one leg of the survey scans: every ``spacing_m`` of odometry while the last fix is a tag fix at most
    ``fresh_m`` behind."""

    spacing_m: float = SURVEY_SPACING_M
    fresh_m: float = SURVEY_FRESH_M
    surveyed_at_m: float = -math.inf      # odometry distance at the last scan of this leg

    def __post_init__(self) -> None:
        if not (math.isfinite(self.spacing_m) and self.spacing_m > 0.0):
            raise ValueError(f"spacing_m: must be a positive number of metres, got {self.spacing_m}")

    def due(self, estimate: DeadReckoningEstimate, travelled_m: float) -> tuple[float, float] | None:
        """Where the scan taken now is recorded (the believed position), or None when no scan is due; a position
        returned counts as surveyed whether or not the scan hears any access point."""
        fix = estimate.last_fix
        if (estimate.position is None or fix is None or not fix.tag_id
                or estimate.distance_since_fix_m > self.fresh_m or travelled_m - self.surveyed_at_m < self.spacing_m):
            return None
        self.surveyed_at_m = travelled_m
        return estimate.position


@dataclass(frozen=True)
class SurveyLeg:
    index: int                          # 0-based, in the order driven
    landmark: str                       # the tag group it drives to
    target: tuple[float, float]         # its centre
    known_start: Fix | None             # where the leg starts when the robot knows it (the dock, the last landmark)


@dataclass
class RobotSurvey:
    """The survey's legs over ``groups`` (the robot map's tag groups): docked on ``dock`` (its first if empty), to
    each of ``landmarks`` in order (all the others, in the map's order, if empty)."""

    groups: Sequence[TagGroup]
    dock: str = ""
    landmarks: Sequence[str] = ()
    reached: list[str] = field(default_factory=list)     # the landmarks the legs so far reached
    legs: list[SurveyLeg] = field(default_factory=list)  # the legs started so far

    def __post_init__(self) -> None:
        by_id = {group.group_id: group for group in self.groups}
        if not by_id:
            raise ValueError("the robot's survey visits the map's landmarks (tag_groups): the map has none")
        dock = self.dock or self.groups[0].group_id
        unknown = [name for name in (dock, *self.landmarks) if name not in by_id]
        if unknown:
            raise ValueError(f"no tag group {', '.join(map(repr, unknown))} in the map "
                             f"(known: {', '.join(by_id)})")
        self.dock = dock
        self.route = [by_id[name] for name in self.landmarks] or [group for group in self.groups
                                                                   if group.group_id != dock]
        if not self.route:
            raise ValueError(f"nothing to survey: the map's only landmark is the dock {dock!r}")
        self.dock_group = by_id[dock]

    def first_leg(self) -> SurveyLeg:
        """The first leg, from the dock (a known start on its centre)."""
        start = self.dock_group
        return self._leg(Fix(start.centre, HF_READ_RANGE_M, TIER_TAG, f"{start.group_id} (dock)"))

    def leg_ended(self, reached: bool) -> SurveyLeg | None:
        """The next leg after the current one ended (``reached`` its landmark or not), None when all are done."""
        leg = self.legs[-1]
        if reached:
            self.reached.append(leg.landmark)
        if len(self.legs) == len(self.route):
            return None
        return self._leg(Fix(leg.target, HF_READ_RANGE_M, TIER_TAG, leg.landmark) if reached else None)

    @property
    def complete(self) -> bool:
        """Every leg driven and every landmark reached."""
        return len(self.legs) == len(self.route) and len(self.reached) == len(self.route)

    def _leg(self, known_start: Fix | None) -> SurveyLeg:
        group = self.route[len(self.legs)]
        leg = SurveyLeg(len(self.legs), group.group_id, group.centre, known_start)
        self.legs.append(leg)
        return leg
