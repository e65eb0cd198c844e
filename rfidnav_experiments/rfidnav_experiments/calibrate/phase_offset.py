"""``./rfidnav calibrate phase-offset``: heading_controller's ``phase_difference_offset_rad``, measured on the robot.

The controller steers on dphi = phi_left - phi_right (paper 001 eq. 2) and takes a constant off it: what the two
antenna ports, their cables and the reader add to one side and not to the other. With the robot standing still
and a tag straight above the midpoint of the left and right antennas (or squarely in front of the robot, on its
centre line), both antennas are equally far from the tag, the geometry adds nothing, and the left minus right
difference is that constant plus noise.

The command listens to /rfid/reads over DDS for a while (the llrp_reader driver on the robot, or the reader
simulator), pairs each round's left and right reads of the tag on one channel with the controller's own pairing
(rfidnav_control.tag_route.pair_phases; a cross-channel pair is meaningless and is counted, not used), and takes
the circular mean of the differences per channel, then over the channels. A cable's delay makes the offset change
with the frequency (2*pi*f*dt); the controller takes one offset off every channel, so the per-channel means and
their spread are printed with it. Too few same-channel pairs is an error, not a number.
"""

from __future__ import annotations

import math
import re
import time
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from rfidnav_common.config import node_parameter_values
from rfidnav_common.errors import RfidnavError
from rfidnav_common.geometry import wrap_angle
from rfidnav_common.progress import stage
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import TagObservation, pair_phases

MIN_PAIRS = 50            # same-channel pairs of the tag, in all, below which no offset is given
MIN_CHANNEL_PAIRS = 3     # a channel with fewer is listed but left out of the mean: its mean is mostly noise
OFFSET_KEY = "phase_difference_offset_rad"
NODE_NAME = "heading_controller"


class CalibrationError(RfidnavError):
    """No offset can be given: no reader on the topic, or too few same-channel pairs of the tag."""


@dataclass(frozen=True)
class ChannelOffset:
    frequency_hz: float
    pairs: int
    offset_rad: float        # circular mean of this channel's left - right differences
    spread_rad: float        # their circular standard deviation


@dataclass(frozen=True)
class PhaseOffsetEstimate:
    tag_id: str
    left_antenna: int
    right_antenna: int
    rounds: int                          # inventory rounds heard
    pairs: int                           # same-channel pairs of the tag in the channels used
    cross_channel_rounds: int            # rounds with left and right reads of the tag on different channels only
    offset_rad: float                    # circular mean of the channel means: phase_difference_offset_rad
    spread_rad: float                    # circular standard deviation of one difference about its channel's mean
    standard_error_rad: float            # of offset_rad, from the noise of the differences
    channel_spread_rad: float            # largest distance of a channel's mean from offset_rad
    channels: tuple[ChannelOffset, ...]  # used, by frequency
    sparse_channels: tuple[ChannelOffset, ...]   # fewer than MIN_CHANNEL_PAIRS pairs: left out


def circular_mean(angles: Sequence[float]) -> float:
    return math.atan2(sum(math.sin(a) for a in angles), sum(math.cos(a) for a in angles))


def circular_spread(angles: Sequence[float]) -> float:
    """Circular standard deviation sqrt(-2 ln R) [rad], R the mean resultant length (the standard deviation for
    a narrow spread)."""
    resultant = math.hypot(sum(math.sin(a) for a in angles), sum(math.cos(a) for a in angles)) / len(angles)
    return math.sqrt(-2.0 * math.log(resultant)) if resultant > 0.0 else math.inf


def tag_pairs(rounds: Sequence[Sequence[TagObservation]], tag_id: str, left_antenna: int,
              right_antenna: int) -> tuple[dict[float, list[float]], int]:
    """Each round's same-channel left - right difference of ``tag_id`` by channel frequency, and the rounds that
    had only cross-channel pairs of it."""
    differences: dict[float, list[float]] = defaultdict(list)
    cross_channel = 0
    for reads in rounds:
        pairing = pair_phases(list(reads), tag_id, left_antenna, right_antenna)
        if pairing.left is not None:
            differences[pairing.left.frequency_hz].append(pairing.difference_rad)
        cross_channel += pairing.cross_channel
    return dict(differences), cross_channel


