"""Sonar wall following of paper 004 (sections 4-5): the Fig. 8(b) geometry by hand, and the follower driving an
ideal unicycle in hallways drawn as wall segments, its sonars ray-cast against them (odometry is exact)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pytest

from rfidnav_control.wall_following import (
    Command,
    OdomPose,
    Sonar,
    Stretch,
    WallFollower,
    WallFollowerSettings,
    wall_angle,
    wall_distance,
)

pytestmark = pytest.mark.tier("unit")

DT = 0.05
MAX_RANGE = 5.0
WIDTH = 1.6                      # the paper's hallway: walls y = 0 (right) and y = 1.6 (left), heading +x
Segment = tuple[float, float, float, float]
IDEAL_RAYS = WallFollowerSettings(sonar_half_angle_rad=0.0)


def ray(x: float, y: float, direction: float, walls: list[Segment]) -> float:
    """Range along ``direction`` to the nearest wall segment; inf beyond ``MAX_RANGE``."""
    dx, dy = math.cos(direction), math.sin(direction)
    best = math.inf
    for x1, y1, x2, y2 in walls:
        ex, ey = x2 - x1, y2 - y1
        denominator = dx * ey - dy * ex
        if abs(denominator) < 1e-12:
            continue
        t = ((x1 - x) * ey - (y1 - y) * ex) / denominator       # along the ray
        u = ((x1 - x) * dy - (y1 - y) * dx) / denominator       # along the segment
        if t > 0.0 and 0.0 <= u <= 1.0:
            best = min(best, t)
    return best if best <= MAX_RANGE else math.inf


def hallway(left_gaps: tuple[tuple[float, float], ...] = (), length: float = 30.0) -> list[Segment]:
    """A straight hallway along +x; each left gap (x0, x1) opens a side corridor to +y, 5 m long."""
    walls: list[Segment] = [(-10.0, 0.0, length, 0.0)]
    x = -10.0
    for x0, x1 in left_gaps:
        walls += [(x, WIDTH, x0, WIDTH), (x0, WIDTH, x0, WIDTH + 5.0), (x1, WIDTH, x1, WIDTH + 5.0)]
        x = x1
    return walls + [(x, WIDTH, length, WIDTH)]


@dataclass
class Run:
    walls: list[Segment]
    x: float
    y: float
    yaw: float
    # The harness's sonars are single rays (no cone): the follower is told so (no edge compensation).
    follower: WallFollower = field(default_factory=lambda: WallFollower(IDEAL_RAYS))
    cone_rad: float = 0.0                 # > 0: each sonar is a cone of this half angle (nearest of 11 rays)
    events: list[tuple[str, float, float, float]] = field(default_factory=list)   # (event, x, y, yaw)
    last: Command | None = None

    def beam(self, bearing: float) -> float:
        if self.cone_rad <= 0.0:
            return ray(self.x, self.y, self.yaw + bearing, self.walls)
        return min(ray(self.x, self.y, self.yaw + bearing + self.cone_rad * k / 5.0, self.walls)
                   for k in range(-5, 6))

    def sonar(self) -> Sonar:
        return Sonar(front=self.beam(0.0), left=self.beam(math.pi / 2), right=self.beam(-math.pi / 2),
                     front_left=self.beam(math.pi / 4), front_right=self.beam(-math.pi / 4))

    def step(self) -> Command:
        command = self.last = self.follower.step(self.sonar(), OdomPose(self.x, self.y, self.yaw))
        if command.event is not None:
            self.events.append((command.event, self.x, self.y, self.yaw))
        self.yaw += command.angular * DT
        self.x += command.linear * math.cos(self.yaw) * DT
        self.y += command.linear * math.sin(self.yaw) * DT
        return command

    def until(self, done, max_steps: int = 4000) -> None:
        for _ in range(max_steps):
            self.step()
            if done(self):
                return
        raise AssertionError(f"not done after {max_steps} steps; events {self.names()}")

    def names(self) -> list[str]:
        return [event[0] for event in self.events]


def test_wall_angle_and_distance_by_hand() -> None:
    assert wall_angle(0.8, 0.9, 1.0) == pytest.approx(math.atan(0.1))     # heading away from the wall: positive
    assert wall_angle(0.9, 0.8, 1.0) == pytest.approx(-math.atan(0.1))
    assert wall_angle(0.8, 0.8, 2.0) == 0.0
    assert wall_distance(0.9, math.atan(0.1)) == pytest.approx(0.9 / math.sqrt(1.01))
    # Exact for a perpendicular sonar: 10 degrees off, 0.5 m then 0.5 + sin(10 deg) m from the wall.
    a = math.radians(10.0)
    d1, d2 = 0.5 / math.cos(a), (0.5 + math.sin(a)) / math.cos(a)
    assert wall_angle(d1, d2, 1.0) == pytest.approx(a)
    assert wall_distance(d2, a) == pytest.approx(0.5 + math.sin(a))


@pytest.mark.parametrize("args", [(0.8, 0.9, 0.0), (0.8, 0.9, -1.0), (math.inf, 0.9, 1.0), (0.8, math.nan, 1.0)])
def test_wall_angle_rejects_bad_input(args: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError, match="wall_angle"):
        wall_angle(*args)


def test_wall_distance_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="wall_distance"):
        wall_distance(math.inf, 0.1)


@pytest.mark.parametrize("bad", [dict(speed_mps=0.0), dict(opening_threshold_m=0.5), dict(stop_distance_m=math.nan),
                                 dict(resume_margin_m=-0.1), dict(opening_confirm_m=1.0)])
def test_settings_validate(bad: dict) -> None:
    with pytest.raises(ValueError):
        WallFollowerSettings(**bad).validate()
    with pytest.raises(ValueError):
        WallFollower(WallFollowerSettings(**bad))


def test_inputs_and_commands_are_checked() -> None:
    with pytest.raises(ValueError, match="NaN"):
        Sonar(front=math.nan, left=1.0, right=1.0)
    with pytest.raises(ValueError, match="OdomPose"):
        OdomPose(0.0, math.inf, 0.0)
    with pytest.raises(ValueError, match="sideways"):
        WallFollower().command_turn("sideways")


@pytest.mark.parametrize("off_deg", [10.0, -10.0])
def test_converges_to_the_set_distance_and_parallel(off_deg: float) -> None:
    run = Run(hallway(), x=0.0, y=WIDTH - 0.5, yaw=math.radians(off_deg))
    run.until(lambda r: math.hypot(r.x, r.y - (WIDTH - 0.5)) >= 6.0)
    assert WIDTH - run.y == pytest.approx(0.8, abs=0.05)
    assert abs(math.degrees(run.yaw)) < 2.0
    assert run.events == []
    angle, distance = run.follower.last_measurement
    assert abs(math.degrees(angle)) < 2.0 and distance == pytest.approx(0.8, abs=0.05)


def test_front_obstacle_stops_and_resumes_when_cleared() -> None:
    walls = hallway()
    run = Run(walls + [(3.0, 0.0, 3.0, WIDTH)], x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: r.names() == ["obstacle"])
    assert run.last.linear == 0.0 and run.last.angular == 0.0
    assert 3.0 - run.x == pytest.approx(0.4, abs=0.02)
    for _ in range(20):                     # stays stopped, reporting once
        assert run.step().linear == 0.0
    assert run.names() == ["obstacle"]
    run.walls = walls                       # the obstacle goes away
    assert run.step().linear > 0.0


def test_left_opening_is_entered_and_its_centre_found() -> None:
    run = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: "junction_centre" in r.names())
    (entered, x_in, _, _), (centre, x_c, _, _) = run.events
    assert (entered, centre) == ("junction_entered", "junction_centre")
    assert x_in == pytest.approx(5.0 + 0.1, abs=0.03)         # edge at 5.0, confirmed 0.1 m later
    assert x_c == pytest.approx(5.8, abs=0.05)
    run.until(lambda r: r.x > 12.0)                           # no command: straight on, following the wall again
    assert run.names() == ["junction_entered", "junction_centre"]
    assert WIDTH - run.y == pytest.approx(0.8, abs=0.05)


def test_centre_of_a_narrow_opening_is_midway_and_the_robot_backs_up_to_it() -> None:
    run = Run(hallway(left_gaps=((5.0, 5.5),)), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: "junction_centre" in r.names())
    assert run.events[-1][1] == pytest.approx(5.25, abs=0.03)


def test_commanded_left_turn_at_an_opening() -> None:
    run = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0)
    run.follower.command_turn("left")
    run.until(lambda r: "turn_done" in r.names())
    assert run.names() == ["junction_entered", "junction_centre", "turn_done"]
    assert math.degrees(run.yaw) == pytest.approx(90.0, abs=1.0)
    assert run.x == pytest.approx(5.8, abs=0.05)
    run.until(lambda r: r.y > WIDTH + 3.0)                    # up the side corridor, its left wall at x = 5
    assert run.x - 5.0 == pytest.approx(0.8, abs=0.05)


def test_commanded_right_turn_into_a_wall_is_reported_not_made() -> None:
    run = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0)
    run.follower.command_turn("right")
    run.until(lambda r: "no_opening" in r.names())
    assert run.names() == ["junction_entered", "junction_centre", "no_opening"]
    assert abs(math.degrees(run.yaw)) < 1.0 and run.x == pytest.approx(5.8, abs=0.05)   # stopped, no turn
    x, yaw = run.x, run.yaw
    for _ in range(40):
        command = run.step()
        assert (command.linear, command.angular) == (0.0, 0.0)
    assert (run.x, run.yaw) == (x, yaw)
    run.follower.command_turn("left")                         # a new command is tried where it stopped
    run.until(lambda r: "turn_done" in r.names())
    assert math.degrees(run.yaw) == pytest.approx(90.0, abs=1.0)


def test_back_turns_at_once_and_follows_the_other_wall() -> None:
    run = Run(hallway(), x=0.0, y=0.5, yaw=0.0)
    run.until(lambda r: r.x > 2.0)
    run.follower.command_turn("back")
    run.until(lambda r: "turn_done" in r.names())
    assert abs(math.degrees(run.yaw)) == pytest.approx(180.0, abs=1.0)
    x0 = run.x
    run.until(lambda r: x0 - r.x > 6.0)
    assert run.y == pytest.approx(0.8, abs=0.05)              # the old right wall (y = 0) is the new left wall


CONE = math.radians(12.5)        # the paper's sonars: 25 deg cones (the follower's default half angle)


def test_an_opening_edge_does_not_corrupt_the_wall_angle() -> None:
    # With cones, the left sonar sees the opening's far corner and the side corridor's walls obliquely (~1.4 m):
    # such readings are not taken for the followed wall, so every accepted measurement keeps the wall's direction.
    run = Run(hallway(left_gaps=((5.0, 6.6), (10.0, 11.6))), x=0.0, y=0.8, yaw=0.0, follower=WallFollower(),
              cone_rad=CONE)
    wall_directions = []
    while run.x < 16.0:
        before = run.follower.last_measurement
        run.step()
        if run.follower.last_measurement is not before:
            wall_directions.append(run.follower.wall_yaw)    # the hallway runs along +x: 0
        assert abs(math.degrees(run.yaw)) < 25.0      # the 20 deg approach cap and the hold: never into a wall
        assert len(run.events) < 20
    assert len(wall_directions) >= 5 and max(abs(math.degrees(a)) for a in wall_directions) < 3.0
    assert WIDTH - run.y == pytest.approx(0.8, abs=0.05)
    assert "obstacle" not in run.names()


def test_a_robot_steered_into_the_wall_turns_away_and_recovers() -> None:
    # A corrupted wall direction (as from a bad measurement) heads the robot 35 deg into the left wall.
    run = Run(hallway(), x=0.0, y=0.8, yaw=0.0, follower=WallFollower(IDEAL_RAYS))
    run.follower.step(run.sonar(), OdomPose(run.x, run.y, run.yaw))
    run.follower.wall_yaw = run.follower.target_yaw = math.radians(35.0)
    run.until(lambda r: "obstacle" in r.names())
    assert run.last.linear == 0.0
    run.until(lambda r: r.x > 24.0)                 # it turned away on the spot, re-measured and followed again
    assert run.names().count("obstacle") <= 2
    assert WIDTH - run.y == pytest.approx(0.8, abs=0.05)
    assert abs(math.degrees(run.yaw)) < 2.0


def test_blocked_in_front_only_forward_motion_is_stopped() -> None:
    walls = hallway() + [(3.0, 0.0, 3.0, WIDTH)]       # a dead end: waits, then turns on the spot, never drives in
    run = Run(walls, x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: r.names() == ["obstacle"])
    turned = False
    for _ in range(200):
        command = run.step()
        turned = turned or command.angular != 0.0
        assert run.x < 3.0 - 0.2                  # the robot never drives into the end wall
    assert turned


def test_junction_centre_with_a_25_degree_cone() -> None:
    run = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0, follower=WallFollower(), cone_rad=CONE)
    run.until(lambda r: "junction_centre" in r.names())
    assert run.events[-1][1] == pytest.approx(5.8, abs=0.05)
    # Without the compensation the cone's late edge puts the centre ~0.18 m too far.
    late = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0, follower=WallFollower(IDEAL_RAYS),
               cone_rad=CONE)
    late.until(lambda r: "junction_centre" in r.names())
    assert late.events[-1][1] > 5.9


def test_a_stretch_is_a_line_fitted_to_its_ranges() -> None:
    on_a_line = Stretch(0.0, 0.0, 0.0, [0.0, 0.25, 0.5, 0.75, 1.0], [0.8, 0.825, 0.85, 0.875, 0.9])
    d1, d2, residual = on_a_line.fitted_ends()
    assert (d1, d2) == (pytest.approx(0.8), pytest.approx(0.9)) and residual == pytest.approx(0.0, abs=1e-9)
    # The cone reading a side corridor's wall first (ranges falling to the followed wall, then flat): no line.
    past_a_corner = Stretch(0.0, 0.0, 0.0, [0.0, 0.05, 0.1, 0.5, 1.0], [1.2, 1.0, 0.82, 0.8, 0.8])
    assert past_a_corner.fitted_ends()[2] > WallFollowerSettings().max_fit_residual_m


def test_no_opening_is_looked_for_before_the_wall_is_measured() -> None:
    # Starting beside an opening, the robot does not yet know the hallway's direction: that opening is no
    # junction; the next one, after the first measured stretch, is.
    run = Run(hallway(left_gaps=((0.3, 1.9), (8.0, 9.6))), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: "junction_centre" in r.names())
    assert run.follower.wall_known
    assert run.names() == ["junction_entered", "junction_centre"] and run.x == pytest.approx(8.8, abs=0.05)


def test_stop_at_the_next_junction_centre() -> None:
    run = Run(hallway(left_gaps=((5.0, 6.6),)), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: r.x > 2.0)
    run.follower.command_stop(10.0)
    run.until(lambda r: "stopped" in r.names())
    assert run.names() == ["junction_entered", "stopped"] and run.x == pytest.approx(5.8, abs=0.05)
    assert run.step() == Command(0.0, 0.0)                    # halted until the next command


@pytest.mark.parametrize("within_m", [0.0, 1.5])
def test_stop_after_a_distance_where_there_is_no_junction(within_m: float) -> None:
    run = Run(hallway(), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: r.x > 2.0)
    x0 = run.x
    run.follower.command_stop(within_m)
    run.until(lambda r: "stopped" in r.names())
    assert run.x - x0 == pytest.approx(within_m, abs=0.02)
    with pytest.raises(ValueError):
        run.follower.command_stop(math.nan)


def corner(end_x: float = 10.0) -> list[Segment]:
    """The hallway of ``hallway()`` ending at ``end_x`` and turning left: a side corridor up +y at its end."""
    return [(-10.0, 0.0, end_x, 0.0), (end_x, 0.0, end_x, 8.0), (-10.0, WIDTH, end_x - WIDTH, WIDTH),
            (end_x - WIDTH, WIDTH, end_x - WIDTH, 8.0)]


def test_without_a_command_a_corner_is_followed_round() -> None:
    run = Run(corner(), x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: r.y > 6.0)
    assert run.names() == ["junction_entered", "junction_centre", "turn_done"]
    assert math.degrees(run.yaw) == pytest.approx(90.0, abs=2.0) and run.x == pytest.approx(9.2, abs=0.05)


def test_a_dead_end_is_turned_back_from() -> None:
    walls = hallway(length=10.0) + [(10.0, 0.0, 10.0, WIDTH)]
    run = Run(walls, x=0.0, y=0.8, yaw=0.0)
    run.until(lambda r: "turn_done" in r.names())
    assert run.names() == ["obstacle", "turn_done"] and abs(math.degrees(run.yaw)) == pytest.approx(180.0, abs=1.0)
    run.until(lambda r: r.x < 4.0)
    assert run.y == pytest.approx(0.8, abs=0.05) and run.names() == ["obstacle", "turn_done"]
