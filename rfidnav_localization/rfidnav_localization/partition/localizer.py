"""Partition localization of paper 000 (sections 3-4), or the particle filter (partition.particle_filter) over
the same observations.

Observations: one inventory round of the downward floor antenna (the tag ids read, in any order, possibly
repeated or junk) and the odometry pose at that time. Every tag id describes itself
(rfidnav_common.tag_lattice): the layout, the lattice spacing and the tag's lattice coordinate, hence its map
position and also the read range r (partition.geometry.read_range_of), so no map file is needed. r is derived
from the spacing, which the ids carry in whole micrometres rounded down: it is at most a micrometre short of
the deployment's r.

Paper method ("paper"):

* Location (sec. 4.1): the mean position of the tags read (the partition centre). Its covariance is the
  second moment, about that centre, of the partition's region (the points that read exactly those tags),
  so a consumer knows how far off the centre the robot may be.
* Orientation (sec. 4.2): while the robot drives straight it records the partitions it enters. Start set: the
  crossing points between the first two partitions; end set: between the last two (with only two partitions
  the start set is the first partition's region, whose extreme directions lie on its boundary). The heading
  of a straight traversal is the direction of a segment from a start point to an end point, so the bounds are
  the smallest and largest such direction and the estimate is their mean (partition.geometry). yaw_std is a
  quarter of the bounds' width (half-width / 2).
* Straight stretches: the odometry tells when the robot rotates. Once its heading has changed by more than
  ``turn_threshold_rad`` since the stretch began, a new stretch starts at the current partition and the
  heading is carried through the turn as the previous estimate plus the odometry's heading change (widened
  by the odometry's relative rotation error). Within a stretch the estimate is whichever is narrower of
  the carried bounds and the stretch's own partition bounds: right after a turn the region-to-boundary
  bound of the first partition change is often wider than what the robot already knew, and a partition
  bound is preferred only once it is tighter. The first stretch has nothing carried (the paper's case).

Particle filter ("filter", beyond the paper): see partition.particle_filter. When it is lost the localizer
re-initialises it from the current partition, counts it, and starts a new stretch (the heading is unknown
again).

Both methods:

* Every id is decoded; undecodable ids are ignored and counted. The first round with decodable tags fixes
  the lattice (its most common lattice, ties to the smallest id); tags of another lattice are ignored and
  counted as undecodable, as the robot cannot place them in its frame.
* Rogue tags (partition.rogue): the largest group of tags read together that lie within
  ``rogue_distance_factor`` * r of each other is kept (ties: the group containing the tag closest to the
  previous estimate, or the smallest id before any estimate); the others are rejected and reported. A rogue
  tag read alone is not caught here.
* An empty round keeps the previous partition's estimate (partition empty), as the robot may be between
  reads or outside the deployment; the heading follows the odometry.
* ``partitions_traversed`` counts the partition changes since the current stretch began (the first
  partition counts 0), so a navigator's "localization phase of N partitions" works for both methods.
  ``partition_changed`` compares with the last non-empty partition (an empty round is a missed read, not a
  partition), and is true for the first partition ever seen.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate, DecodedTag, Deployment, Lattice, TagIdError, decode_tag_id
from rfidnav_localization.partition.estimate import LocalizationEstimate, LocalizerSettings, YawEstimate
from rfidnav_localization.partition.geometry import (
    PartitionGeometry,
    orientation_bounds,
    partition_geometry,
    read_range_of,
)
from rfidnav_localization.partition.particle_filter import FilterTracker
from rfidnav_localization.partition.rogue import consistent_group
from rfidnav_localization.partition.stretch import Stretch

DECODE_CACHE_LIMIT = 200_000


@dataclass(frozen=True)
class _Heading:
    """A heading belief held relative to the odometry (map yaw = odometry yaw + offset), so it follows turns."""
    offset: float        # [rad]
    half_width: float    # half the width of the bounds [rad]

    def widened(self, by: float) -> _Heading:
        return _Heading(self.offset, min(self.half_width + by, math.pi))   # not replace(): twice a round


@dataclass(frozen=True)
class _Observation:
    partition: frozenset[Coordinate]
    tag_ids: tuple[str, ...]
    rejected_ids: tuple[str, ...]
    rejected: frozenset[Coordinate]     # read but rejected: neither evidence of reading nor of not reading


class PartitionLocalizer:
    """Localization from the partitions read, by the paper's method or a particle filter (module docstring)."""

    def __init__(self, settings: LocalizerSettings, rng: np.random.Generator) -> None:
        settings.validate()
        self.settings = settings
        self.rng = rng
        self._decoded: dict[str, DecodedTag | None] = {}
        self.reset()

    def reset(self) -> None:
        """Forget everything observed (the lattice too); settings and the random stream go on."""
        self.lattice: Lattice | None = None
        self.read_range_m: float | None = None
        self._geometry: PartitionGeometry | None = None
        self._deployment: Deployment | None = None
        self._last_partition: frozenset[Coordinate] = frozenset()
        self._last_odom: tuple[float, float, float] | None = None
        self._stretch: Stretch | None = None
        self._position: tuple[float, float] | None = None
        self._covariance = (0.0, 0.0, 0.0)
        self._heading: _Heading | None = None      # paper: the estimate in force
        self._carried: _Heading | None = None      # paper: the estimate carried into the current stretch
        self._filter: FilterTracker | None = None
        self.rogue_count = 0
        self.undecodable_count = 0
        self.filter_reinitialisations = 0

    # ------------------------------------------------------------------------------ observation

    def _decode(self, tag_id: str) -> DecodedTag | None:
        if tag_id not in self._decoded:
            if len(self._decoded) >= DECODE_CACHE_LIMIT:
                self._decoded.clear()
            try:
                self._decoded[tag_id] = decode_tag_id(tag_id)
            except TagIdError:
                self._decoded[tag_id] = None
        return self._decoded[tag_id]

    def _observe(self, tag_ids: Sequence[str]) -> _Observation:
        decoded: list[tuple[str, DecodedTag]] = []
        for tag_id in sorted(set(tag_ids)):    # a tag may be reported several times in one round
            tag = self._decode(tag_id)
            if tag is None:
                self.undecodable_count += 1
            else:
                decoded.append((tag_id, tag))
        if self.lattice is None and decoded:
            counts: dict[tuple[str, float], int] = {}
            for _, tag in decoded:
                counts[(tag.layout, tag.spacing_m)] = counts.get((tag.layout, tag.spacing_m), 0) + 1
            layout, spacing = max(counts, key=lambda key: counts[key])   # first maximum: the smallest id's
            self.lattice = Lattice(layout, spacing)
            self.read_range_m = read_range_of(self.lattice)
            self._geometry = partition_geometry(self.lattice, self.read_range_m)
            area = self.settings.deployment_area
            self._deployment = Deployment(self.lattice, self.read_range_m, area) if area is not None else None
        by_coordinate: dict[Coordinate, str] = {}
        for tag_id, tag in decoded:
            if (tag.layout, tag.spacing_m) != (self.lattice.layout, self.lattice.spacing_m):
                self.undecodable_count += 1
            else:
                by_coordinate.setdefault(tag.coordinate, tag_id)
        if not by_coordinate:
            return _Observation(frozenset(), (), (), frozenset())
        coordinates = list(by_coordinate)
        positions = [self.lattice.position(c) for c in coordinates]
        kept = consistent_group(positions, self.settings.rogue_distance_factor * self.read_range_m, self._position)
        kept_set = set(kept)
        rejected = [c for k, c in enumerate(coordinates) if k not in kept_set]
        self.rogue_count += len(rejected)
        return _Observation(frozenset(coordinates[k] for k in kept),
                            tuple(sorted(by_coordinate[coordinates[k]] for k in kept)),
                            tuple(sorted(by_coordinate[c] for c in rejected)), frozenset(rejected))

    # ------------------------------------------------------------------------------------ update

    def update(self, stamp_s: float, tag_ids: Sequence[str], odom: tuple[float, float, float]) -> LocalizationEstimate:
        """One inventory round: the floor tag ids read and the odometry pose (x, y, yaw) at that time."""
        if not all(math.isfinite(value) for value in odom):
            raise ValueError(f"odom: expected finite (x, y, yaw), got {odom}")
        observation = self._observe(tag_ids)
        partition = observation.partition
        changed = bool(partition) and partition != self._last_partition
        odom_rotation = wrap_angle(odom[2] - self._last_odom[2]) if self._last_odom is not None else 0.0
        turned = self._advance_stretch(partition, odom[2])
        if self.settings.method == "paper":
            yaw = self._paper_update(partition, changed, turned, odom, odom_rotation)
        else:
            yaw = self._filter_update(observation, odom)
        if partition:
            self._last_partition = partition
        self._last_odom = odom
        yaw_value, yaw_bounds, yaw_std = yaw if yaw is not None else (None, None, None)
        return LocalizationEstimate(
            stamp_s=stamp_s, method=self.settings.method, partition=partition,
            partition_tag_ids=observation.tag_ids, partition_changed=changed,
            partitions_traversed=max(len(self._stretch.partitions) - 1, 0),
            position=self._position, position_covariance=self._covariance,
            yaw=yaw_value, yaw_bounds=yaw_bounds, yaw_std=yaw_std,
            read_range_m=self.read_range_m, lattice=self.lattice, rejected_tag_ids=observation.rejected_ids,
            rogue_count=self.rogue_count, undecodable_count=self.undecodable_count,
            filter_reinitialisations=self.filter_reinitialisations)

    def _advance_stretch(self, partition: frozenset[Coordinate], odom_yaw: float) -> bool:
        """Record the partition in the current straight stretch; True when the odometry says the robot has
        turned, in which case a new stretch starts here."""
        stretch = self._stretch
        turned = False
        if stretch is None:
            stretch = self._stretch = Stretch(odom_yaw, [])
        else:
            change = wrap_angle(odom_yaw - stretch.start_odom_yaw)
            if abs(change) > self.settings.turn_threshold_rad:
                stretch = self._stretch = Stretch(odom_yaw, [])
                turned = True
            else:
                stretch.yaw_change_sum += change
                stretch.updates += 1
        if partition and (not stretch.partitions or stretch.partitions[-1] != partition):
            stretch.partitions.append(partition)
        return turned

    @staticmethod
    def _reported_yaw(heading: _Heading, odom_yaw: float) -> YawEstimate:
        yaw = wrap_angle(odom_yaw + heading.offset)
        return yaw, (yaw - heading.half_width, yaw + heading.half_width), heading.half_width / 2.0

    # ------------------------------------------------------------------------------ paper method

    def _paper_update(self, partition: frozenset[Coordinate], changed: bool, turned: bool,
                      odom: tuple[float, float, float], odom_rotation: float) -> YawEstimate | None:
        if partition:
            self._position, self._covariance = self._geometry.location(partition)
        widening = self.settings.motion_noise_fraction * abs(odom_rotation)
        if self._heading is not None:
            self._heading = self._heading.widened(widening)
        if self._carried is not None:
            self._carried = self._carried.widened(widening)
        if turned:
            self._carried = self._heading
        stretch = self._stretch
        if changed and len(stretch.partitions) >= 2:
            bounds = orientation_bounds(self.lattice, self.read_range_m, stretch.partitions)
            if bounds is not None:
                lower, upper = bounds
                candidate = _Heading(wrap_angle((lower + upper) / 2.0 - stretch.mean_odom_yaw), (upper - lower) / 2.0)
                carried = self._carried
                self._heading = candidate if carried is None or candidate.half_width <= carried.half_width else carried
        return self._reported_yaw(self._heading, odom[2]) if self._heading is not None else None

    # ---------------------------------------------------------------------------- particle filter

    def _filter_update(self, observation: _Observation, odom: tuple[float, float, float]) -> YawEstimate | None:
        partition = observation.partition
        if self._filter is None:
            if not partition:
                return None
            self._filter = FilterTracker(self.settings, self.rng, self._geometry, self._deployment)
            self._restart_filter(partition, odom[2])
        elif not self._filter.track(self._last_odom, odom, self._last_partition, partition, observation.rejected,
                                    self._stretch):
            self.filter_reinitialisations += 1
            self._restart_filter(partition, odom[2])
        self._position, self._covariance, yaw = self._filter.estimate()
        return yaw

    def _restart_filter(self, partition: frozenset[Coordinate], odom_yaw: float) -> None:
        """Start the filter afresh in this partition; its heading is unknown again, so a new stretch begins."""
        self._filter.start(partition)
        self._stretch = Stretch(odom_yaw, [partition])
