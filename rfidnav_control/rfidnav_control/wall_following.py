"""Sonar wall following and junction handling of paper 004 (sections 4-5), as a decision core without ROS.

The robot follows the LEFT wall of a hallway (the RFID tags are on the left walls) and is fed one set of sonar
ranges with the odometry pose per control step; it answers with a velocity command and, at most, one event.
The DDS node turns the answer into /cmd_vel; the in-process experiments apply it to an idealised robot.

Measuring the wall (Fig. 8(b)). The left sonar looks perpendicular to the heading. Driving a straight stretch
of length ``L`` at a constant angle ``a`` to the wall, it reads ``d = p / cos(a)`` for a perpendicular distance
``p`` that grows by ``L sin(a)``, so ``d2 - d1 = L tan(a)`` and ``atan2(d2 - d1, L)`` is exactly ``a``, and
``d2 cos(a)`` is exactly the perpendicular distance at the end. Sign convention: the angle is POSITIVE when the
robot heads AWAY from the left wall (it has turned clockwise from the wall's direction), so the wall runs at
``yaw + angle`` in the odometry frame and rotating counter-clockwise by ``angle`` makes the robot parallel.

Realigning (Fig. 9). The paper realigns every metre: it rotates parallel to the wall, then drives to the set
distance. Here one realignment sets a single new heading, the wall's direction plus an approach angle
proportional to the distance error (``distance_gain`` rad per metre, capped), which the robot holds over the
next stretch with odometry; small heading changes are steered while driving, large ones (turns) on the spot.
The next stretch is then measured at that constant heading, so every measurement satisfies the formula's
straight-travel assumption, and the distance error shrinks by about ``distance_gain * L`` per stretch.

Measuring a stretch (ours). The paper takes d1 and d2 as two single readings. Here every left reading along the
stretch is kept and a straight line is fitted to range against travel; d1 and d2 are the line's ends. Beside a
straight wall at constant heading the ranges ARE on a line, so the fit only averages the sonar noise away
(~20 times less variance than two readings); where they are not — the 25 deg cone still reading the inside of
a side corridor's wall or a corner just past a junction, which put the wall ~20 deg off — the largest residual
exceeds ``max_fit_residual_m`` and the stretch is measured again from there.

Junctions. A side whose wall was seen and then reads beyond ``opening_threshold_m`` for ``opening_confirm_m``
of travel has an opening: the junction is entered (the edge is where the reading first jumped). Its centre
along the hallway is midway between that edge and where the same side's wall resumes; when no wall resumes
within ``junction_half_width_m`` the centre is that far past the edge (half the paper's 1.6 m hallway: a
crossing corridor of the expected width). A wall resuming earlier means the robot has passed the centre
of a narrow opening, and it backs up to it. At the centre a commanded turn is made if the side (or, straight on,
the front) is open; otherwise ``no_opening`` is reported and the robot stops there, never turning into a
wall, until the next command. Without a command it drives straight on, or, where the front is closed (a corner,
the end of a T), follows the walls round: left if open, else right, else back. A U-turn (``back``) needs no
junction.
Openings are looked for only while the hallway's direction is known: from the start and after turning away from
an obstacle, not until a stretch has been measured (the side sonars of a robot at a slant to the walls read
them growing past the threshold, which is no opening). The first measurement is then taken whatever it says.

Stopping at a node (ours). :meth:`command_stop` ends the drive at the next junction's centre or after a given
travel, whichever comes first, with the event ``stopped``: the goal's tag is read before its junction (the paper
stops there), and a node with no side opening has no centre the sonar could find, only a known distance.

Distances are from the robot's reference point (a driver adds each sonar's mounting offset). Corridors are
assumed to meet at right angles, as on the paper's compass-point map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle

FOLLOWING, JUNCTION, CENTRE, TURNING, HALTED = "following", "junction", "centre", "turning", "halted"
LEFT, RIGHT, STRAIGHT, BACK = "left", "right", "straight", "back"
ACTIONS = (LEFT, RIGHT, STRAIGHT, BACK)
TURN_ANGLES = {LEFT: math.pi / 2.0, RIGHT: -math.pi / 2.0, STRAIGHT: 0.0, BACK: math.pi}
OBSTACLE, JUNCTION_ENTERED, JUNCTION_CENTRE = "obstacle", "junction_entered", "junction_centre"
TURN_DONE, NO_OPENING, STOPPED = "turn_done", "no_opening", "stopped"


def wall_angle(d1: float, d2: float, travel_m: float) -> float:
    """Angle [rad] between the heading and the left wall from two lateral ranges ``travel_m`` apart (Fig. 8(b)).

    Positive when the robot heads away from the wall (``d2 > d1``). Exact for a straight stretch at constant
    heading beside a straight wall (see the module docstring)."""
    if not all(math.isfinite(v) for v in (d1, d2, travel_m)):
        raise ValueError(f"wall_angle: d1 {d1}, d2 {d2} and travel_m {travel_m} must be finite")
    if travel_m <= 0.0:
        raise ValueError(f"wall_angle: travel_m must be positive, got {travel_m}")
    return math.atan2(d2 - d1, travel_m)


def wall_distance(d2: float, angle: float) -> float:
    """Perpendicular distance [m] to the wall from a lateral range ``d2`` read at ``angle`` to it."""
    if not (math.isfinite(d2) and math.isfinite(angle)):
        raise ValueError(f"wall_distance: d2 {d2} and angle {angle} must be finite")
    return d2 * math.cos(angle)


@dataclass(frozen=True)
class WallFollowerSettings:
    wall_distance_m: float = 0.8          # set distance to the left wall (paper: 0.8 m; tags read within 1 m)
    speed_mps: float = 0.2                # forward speed (paper 001's speed; the paper gives none)
    realign_every_m: float = 1.0          # L: length of a measuring stretch (paper: every 1 m)
    stop_distance_m: float = 0.4          # emergency stop when the front sonar reads closer than this
    diagonal_stop_distance_m: float = 0.25   # ... or a front-left/right one this close (lower: the followed wall,
                                             # seen obliquely while approaching it, reads 0.4 m at 0.33 m and 10 deg)
    resume_margin_m: float = 0.1          # drive on once the front is clear by this much more (no chatter)
    opening_threshold_m: float = 1.5      # a side range beyond this is no wall; must exceed the far wall's range
    opening_confirm_m: float = 0.1        # an opening must last this far (a lost echo is not a junction)
    junction_half_width_m: float = 0.8    # centre this far past an edge when no wall resumes (1.6 m hallways)
    turn_rate_radps: float = 0.8          # angular speed limit
    heading_gain_per_s: float = 2.0       # yaw rate per radian of heading error (odometry heading hold)
    distance_gain: float = 0.5            # approach angle [rad] per metre of distance error; < 1 / L: no overshoot
    max_approach_rad: float = math.radians(20.0)   # cap on the approach angle to the set distance
    turn_in_place_rad: float = math.radians(30.0)  # turn on the spot while the heading is further off
    settled_rad: float = math.radians(0.5)         # a stretch starts (and a turn ends) within this heading error
    position_tolerance_m: float = 0.01    # at the junction centre within this distance (slowing down to it)
    measure_band_m: float = 0.4           # a stretch is measured only while the left reading stays within this
                                          # of the set distance (beyond: an oblique wall or an opening's edge)
    max_fit_residual_m: float = 0.06      # a stretch whose ranges stray further from their line is no straight
                                          # wall (sonar noise at 0.8 m is ~0.02 m)
    max_wall_change_rad: float = math.radians(25.0)  # reject (and re-measure) a wall direction further off
                                          # the current estimate than this (corridors are straight)
    sonar_half_angle_rad: float = math.radians(12.5)  # side sonar's half cone: an edge is seen this much late
    recover_after_steps: int = 40         # blocked this many steps (2 s at 20 Hz): turn on the spot away

    def validate(self) -> None:
        for name in ("wall_distance_m", "speed_mps", "realign_every_m", "stop_distance_m", "diagonal_stop_distance_m",
                     "opening_threshold_m",
                     "opening_confirm_m", "junction_half_width_m", "turn_rate_radps", "heading_gain_per_s",
                     "distance_gain", "max_approach_rad", "turn_in_place_rad", "settled_rad",
                     "position_tolerance_m", "measure_band_m", "max_fit_residual_m", "max_wall_change_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")
        if not (math.isfinite(self.sonar_half_angle_rad) and 0.0 <= self.sonar_half_angle_rad < math.pi / 4.0):
            raise ParameterError("sonar_half_angle_rad", f"must be in [0, pi/4), got {self.sonar_half_angle_rad}")
        if not (isinstance(self.recover_after_steps, int) and self.recover_after_steps >= 0):
            raise ParameterError("recover_after_steps", f"must be a non-negative int, got {self.recover_after_steps}")
        if not (math.isfinite(self.resume_margin_m) and self.resume_margin_m >= 0.0):
            raise ParameterError("resume_margin_m", f"must be a non-negative number, got {self.resume_margin_m}")
        if self.opening_threshold_m <= self.wall_distance_m:
            raise ParameterError("", f"opening_threshold_m ({self.opening_threshold_m}) must exceed "
                                     f"wall_distance_m ({self.wall_distance_m}): the followed wall would read as an "
                                     "opening")
        if self.opening_confirm_m >= self.junction_half_width_m:
            raise ParameterError("", f"opening_confirm_m ({self.opening_confirm_m}) must be below "
                                     f"junction_half_width_m ({self.junction_half_width_m})")
        if self.max_approach_rad >= self.turn_in_place_rad:
            raise ParameterError("", "max_approach_rad must be below turn_in_place_rad (an approach is steered, not "
                                     "spun)")


@dataclass(frozen=True)
class Sonar:
    """One reading of the rangefinders [m], from the robot's reference point. ``inf`` is no echo; REP 117's
    ``-inf`` (closer than the minimum range) is kept and counts as an obstacle or a wall. NaN is refused."""
    front: float
    left: float
    right: float
    front_left: float = math.inf
    front_right: float = math.inf

    def __post_init__(self) -> None:
        for name in ("front", "left", "right", "front_left", "front_right"):
            if math.isnan(getattr(self, name)):
                raise ValueError(f"Sonar.{name}: NaN is not a range (use inf for no echo)")


@dataclass(frozen=True)
class OdomPose:
    """Odometry pose (odom frame, REP 103) at the time of the sonar reading."""
    x: float
    y: float
    yaw: float

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.yaw)):
            raise ValueError(f"OdomPose: ({self.x}, {self.y}, {self.yaw}) must be finite")


@dataclass(frozen=True)
class Command:
    linear: float                         # m/s, forward positive
    angular: float                        # rad/s, CCW positive
    event: str | None = None              # obstacle | junction_entered | junction_centre | turn_done | no_opening
                                          # | stopped


@dataclass
class Stretch:
    """A measuring stretch: where and at which yaw it started, and the left ranges read along it with the
    travel [m] at which each was read."""
    x: float
    y: float
    yaw: float
    travels: list[float]
    ranges: list[float]

    def add(self, odom: OdomPose, reading: float) -> float:
        """Keep ``reading``; return the travel so far."""
        travel = math.hypot(odom.x - self.x, odom.y - self.y)
        self.travels.append(travel)
        self.ranges.append(reading)
        return travel

    def fitted_ends(self) -> tuple[float, float, float]:
        """(d1, d2, largest residual) of the straight line fitted to range against travel."""
        travels, ranges = np.asarray(self.travels), np.asarray(self.ranges)
        slope, intercept = np.polyfit(travels, ranges, 1)
        residual = float(np.max(np.abs(ranges - (intercept + slope * travels))))
        return float(intercept), float(intercept + slope * travels[-1]), residual


@dataclass(frozen=True)
class Junction:
    """An opening being crossed: its first edge (odometry), the side it is on, the hallway axis, and the centre's
    distance past the edge along that axis (updated once when the wall on that side resumes)."""
    edge_x: float
    edge_y: float
    side: str
    axis_yaw: float
    centre_s: float
    resumed: bool = False

    def along(self, odom: OdomPose) -> float:
        """Distance [m] of the robot past the edge along the hallway (negative before it)."""
        return (odom.x - self.edge_x) * math.cos(self.axis_yaw) + (odom.y - self.edge_y) * math.sin(self.axis_yaw)


class WallFollower:
    """Left-wall follower (state machine). Call :meth:`step` once per sonar reading; :meth:`command_turn` queues
    the action for the next junction centre (``back`` turns at once). States: following, junction (driving to
    its centre), centre (stopped for one step; the next decides), turning, halted (after ``no_opening``, until
    the next command)."""

    def __init__(self, settings: WallFollowerSettings = WallFollowerSettings()) -> None:
        settings.validate()
        self.settings = settings
        self.state = FOLLOWING
        self.pending: str | None = None          # commanded action for the next junction centre
        self.stop_from: tuple[float, float, float] | None = None   # (x, y, at most this far) of command_stop
        self.wall_yaw: float | None = None       # the hallway's direction in the odom frame, as last measured
        self.target_yaw: float | None = None     # heading held by odometry
        self.stretch: Stretch | None = None
        self.wall_seen = {LEFT: False, RIGHT: False}          # a wall was read since the last reset
        self.gap_start: dict[str, tuple[float, float] | None] = {LEFT: None, RIGHT: None}
        self.junction: Junction | None = None
        self.blocked = False                     # emergency stop in force
        self.blocked_steps = 0                   # steps blocked so far (turning away after recover_after_steps)
        self.turn_away = 0.0                     # sign of the on-the-spot turn away from the obstacle
        # The last side reading that was a wall (for the edge compensation).
        self.last_side = {LEFT: settings.wall_distance_m, RIGHT: settings.wall_distance_m}
        self.wall_known = False                  # wall_yaw was measured (not assumed, nor lost by turning away)
        self.rejected = 0                        # measurements rejected (oblique wall, edge, implausible angle)
        self.last_measurement: tuple[float, float] | None = None   # (wall angle, wall distance) of the last stretch

    # ------------------------------------------------------------------------------------ commands
    def command_turn(self, action: str) -> None:
        """Queue ``action`` (left, right, straight, back) for the next junction centre; the latest command wins.

        ``back`` starts a U-turn at the next step. Halted at a centre after ``no_opening``, any action is
        tried there at the next step."""
        if action not in ACTIONS:
            raise ValueError(f"command_turn: '{action}' is not one of {', '.join(ACTIONS)}")
        self.pending = action

    def command_stop(self, within_m: float) -> None:
        """Stop at the next junction's centre or after ``within_m`` more travel (0: at the next step), whichever
        comes first, reporting ``stopped``; a queued turn is dropped. The position is taken at the next step."""
        if not (math.isfinite(within_m) and within_m >= 0.0):
            raise ValueError(f"command_stop: within_m must be a non-negative number, got {within_m}")
        self.pending = None
        self.stop_from = (math.nan, math.nan, within_m)

    # --------------------------------------------------------------------------------------- steps
    def step(self, sonar: Sonar, odom: OdomPose) -> Command:
        """One control step: the velocity to apply until the next reading, and at most one event."""
        if self.target_yaw is None:
            self.target_yaw = self.wall_yaw = odom.yaw
        if self.stop_from is not None:
            return self.stopping(sonar, odom)
        if self.pending == BACK and self.state != TURNING:
            return self.start_turn(BACK, odom)
        if self.state == CENTRE or (self.state == HALTED and self.pending is not None):
            return self.decide(sonar, odom)
        if self.state == HALTED:
            return Command(0.0, 0.0)
        if self.state == TURNING:
            return self.turning(odom)
        command = self.junction_step(sonar, odom) if self.state == JUNCTION else self.following(sonar, odom)
        return self.guard(command, sonar, odom)

    def stopping(self, sonar: Sonar, odom: OdomPose) -> Command:
        x, y, within = self.stop_from
        if math.isnan(x):
            x, y = odom.x, odom.y
            self.stop_from = (x, y, within)
        command = None
        if self.state in (FOLLOWING, JUNCTION) and math.hypot(odom.x - x, odom.y - y) < within:
            command = self.guard(self.junction_step(sonar, odom) if self.state == JUNCTION
                                 else self.following(sonar, odom), sonar, odom)
        if command is None or command.event == JUNCTION_CENTRE:
            self.state, self.stop_from, self.junction = HALTED, None, None
            return Command(0.0, 0.0, STOPPED)
        return command

    def guard(self, command: Command, sonar: Sonar, odom: OdomPose | None = None) -> Command:
        """Emergency stop of a forward command while an obstacle is too close ahead; once stopped, the front must
        clear by ``resume_margin_m`` more before the robot drives on.

        Only forward motion is blocked. The robot first waits ``recover_after_steps`` steps (a person may step
        aside), then, with walls on both sides, turns back (a dead end); otherwise it turns on the spot towards
        the freer side (the larger of the front-left/right readings)
        until the way is clear; it then holds its new heading and re-measures the wall (a stretch that the
        turn interrupted is dropped). Without that turn a robot steered into a wall would never get free."""
        s = self.settings
        margin = s.resume_margin_m if self.blocked else 0.0
        too_close = (sonar.front < s.stop_distance_m + margin
                     or min(sonar.front_left, sonar.front_right) < s.diagonal_stop_distance_m + margin)
        turning_away = self.blocked and self.blocked_steps > s.recover_after_steps
        if (command.linear > 0.0 or turning_away) and too_close:
            event = command.event if self.blocked else OBSTACLE
            if not self.blocked:
                self.blocked, self.blocked_steps = True, 0
                self.turn_away = 1.0 if _free(sonar.front_left) + _free(sonar.left) >= \
                    _free(sonar.front_right) + _free(sonar.right) else -1.0
            self.blocked_steps += 1
            self.stretch = None
            if self.blocked_steps <= s.recover_after_steps:
                return Command(0.0, 0.0, event)
            if (self.blocked_steps == s.recover_after_steps + 1 and odom is not None
                    and max(sonar.left, sonar.right) <= s.opening_threshold_m):
                # Walls left, right and ahead: a dead end (or a blocked hallway); turn back along the hallway
                # rather than towards a side wall it would drive into next.
                return self.start_turn(BACK, odom)
            return Command(0.0, self.turn_away * s.turn_rate_radps, event)
        if (command.linear > 0.0 or turning_away) and self.blocked:
            self.blocked = False
            if turning_away and odom is not None:
                # Turned away: hold the heading reached and measure the wall again from here (a junction being
                # crossed is given up: the opening may have been the robot's slant, not the floor's).
                self.stretch, self.wall_known = None, False
                if self.state == JUNCTION:
                    self.state, self.junction = FOLLOWING, None
                if self.state == FOLLOWING:
                    self.target_yaw = odom.yaw
                    command = Command(command.linear, 0.0, command.event)
            self.blocked_steps = 0
        return command

    def following(self, sonar: Sonar, odom: OdomPose) -> Command:
        entered = self.detect_opening(sonar, odom)
        if entered is not None:
            self.stretch = None
            self.state = JUNCTION
            self.junction = entered
            self.target_yaw = self.wall_yaw
            return self.junction_step(sonar, odom, JUNCTION_ENTERED)
        self.measure(sonar.left, odom)
        return self.hold_heading(odom)

    def detect_opening(self, sonar: Sonar, odom: OdomPose) -> Junction | None:
        """The junction once a side wall that was seen has read as open for ``opening_confirm_m``; else None."""
        s = self.settings
        if not self.wall_known:
            self.gap_start = {LEFT: None, RIGHT: None}
            return None
        for side, reading in ((LEFT, sonar.left), (RIGHT, sonar.right)):
            if reading <= s.opening_threshold_m:
                self.wall_seen[side], self.gap_start[side] = True, None
                if reading > 0.0:
                    self.last_side[side] = reading
            elif self.wall_seen[side] and self.gap_start[side] is None:
                self.gap_start[side] = (odom.x, odom.y)
        for side in (LEFT, RIGHT):
            start = self.gap_start[side]
            if start is not None and math.hypot(odom.x - start[0], odom.y - start[1]) >= s.opening_confirm_m:
                # The cone still sees the corner until it is half a cone behind the beam: the true edge is
                # (distance to the wall) * tan(half angle) before where the reading jumped.
                late = min(self.last_side[side], s.opening_threshold_m) * math.tan(s.sonar_half_angle_rad)
                axis = self.wall_yaw
                return Junction(start[0] - late * math.cos(axis), start[1] - late * math.sin(axis), side, axis,
                                s.junction_half_width_m)
        return None

    def measure(self, left: float, odom: OdomPose) -> None:
        """Fig. 8(b) over a fitted stretch (module docstring): start once the heading has settled, conclude after
        ``realign_every_m``; then realign.

        Only a reading within ``measure_band_m`` of the set distance is taken for the followed wall: right after
        a turn or next to an opening's edge the 25 deg cone sees an oblique wall or a corner further off; the
        stretch is then dropped and measured again. So is one whose ranges are not on a line, and a wall
        direction more than ``max_wall_change_rad`` off the current estimate (straight corridors)."""
        s = self.settings
        if not (0.0 <= left <= s.wall_distance_m + s.measure_band_m):
            self.stretch = None                  # no (plausible) followed wall beside the robot
            return
        if self.stretch is None:
            if abs(wrap_angle(self.target_yaw - odom.yaw)) <= s.settled_rad:
                self.stretch = Stretch(odom.x, odom.y, odom.yaw, [0.0], [left])
            return
        travel = self.stretch.add(odom, left)
        if travel < s.realign_every_m:
            return
        d1, d2, residual = self.stretch.fitted_ends()
        mean_yaw = self.stretch.yaw + wrap_angle(odom.yaw - self.stretch.yaw) / 2.0
        angle = wall_angle(d1, d2, travel)
        self.stretch = None
        implausible = self.wall_known and abs(wrap_angle(mean_yaw + angle - self.wall_yaw)) > s.max_wall_change_rad
        if residual > s.max_fit_residual_m or implausible:
            self.rejected += 1                   # not a straight wall, or an implausible one: measure again
            return
        self.wall_known = True
        self.wall_yaw = wrap_angle(mean_yaw + angle)
        distance = wall_distance(d2, wrap_angle(self.wall_yaw - odom.yaw))
        approach = max(-s.max_approach_rad, min(s.max_approach_rad, s.distance_gain * (distance - s.wall_distance_m)))
        self.target_yaw = wrap_angle(self.wall_yaw + approach)    # CCW (towards the left wall) when too far
        self.last_measurement = (angle, distance)

    def junction_step(self, sonar: Sonar, odom: OdomPose, event: str | None = None) -> Command:
        """Drive along the hallway axis (backwards if past it) to the junction's centre, then stop there.

        ``event`` is the entry step's ``junction_entered``; the centre is at least ``junction_half_width_m -
        opening_confirm_m`` further on, so arrival is checked only from the next step."""
        junction = self.junction
        along = junction.along(odom)
        reading = sonar.left if junction.side == LEFT else sonar.right
        if not junction.resumed and reading <= self.settings.opening_threshold_m and along < junction.centre_s:
            # The cone sees the far corner early: its slant range times sin(half angle) before the edge.
            early = min(reading, self.settings.opening_threshold_m) * math.sin(self.settings.sonar_half_angle_rad)
            junction = self.junction = replace(junction, centre_s=(along + early) / 2.0, resumed=True)
        error = junction.centre_s - along
        if event is None and abs(error) <= self.settings.position_tolerance_m:
            self.state, self.junction = CENTRE, None
            return Command(0.0, 0.0, JUNCTION_CENTRE)
        linear = math.copysign(min(self.settings.speed_mps, abs(error) * self.settings.heading_gain_per_s), error)
        return Command(linear, self.heading_rate(odom), event)

    def decide(self, sonar: Sonar, odom: OdomPose) -> Command:
        """At a junction's centre: make the commanded turn if that way is open, report ``no_opening`` and stay
        (halted) if it is not, or, without a command, drive straight on."""
        action, self.pending = self.pending, None
        if action is None:
            action = self.way_on(sonar)
        if action is None:
            self.resume_following(self.wall_yaw)
            return self.guard(self.following(sonar, odom), sonar, odom)
        reading = {LEFT: sonar.left, RIGHT: sonar.right, STRAIGHT: sonar.front}.get(action, math.inf)
        if reading <= self.settings.opening_threshold_m:
            self.state = HALTED
            return Command(0.0, 0.0, NO_OPENING)
        return self.start_turn(action, odom)

    def way_on(self, sonar: Sonar) -> str | None:
        """Without a command: None (straight on) if the front is open, else the way a left-wall follower goes on
        at a corner or the end of a T: left, right, or back from a dead end."""
        threshold = self.settings.opening_threshold_m
        if sonar.front > threshold:
            return None
        return LEFT if sonar.left > threshold else RIGHT if sonar.right > threshold else BACK

    def start_turn(self, action: str, odom: OdomPose) -> Command:
        """Turn on the spot by the action's angle from the hallway's direction (not from the current heading, so
        the approach angle of the last realignment does not carry into the new hallway)."""
        self.pending = None
        self.state, self.junction, self.stretch, self.blocked = TURNING, None, None, False
        self.wall_yaw = wrap_angle(self.wall_yaw + TURN_ANGLES[action])
        self.target_yaw = self.wall_yaw
        return self.turning(odom)

    def turning(self, odom: OdomPose) -> Command:
        if abs(wrap_angle(self.target_yaw - odom.yaw)) <= self.settings.settled_rad:
            self.resume_following(self.target_yaw)
            return Command(0.0, 0.0, TURN_DONE)
        return Command(0.0, self.heading_rate(odom))

    def resume_following(self, yaw: float) -> None:
        """Follow again along ``yaw``; walls count only once seen again (the junction's openings are no new one)."""
        self.state, self.target_yaw, self.stretch = FOLLOWING, yaw, None
        self.wall_seen = {LEFT: False, RIGHT: False}
        self.gap_start = {LEFT: None, RIGHT: None}

    # ------------------------------------------------------------------------------------- heading
    def heading_rate(self, odom: OdomPose) -> float:
        s = self.settings
        error = wrap_angle(self.target_yaw - odom.yaw)
        return max(-s.turn_rate_radps, min(s.turn_rate_radps, s.heading_gain_per_s * error))

    def hold_heading(self, odom: OdomPose) -> Command:
        """Forward at speed on the held heading; on the spot while it is more than ``turn_in_place_rad`` off."""
        error = wrap_angle(self.target_yaw - odom.yaw)
        linear = 0.0 if abs(error) > self.settings.turn_in_place_rad else self.settings.speed_mps
        return Command(linear, self.heading_rate(odom))


def _free(reading: float) -> float:
    """A range for comparing how free a side is (no echo: far; closer than the minimum range: zero)."""
    return 10.0 if reading == math.inf else max(0.0, reading)