def estimate_offset(rounds: Sequence[Sequence[TagObservation]], left_antenna: int, right_antenna: int,
                    tag_id: str | None = None, min_pairs: int = MIN_PAIRS,
                    min_channel_pairs: int = MIN_CHANNEL_PAIRS) -> PhaseOffsetEstimate:
    """The offset from ``rounds`` (each the valid reads of one TagReadArray). ``tag_id`` None: the tag with the
    most same-channel pairs. CalibrationError when fewer than ``min_pairs`` pairs fall in channels with at least
    ``min_channel_pairs`` each."""
    heard = sorted({read.tag_id for reads in rounds for read in reads})
    antennas = f"antennas {left_antenna} (left) and {right_antenna} (right)"
    if tag_id is None:
        counts = {tag: sum(map(len, tag_pairs(rounds, tag, left_antenna, right_antenna)[0].values()))
                  for tag in heard}
        if not counts or max(counts.values()) == 0:
            raise CalibrationError(f"no tag was read by both {antennas} on one channel in {len(rounds)} rounds "
                                   f"(tags heard: {', '.join(heard) or 'none'})")
        tag_id = max(counts, key=lambda tag: counts[tag])
    differences, cross_channel = tag_pairs(rounds, tag_id, left_antenna, right_antenna)
    per_channel = [ChannelOffset(frequency, len(values), circular_mean(values), circular_spread(values))
                   for frequency, values in sorted(differences.items())]
    used = tuple(c for c in per_channel if c.pairs >= min_channel_pairs)
    sparse = tuple(c for c in per_channel if c.pairs < min_channel_pairs)
    pairs = sum(c.pairs for c in used)
    if pairs < min_pairs:
        raise CalibrationError(
            f"tag {tag_id}: {pairs} same-channel pairs of {antennas} in channels with at least {min_channel_pairs} "
            f"each ({sum(c.pairs for c in sparse)} more in {len(sparse)} sparser channels, {cross_channel} rounds "
            f"with its left and right reads on different channels only, {len(rounds)} rounds heard); at least "
            f"{min_pairs} are needed: listen longer (--duration), or check that both antennas see the tag"
            + ("" if tag_id in heard else f" (not heard at all; tags heard: {', '.join(heard) or 'none'})"))
    offset = circular_mean([c.offset_rad for c in used])
    residuals = [wrap_angle(d - c.offset_rad) for c in used for d in differences[c.frequency_hz]]
    spread = circular_spread(residuals)
    channel_deviation = [abs(wrap_angle(c.offset_rad - offset)) for c in used]
    # The noise of a mean of channel means (each of n_k differences spreading ``spread``): the channels are all the
    # reader hops over, so their offsets differing adds no sampling error.
    standard_error = spread * math.sqrt(sum(1.0 / c.pairs for c in used)) / len(used)
    return PhaseOffsetEstimate(
        tag_id=tag_id, left_antenna=left_antenna, right_antenna=right_antenna, rounds=len(rounds), pairs=pairs,
        cross_channel_rounds=cross_channel, offset_rad=offset, spread_rad=spread,
        standard_error_rad=standard_error, channel_spread_rad=max(channel_deviation),
        channels=used, sparse_channels=sparse)


def antenna_ports(controller_file: Path) -> tuple[int, int]:
    """heading_controller's left and right antenna ports as ``controller_file`` sets them (else the defaults)."""
    values = node_parameter_values(HeadingControllerParameters, controller_file, NODE_NAME)
    defaults = HeadingControllerParameters()
    return values.get("left_antenna", defaults.left_antenna), values.get("right_antenna", defaults.right_antenna)


def with_offset(text: str, offset_rad: float) -> str:
    """A heading_controller parameter file's ``text`` with ``phase_difference_offset_rad`` set (its line's
    comment and the rest of the file kept), or added as the first parameter when it is not there."""
    value = f"{offset_rad:.4f}"
    line = re.compile(rf"^(?P<head>[ \t]+{OFFSET_KEY}:[ \t]*)(?P<value>[^#\n]*?)(?P<tail>[ \t]*(#.*)?)$",
                      re.MULTILINE)
    match = line.search(text)
    if match is not None:
        comment = match["tail"].lstrip(" \t")
        if not comment:
            return text[:match.start()] + match["head"] + value + text[match.end():]
        # Keep the comment in its column (one space after the value at least).
        column = len(match["value"]) + len(match["tail"]) - len(comment)
        return text[:match.start()] + match["head"] + value.ljust(column - 1) + " " + comment + text[match.end():]
    section = re.search(r"^(?P<indent>[ \t]*)ros__parameters:[ \t]*(#.*)?\n(?P<next>[ \t]*)", text, re.MULTILINE)
    if section is None:
        raise CalibrationError(f"no '{NODE_NAME}: ros__parameters:' section to set {OFFSET_KEY} in")
    indent = section["next"] if len(section["next"]) > len(section["indent"]) else section["indent"] + "  "
    insert = section.end() - len(section["next"])
    return text[:insert] + f"{indent}{OFFSET_KEY}: {value}\n" + text[insert:]


