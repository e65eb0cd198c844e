"""Tag-route following (paper 001, section IV-C): the supervisory loop around the fuzzy controller.

Once per inventory round: check arrival (the floor tag paired with the target is read, step 8), take
the target's phases at the left and right antennas (steps 3-4), form the phase difference
dphi = phi_left - phi_right (step 5, eq. 2) from two reads on one channel (pair_phases), run the fuzzy
controller for the heading change dtheta (steps 6-7) and command the yaw rate that turns the robot by dtheta
over the round, at constant forward speed.

Beyond the paper, and switchable so the faithful baseline stays available:

* Receding target. A tag straight behind also gives dphi ~ 0, "go straight", which drives away from
  it. The round-trip phase at each antenna changes by 4*pi*dd/lambda when the range changes by dd,
  so consecutive rounds on one channel give the range rate to millimetres per second. When the
  filtered range rate stays positive (the target is receding) the robot turns towards the side the
  phase difference points to (CCW when it is zero) until the range shrinks again.
* Filtering (``filter_rounds``): the circular mean of the last N phase differences.
* Closest-approach arrival (``arrival: closest_approach``): the floor tag is first read up to ~9 cm
  before the robot is over it; switching targets there cuts the corner. The floor antenna's own phase
  of that tag tracks its range with sub-millimetre noise, so the switch waits for its minimum.
* Approach speed (``approach_speed_fraction``): from the first read of the floor tag the robot slows down,
  so it can stop and turn over the tag instead of overshooting by its braking distance, and averages
  proportionally more phase differences (the same lag in distance) for the final centimetres.
* Speed scheduling in turns (``turn_speed_fraction``): slow down while the controller commands large
  heading changes, so corners are turned on a tighter radius.
* Search for an unheard target (``unheard_search``). The paper's robot always hears its next tag; a route leg
  longer than the reader's reach (rfidnav_sim.rfid_model.reach_m: about 9 m for a 3 m ceiling) leaves it deaf at
  the corner, where driving straight on in the old heading rarely brings the tag into reach. Unheard for
  ``search_after_s`` (a missed round is common: straight on till then, as the paper), the robot turns once on the
  spot at ``search_turn_rate_radps``, then drives an expanding square spiral, open loop (the follower has no
  odometry): legs a, a, 2a, 2a, 3a, ... (a = ``search_spacing_m``) with a quarter turn on the spot after each,
  CCW, the first leg along its heading when the search began, until the rings reach ``search_radius_m`` from where
  it began. The target paired in any round ends the search and seeking resumes; the route fails only when the
  whole search has passed unheard, saying what was searched and for how long. Off, the target unheard for
  ``unheard_timeout_s`` fails the route.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle
from rfidnav_common.inputs import BadInput, TagRead, tag_read
from rfidnav_common.rf import range_change_m
from rfidnav_common.robot_map import repeated_in_a_row

ARRIVAL_MODES = ("first_read", "closest_approach")
SEARCH_MODES = ("search_turn", "search_spiral")


# One checked tag read (rfidnav_common.inputs.tag_read: finite numbers in their physical ranges, the phase from I/Q
# as in paper 001 eq. (1), phi = atan2(Q, I), or the reported phase angle when I = Q = 0); the node drops the rest.
TagObservation = TagRead


def observe(read) -> TagObservation | None:
    """A TagObservation from a TagReading message (or anything with its fields), as heading_controller takes it
    (rfidnav_common.inputs.tag_read); None for a read it drops."""
    try:
        return tag_read(read)
    except BadInput:
        return None


@dataclass(frozen=True)
class PhasePairing:
    """What one inventory round gives for the phase difference of one tag (pair_phases)."""

    left: TagObservation | None = None     # the left and right reads paired: same tag, same channel
    right: TagObservation | None = None
    cross_channel: bool = False            # both antennas read the tag, but never on one channel: no pair

    @property
    def difference_rad(self) -> float:
        """phi_left - phi_right, wrapped to (-pi, pi] (no calibration offset taken off)."""
        if self.left is None or self.right is None:
            raise ValueError("no same-channel pair in this round")
        return wrap_angle(self.left.phase_rad - self.right.phase_rad)


def pair_phases(reads: list[TagObservation], tag_id: str, left_antenna: int, right_antenna: int) -> PhasePairing:
    """The left and right reads of ``tag_id`` to subtract: both on one channel (carrier frequency), the newest such
    pair of the round (reads are in the reader's order).

    The round-trip phase is 4*pi*d*f/c plus what the reader's and the tag's circuits add, which also changes
    with the channel. A left read on channel f1 minus a right read on f2 carries 4*pi*d*(f1 - f2)/c whatever the
    tag's side (up to 3.3 rad at 3 m across the 902-928 MHz band) and the two channels' circuit phases. A reader
    that hops between the left and the right antenna's turn in one batch gives such pairs; they say nothing about
    the tag's side and are refused (``cross_channel``), not subtracted."""
    left: dict[float, int] = {}
    right: dict[float, int] = {}
    for index, read in enumerate(reads):
        if read.tag_id != tag_id:
            continue
        if read.antenna == left_antenna:
            left[read.frequency_hz] = index
        elif read.antenna == right_antenna:
            right[read.frequency_hz] = index
    channels = left.keys() & right.keys()
    if not channels:
        return PhasePairing(cross_channel=bool(left) and bool(right))
    # The channel whose pair is the newest: its older read is the latest of all channels' older reads.
    channel = max(channels, key=lambda f: min(left[f], right[f]))
    return PhasePairing(reads[left[channel]], reads[right[channel]])


@dataclass(frozen=True)
class FollowerSettings:
    forward_speed_mps: float = 0.2
    left_antenna: int = 1
    right_antenna: int = 2
    floor_antenna: int = 3
    phase_difference_offset_rad: float = 0.0   # calibration: phi_left - phi_right of a tag straight ahead
    max_yaw_rate_radps: float = 2.0
    nominal_round_s: float = 0.04              # used for the first round and to bound measured round times
    unheard_timeout_s: float = 10.0
    filter_rounds: int = 1                     # 1 = the paper: the latest phase difference only
    receding_detection: bool = True
    receding_rate_mps: float = 0.02            # filtered range rate above which the target recedes
    range_rate_smoothing: float = 0.2          # weight of the newest round in the range-rate average
    arrival: str = "first_read"
    turn_speed_fraction: float = 1.0           # forward speed at the largest heading change, as a fraction
    approach_speed_fraction: float = 1.0       # forward speed once the target's floor tag is heard, as a fraction
    unheard_search: bool = True                # search for an unheard target (False: the paper, straight on)
    search_after_s: float = 1.0                # unheard this long: the search begins
    search_turn_rate_radps: float = 1.0        # yaw rate of the full turn and the spiral's quarter turns
    search_spacing_m: float = 3.0              # distance between the spiral's rings
    search_radius_m: float = 6.0               # the spiral's rings reach this far from where the search began

    def validate(self) -> None:
        if self.arrival not in ARRIVAL_MODES:
            raise ParameterError("arrival", f"'{self.arrival}' is not one of {', '.join(ARRIVAL_MODES)}")
        if self.filter_rounds < 1:
            raise ParameterError("filter_rounds", "must be at least 1")
        if not 0.0 < self.range_rate_smoothing <= 1.0:
            raise ParameterError("range_rate_smoothing", "must be in (0, 1]")
        if not 0.0 <= self.turn_speed_fraction <= 1.0:
            raise ParameterError("turn_speed_fraction", "must be in [0, 1]")
        if not 0.0 < self.approach_speed_fraction <= 1.0:
            raise ParameterError("approach_speed_fraction", "must be in (0, 1]")
        if self.left_antenna == self.right_antenna:
            raise ParameterError("", "left_antenna and right_antenna must differ")
        if self.unheard_search and self.search_radius_m < self.search_spacing_m:
            raise ParameterError("search_radius_m", f"{self.search_radius_m:g} m is less than search_spacing_m "
                                                    f"({self.search_spacing_m:g} m): the spiral has no ring")


@dataclass(frozen=True)
class SearchLeg:
    """One piece of the search for an unheard target: a command held for a while."""
    duration_s: float
    linear_mps: float
    angular_radps: float
    mode: str                      # search_turn (the full turn on the spot) or search_spiral


class UnheardSearch:
    """The search of an unheard target (module docstring): a full turn on the spot, then the expanding square
    spiral, as commands held for fixed times from the search's start."""

    def __init__(self, settings: FollowerSettings) -> None:
        rate, spacing, speed = settings.search_turn_rate_radps, settings.search_spacing_m, settings.forward_speed_mps
        self.settings = settings
        self.legs = [SearchLeg(2.0 * math.pi / rate, 0.0, rate, "search_turn")]
        for k in range(1, 4 * math.ceil(settings.search_radius_m / spacing - 1e-9) + 2):
            if k > 1:
                self.legs.append(SearchLeg(0.5 * math.pi / rate, 0.0, rate, "search_spiral"))
            self.legs.append(SearchLeg(spacing * math.ceil(k / 2) / speed, speed, 0.0, "search_spiral"))
        self.duration_s = sum(leg.duration_s for leg in self.legs)
        self.distance_m = sum(leg.duration_s * leg.linear_mps for leg in self.legs)

    def leg_at(self, elapsed_s: float) -> SearchLeg | None:
        """The leg ``elapsed_s`` into the search; None once it has all passed."""
        for leg in self.legs:
            if elapsed_s < leg.duration_s:
                return leg
            elapsed_s -= leg.duration_s
        return None

    def describe(self) -> str:
        s = self.settings
        return (f"a full turn on the spot at {s.search_turn_rate_radps:g} rad/s, then a square spiral "
                f"{s.search_spacing_m:g} m apart out to {s.search_radius_m:g} m ({self.distance_m:.0f} m driven, "
                f"{self.duration_s:.0f} s)")


@dataclass(frozen=True)
class Command:
    linear_mps: float
    angular_radps: float
    mode: str                      # seeking, receding_turn, unheard, search_turn, search_spiral, finished, failed
    target_index: int
    target_tag_id: str
    phase_difference_rad: float
    heading_change_rad: float
    arrived_index: int | None = None   # index of the route tag reached this round
    failure: str | None = None


class PhaseTrack:
    """Range change of one tag at one antenna between consecutive reads on the same channel.

    Valid while the range changes by less than lambda/4 between reads (8 cm at 915 MHz), far above
    what a robot moves in one inventory round; a channel hop restarts the track."""

    def __init__(self) -> None:
        self.last: tuple[float, float, float] | None = None  # time, phase, frequency

    def update(self, time_s: float, phase_rad: float, frequency_hz: float) -> tuple[float, float] | None:
        """(range change [m], elapsed [s]) since the previous read, or None when there is none to compare."""
        previous, self.last = self.last, (time_s, phase_rad, frequency_hz)
        if previous is None or previous[2] != frequency_hz or time_s <= previous[0]:
            return None
        return range_change_m(wrap_angle(phase_rad - previous[1]), frequency_hz), time_s - previous[0]


class TagRouteFollower:
    """Follows an ordered list of ceiling tags; call :meth:`step` once per inventory round."""

    def __init__(self, settings: FollowerSettings, heading_controller: Callable[[float], float],
                 arrival_tags: dict[str, str], map_source: str = "the route map") -> None:
        """``map_source``: where ``arrival_tags`` come from, as a refusal names it (the node: the map file)."""
        settings.validate()
        self.map_source = map_source
        self.settings = settings
        self.search = UnheardSearch(settings) if settings.unheard_search else None
        self.heading_controller = heading_controller
        self.arrival_tags = dict(arrival_tags)
        self.route: list[str] = []
        self.index = 0
        self.finished = False
        # Rounds in which both antennas read the target only on different channels (pair_phases), over the
        # follower's life: not steered on, counted for the node's warning.
        self.cross_channel_rounds = 0

    def refusal(self, route: list[str]) -> str | None:
        """Why this route cannot be followed (None if it can): empty, a tag without an arrival tag, a tag twice in
        a row."""
        if not route:
            return "the route is empty"
        if unknown := [tag for tag in route if tag not in self.arrival_tags]:
            return f"unknown tag ids {', '.join(unknown)} (not in {self.map_source})"
        return repeated_in_a_row(route)

    def start(self, route: list[str], time_s: float) -> None:
        if problem := self.refusal(route):
            raise ValueError(problem)
        self.route = list(route)
        self.index = 0
        self.finished = False
        self._reset_target(time_s)
        self.last_round_s: float | None = None

    def _reset_target(self, time_s: float) -> None:
        self.last_heard_s = time_s
        self.target_cross_channel_rounds = 0       # since the target was last paired
        self.search_started_s: float | None = None
        self._reset_steering()
        self.last_difference = 0.0
        self.floor_track = PhaseTrack()
        self.floor_range_m = 0.0
        self.floor_minimum_m = 0.0
        self.floor_seen = False

    def _reset_steering(self) -> None:
        """Forget the phase differences and the range rate: at a new target, or after a search, whose turns make
        them stale."""
        self.differences: list[float] = []
        self.tracks = {self.settings.left_antenna: PhaseTrack(), self.settings.right_antenna: PhaseTrack()}
        self.range_rate_mps: float | None = None
        self.receding = False

    @property
    def target(self) -> str:
        return self.route[min(self.index, len(self.route) - 1)]

    def step(self, time_s: float, reads: list[TagObservation]) -> Command:
        s = self.settings
        round_s = s.nominal_round_s if self.last_round_s is None else time_s - self.last_round_s
        round_s = min(max(round_s, 0.25 * s.nominal_round_s), 4.0 * s.nominal_round_s)
        self.last_round_s = time_s

        if self._arrived(time_s, reads):
            arrived = self.index
            self.index += 1
            if self.index == len(self.route):
                self.finished = True
                return Command(0.0, 0.0, "finished", arrived, self.route[arrived], self.last_difference, 0.0,
                               arrived_index=arrived)
            self._reset_target(time_s)
            command = self._steer(time_s, round_s, reads)
            return Command(**{**command.__dict__, "arrived_index": arrived})
        return self._steer(time_s, round_s, reads)

    def _arrived(self, time_s: float, reads: list[TagObservation]) -> bool:
        s = self.settings
        floor_tag = self.arrival_tags[self.target]
        floor_reads = [r for r in reads if r.tag_id == floor_tag]
        if s.arrival == "first_read":
            return bool(floor_reads)
        below = [r for r in floor_reads if r.antenna == s.floor_antenna] or floor_reads
        if not below:
            # Heard before and now silent: the robot has passed over it.
            return self.floor_seen
        change = self.floor_track.update(time_s, below[0].phase_rad, below[0].frequency_hz)
        self.floor_seen = True
        if change is not None:
            self.floor_range_m += change[0]
        self.floor_minimum_m = min(self.floor_minimum_m, self.floor_range_m)
        # A millimetre above the minimum: past the closest point, with margin over the phase noise.
        return self.floor_range_m > self.floor_minimum_m + 1e-3

    def _steer(self, time_s: float, round_s: float, reads: list[TagObservation]) -> Command:
        s = self.settings
        target = self.target
        pairing = pair_phases(reads, target, s.left_antenna, s.right_antenna)
        left, right = pairing.left, pairing.right
        if left is None or right is None:
            self.cross_channel_rounds += pairing.cross_channel
            self.target_cross_channel_rounds += pairing.cross_channel
            return self._unheard(time_s)
        self.last_heard_s = time_s
        self.target_cross_channel_rounds = 0
        self.search_started_s = None
        difference = wrap_angle(pairing.difference_rad - s.phase_difference_offset_rad)
        # Over the floor tag the robot slows down, so the same lag in distance allows a longer average.
        window = s.filter_rounds if not self.floor_seen else round(s.filter_rounds / s.approach_speed_fraction)
        self.differences = (self.differences + [difference])[-window:]
        filtered = math.atan2(sum(math.sin(d) for d in self.differences),
                              sum(math.cos(d) for d in self.differences))
        self.last_difference = filtered
        self._update_range_rate(time_s, left, right)

        if s.receding_detection and self.range_rate_mps is not None:
            if self.range_rate_mps > s.receding_rate_mps:
                self.receding = True
            elif self.range_rate_mps < 0.0:
                self.receding = False
        if self.receding:
            direction = -1.0 if filtered > 0.0 else 1.0   # dphi > 0: tag on the right, turn CW
            turn = direction * s.max_yaw_rate_radps
            return Command(s.forward_speed_mps * s.turn_speed_fraction, turn, "receding_turn", self.index, target,
                           filtered, turn * round_s)
        heading_change = float(self.heading_controller(filtered))
        angular = float(np.clip(heading_change / round_s, -s.max_yaw_rate_radps, s.max_yaw_rate_radps))
        speed = s.forward_speed_mps * (1.0 - (1.0 - s.turn_speed_fraction) * abs(angular) / s.max_yaw_rate_radps)
        if self.floor_seen:
            speed *= s.approach_speed_fraction
        return Command(speed, angular, "seeking", self.index, target, filtered, heading_change)

    def _unheard(self, time_s: float) -> Command:
        """A round without the target paired: straight on (a missed round is common and the heading is still
        good), then the search (or, without it, the paper's timeout); failed once that has passed."""
        s, target = self.settings, self.target
        unheard_s = time_s - self.last_heard_s
        leg = None
        if self.search is not None and unheard_s > s.search_after_s:
            if self.search_started_s is None:
                self.search_started_s = time_s
                self._reset_steering()
            leg = self.search.leg_at(time_s - self.search_started_s)
            if leg is None:
                return self._failed(f"target tag '{target}' unheard for {unheard_s:.1f} s: not heard during the "
                                    f"whole search ({self.search.describe()})")
        elif self.search is None and unheard_s > s.unheard_timeout_s:
            return self._failed(f"target tag '{target}' unheard for {unheard_s:.1f} s")
        if leg is None:
            return Command(s.forward_speed_mps, 0.0, "unheard", self.index, target, self.last_difference, 0.0)
        return Command(leg.linear_mps, leg.angular_radps, leg.mode, self.index, target, self.last_difference, 0.0)

    def _failed(self, failure: str) -> Command:
        on_two = (f" (in {self.target_cross_channel_rounds} rounds heard by both antennas, but never on one "
                  f"channel)" if self.target_cross_channel_rounds else "")
        return Command(0.0, 0.0, "failed", self.index, self.target, self.last_difference, 0.0,
                       failure=failure + on_two)

    def _update_range_rate(self, time_s: float, *reads: TagObservation) -> None:
        changes = (self.tracks[read.antenna].update(time_s, read.phase_rad, read.frequency_hz) for read in reads)
        rates = [change / elapsed for change, elapsed in (c for c in changes if c is not None)]
        if not rates:
            return
        newest = sum(rates) / len(rates)
        weight = self.settings.range_rate_smoothing
        self.range_rate_mps = newest if self.range_rate_mps is None else (
            (1.0 - weight) * self.range_rate_mps + weight * newest)
