"""Where the robot is when one poll of its floor reader reads tags: paper 003's tier-two fix, ours.

The HF reader reads every tag within its range r of the antenna, and a poll that reads anything has read all of
them (a poll fails whole: rfidnav_common.polling). So at that poll the antenna lay within r of every tag read and
farther than r from every other tag the map knows: the fix is the centroid of that region (the least-squares
point when the robot is equally likely anywhere in it) and its spread the RMS distance from that centroid.

Why not the tag itself (the paper: "on tracking any landmark, the robot knows its accurate location"): the
antenna is anywhere within r of it, 0.71 r off at the median. Why not the edge of the read disc (the first read
of a reader that reads continuously, ``pi r / 4`` behind the tag): a reader polled every 0.5-0.6 s reads while
the robot, 10-12 cm further each poll, is anywhere over the tags, not where it came within range. The region
also uses the neighbours: with tags 5 cm apart along a group's outline, which of them a poll reads pins the
antenna to a lens a few centimetres across.

Pure module: numpy, no ROS; positions in metres, in the map frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

GRID_STEP_IN_RANGES = 0.04
"""Spacing of the candidate points, in read ranges (2 mm at 5 cm): far below the region's size."""


def _unit_disc_grid(step: float) -> np.ndarray:
    ticks = np.arange(-1.0, 1.0 + step / 2.0, step)
    points = np.stack(np.meshgrid(ticks, ticks), axis=-1).reshape(-1, 2)
    return points[np.hypot(points[:, 0], points[:, 1]) <= 1.0]


_UNIT_DISC = _unit_disc_grid(GRID_STEP_IN_RANGES)


@dataclass(frozen=True)
class TagFix:
    position: tuple[float, float]
    sd_m: float                         # RMS distance of the region's points from ``position``
    tag_id: str                         # the read tag nearest to ``position``


def tag_fix(read: Sequence[tuple[str, tuple[float, float]]], unread: Sequence[tuple[float, float]],
            read_range_m: float) -> TagFix:
    """The fix from one poll: ``read`` the (id, position) of every tag it read (at least one), ``unread`` the
    positions of the map's tags near them that it did not read.

    A region left empty (a tag's true range a little short of ``read_range_m``, or a map slightly off) falls
    back to the read tags' centroid with the spread of a disc of radius r."""
    if not read:
        raise ValueError("tag_fix: a fix needs at least one tag read")
    if not (math.isfinite(read_range_m) and read_range_m > 0.0):
        raise ValueError(f"tag_fix: read_range_m must be a positive range, got {read_range_m}")
    positions = np.array([position for _, position in read], dtype=float)
    candidates = positions[0] + read_range_m * _UNIT_DISC
    inside = np.all(np.linalg.norm(candidates[:, None, :] - positions[None, :, :], axis=2) <= read_range_m, axis=1)
    if len(unread):
        others = np.asarray(unread, dtype=float).reshape(-1, 2)
        inside &= np.all(np.linalg.norm(candidates[:, None, :] - others[None, :, :], axis=2) > read_range_m, axis=1)
    region = candidates[inside]
    if len(region) == 0:
        centre, spread = positions.mean(axis=0), read_range_m / math.sqrt(2.0)
    else:
        centre = region.mean(axis=0)
        spread = float(np.sqrt(np.mean(np.sum((region - centre) ** 2, axis=1))))
    nearest = int(np.argmin(np.linalg.norm(positions - centre, axis=1)))
    return TagFix((float(centre[0]), float(centre[1])), spread, read[nearest][0])