def write_offset(controller_file: Path, out: Path, offset_rad: float) -> float:
    """Write ``controller_file`` with the offset set to ``out`` (they may be the same file); returns the offset the
    file had. The file written is read back as the controller would read it."""
    before = node_parameter_values(HeadingControllerParameters, controller_file, NODE_NAME).get(
        OFFSET_KEY, HeadingControllerParameters().phase_difference_offset_rad)   # read, and checked (UTF-8 among it)
    out.write_text(with_offset(controller_file.read_text(), offset_rad))
    written = node_parameter_values(HeadingControllerParameters, out, NODE_NAME).get(OFFSET_KEY)
    if written is None or abs(written - offset_rad) > 1e-4:
        raise CalibrationError(f"{out}: {OFFSET_KEY} reads back as {written}, not {offset_rad:.4f}")
    return float(before)


def listen(duration_s: float, wait_s: float, domain_id: int | None = None) -> list[list[TagObservation]]:
    """The valid reads (tag_route.observe, as the controller validates them) of every /rfid/reads message in
    ``duration_s`` of wall time, once a publisher is there (CalibrationError if none within ``wait_s``). The
    domain is ROS_DOMAIN_ID's unless ``domain_id`` is given."""
    from rfidnav_common.ros import SENSOR_QOS, standalone_node
    from rfidnav_control.tag_route import observe
    from rfidnav_msgs.msg import TagReadArray  # type: ignore[attr-defined]  # generated

    rounds: list[list[TagObservation]] = []

    def on_reads(msg: Any) -> None:
        rounds.append([o for o in map(observe, msg.readings) if o is not None])

    with standalone_node("rfidnav_calibrate", domain_id) as (node, executor):
        node.create_subscription(TagReadArray, "/rfid/reads", on_reads, SENSOR_QOS)
        deadline = time.monotonic() + wait_s
        while not rounds:
            if time.monotonic() > deadline:
                publishers = node.count_publishers("/rfid/reads")
                raise CalibrationError(
                    f"/rfid/reads: no message within {wait_s:g} s ({publishers} publishers; is the reader driver "
                    f"or the simulator running, on this ROS_DOMAIN_ID?)")
            executor.spin_once(timeout_sec=0.05)
        rounds.clear()              # the clock starts with the first message
        end = time.monotonic() + duration_s
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))
        return rounds


def report(estimate: PhaseOffsetEstimate) -> str:
    lines = [f"tag {estimate.tag_id}, antennas {estimate.left_antenna} (left) - {estimate.right_antenna} (right): "
             f"{estimate.pairs} same-channel pairs in {estimate.rounds} rounds on {len(estimate.channels)} channels "
             f"({estimate.cross_channel_rounds} rounds with left and right on different channels only: not used)",
             f"  {'channel [MHz]':>13}  {'pairs':>5}  {'offset [rad]':>12}  {'spread [rad]':>12}"]
    for channel in estimate.channels:
        lines.append(f"  {channel.frequency_hz / 1e6:13.3f}  {channel.pairs:5d}  {channel.offset_rad:12.4f}  "
                     f"{channel.spread_rad:12.4f}")
    if estimate.sparse_channels:
        lines.append(f"  left out: {len(estimate.sparse_channels)} channels with fewer than {MIN_CHANNEL_PAIRS} "
                     f"pairs ({sum(c.pairs for c in estimate.sparse_channels)} pairs)")
    lines.append(f"{OFFSET_KEY}: {estimate.offset_rad:.4f}   (standard error {estimate.standard_error_rad:.4f} rad; "
                 f"one difference spreads {estimate.spread_rad:.3f} rad; the channels' offsets lie within "
                 f"{estimate.channel_spread_rad:.3f} rad of it)")
    return "\n".join(lines)


def calibrate_phase_offset(controller_file: Path, out: Path | None, tag_id: str | None, duration_s: float,
                           wait_s: float, min_pairs: int, as_json: bool, domain_id: int | None = None) -> int:
    """The verb: listen, estimate, print (and write ``out``). Errors are CalibrationError (exit 2 in the CLI)."""
    import json

    left, right = antenna_ports(controller_file)
    with stage(f"calibrate phase-offset: listening to /rfid/reads for {duration_s:g} s"):
        rounds = listen(duration_s, wait_s, domain_id)
    estimate = estimate_offset(rounds, left, right, tag_id, min_pairs=min_pairs)
    before = write_offset(controller_file, out, estimate.offset_rad) if out is not None else None
    if as_json:
        print(json.dumps({**asdict(estimate), "duration_s": duration_s, "out": str(out) if out else None,
                          "previous_offset_rad": before}))
        return 0
    print(report(estimate))
    if out is not None:
        print(f"written to {out} ({NODE_NAME}.ros__parameters.{OFFSET_KEY}, was {before:g})")
    else:
        print(f"put it in the controller's parameter file ({controller_file}: {NODE_NAME}.ros__parameters."
              f"{OFFSET_KEY}), or run again with --out FILE")
    return 0
