"""The kinds of evidence the fused filter weighs (pure), one Measurement each (rfidnav_localization.fused.measurement)
over its model (rfidnav_localization.fused.models), and MEASUREMENTS, which registers them in the order the filter
weighs them and LocalizationStatus.evidence_used names their likelihoods: the floor antenna's tags (lattice,
tag_group), the ceiling tags' phases (ceiling_phase, ceiling_range_rate), the side antenna's wall tags (wall_tag),
WiFi fixes (wifi) and the compass (compass).

Those that can place the robot -- a floor tag read, a wall tag read, a WiFi fix -- propose poses for the particles
sensor resetting redraws: over the floor tag, in the wall tag's induction area, about the WiFi fix; the compass
proposes their headings (the reading less each new particle's bias).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from rfidnav_localization.fused.measurement import Likelihoods, Measurement, MeasurementFactory, Particles
from rfidnav_localization.fused.models import PhaseTags, WallTagModel, mounted
from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.fused.tag_map import FusedMap

# Negative floor evidence (known tags near the particles that were not read) is weighed only while the cloud is
# this compact: a wide cloud would need thousands of lattice tags a round, and is placed by the reads anyway.
NEGATIVE_FLOOR_RADIUS_M = 0.5
# An unread tag farther than the read range plus this many soft edges from every particle's antenna scores
# 1 - eps for all of them (to within e^-6): it cannot change the weights, and weighing it costs particles x tags.
UNREAD_REACH_SOFTNESS = 6.0


@dataclass(frozen=True)
class PhaseReading:
    """One backscatter of a ceiling tag received on both antennas: the phase on each."""
    tag_id: str
    phase1_rad: float
    phase2_rad: float
    frequency_hz: float

    @property
    def dphi_rad(self) -> float:
        return self.phase1_rad - self.phase2_rad


WifiFix = tuple[tuple[float, float], float]      # the location server's answer: (position, uncertainty [m])


class FloorTags(Measurement[Sequence[str]]):
    """The ids the downward antenna read: lattice tags (their ids give their positions) and tag-group tags (the
    map's), each by the soft read model, with the known tags near a compact cloud that were not read."""
    name = "floor_tag_ids"
    kinds = ("lattice", "tag_group")
    reset_memory = {"lattice": 1.0, "tag_group": 1.0}      # a tag read no particle explains resets at once
    proposal_rank = 1

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.model = settings.floor
        self.tag_group_read_range_m = settings.tag_group_read_range_m
        self.map = fused_map

    def log_likelihoods(self, reading: Sequence[str], particles: Particles) -> Likelihoods:
        """Lattice tags and tag-group tags read by the floor antenna, and the known ones near that were not."""
        result = Likelihoods()
        states, weights = particles.states, particles.weights
        lattice_read: list[tuple[float, float]] = []
        group_read: list[tuple[float, float]] = []
        read_range = None
        for tag_id in reading:
            group_tag = self.map.floor_tags.get(tag_id)
            if group_tag is not None:
                group_read.append(group_tag)
                continue
            lattice_tag = self.map.lattice_position(tag_id)
            if lattice_tag is None:
                result.ignored.append(tag_id)
                continue
            lattice_read.append(lattice_tag[0])
            read_range = lattice_tag[1]
        if not lattice_read and not group_read:
            return result          # an empty round says nothing: a failed inventory looks the same
        model = self.model
        antennas = np.vstack(mounted(states, model.antenna_xy))
        centre_x, centre_y = (float(v) for v in antennas @ weights)
        spread = float(np.sqrt(weights @ (np.square(antennas[0] - centre_x) + np.square(antennas[1] - centre_y))))
        compact = spread <= NEGATIVE_FLOOR_RADIUS_M
        margin_m = UNREAD_REACH_SOFTNESS * model.softness_m
        if lattice_read and read_range is not None and self.map.deployment is not None:
            unread = np.zeros((0, 2))
            if compact:
                deployment = self.map.deployment
                read_set = {tuple(p) for p in lattice_read}
                near = [c for c in deployment.lattice.within(centre_x, centre_y, 3.0 * spread + read_range + margin_m)
                        if deployment.is_deployed(c) and deployment.lattice.position(c) not in read_set]
                if near:
                    unread = _within_reach(deployment.lattice.positions(np.array(near, dtype=float)), antennas,
                                           read_range + margin_m)
            result.add("lattice", model.log_likelihood(states, np.array(lattice_read), unread, read_range))
        if group_read:
            range_m = self.tag_group_read_range_m
            unread_tags = np.zeros((0, 2))
            if compact:
                group_set = set(group_read)
                unread_tags = _within_reach(np.array([
                    position for _, position in self.map.floor_tags_near(centre_x, centre_y,
                                                                         3.0 * spread + range_m + margin_m)
                    if position not in group_set]).reshape(-1, 2), antennas, range_m + margin_m)
            result.add("tag_group", model.log_likelihood(states, np.array(group_read), unread_tags, range_m))
        return result

    def poses(self, reading: Sequence[str], yaw: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """The antenna over the first known tag read, within its read range."""
        count = len(yaw)
        for tag_id in reading:
            position = self.map.floor_tags.get(tag_id)
            range_m = self.tag_group_read_range_m
            if position is None:
                lattice_tag = self.map.lattice_position(tag_id)
                if lattice_tag is None:
                    continue
                position, range_m = lattice_tag
            radius = range_m * np.sqrt(rng.random(count))
            angle = rng.uniform(-math.pi, math.pi, count)
            return _centres(position[0] + radius * np.cos(angle), position[1] + radius * np.sin(angle), yaw,
                            self.model.antenna_xy)
        return None


class CeilingPhases(Measurement[Sequence[PhaseReading]]):
    """Each ceiling tag heard on both receiving antennas: its phase difference and, heard on the same channel in
    the previous round too, its range rate, weighed against each particle's pose then (kept from that round, after
    its resampling) and now. Without a pair of receiving antennas (FusedSettings.phase None) every one is ignored."""
    name = "phase"
    kinds = ("ceiling_phase", "ceiling_range_rate")

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.model = settings.phase
        self.map = fused_map
        # The previous round's phases and the particles after it: the range rate's other end.
        self.previous: dict[str, PhaseReading] = {}
        self.previous_states: np.ndarray | None = None

    def log_likelihoods(self, reading: Sequence[PhaseReading], particles: Particles) -> Likelihoods:
        result = Likelihoods()
        model = self.model
        heard: list[tuple[PhaseReading, tuple[float, float, float]]] = []
        for phase in reading:
            ceiling_tag = self.map.ceiling_tags.get(phase.tag_id)
            if ceiling_tag is None or model is None:
                result.ignored.append(phase.tag_id)
            else:
                heard.append((phase, ceiling_tag))
        if not heard or model is None:
            return result
        # All of a round's tags in one pass over the particles (a row each), added one tag at a time as before.
        antennas = model.antennas(particles.states)
        tags = PhaseTags.of([(tag, phase.frequency_hz) for phase, tag in heard])
        for row in model.log_likelihoods_at(antennas, tags, np.array([phase.dphi_rad for phase, _ in heard])):
            result.add("ceiling_phase", row)
        again = [(index, phase, before) for index, (phase, _) in enumerate(heard)
                 if (before := self.previous.get(phase.tag_id)) is not None
                 and before.frequency_hz == phase.frequency_hz]
        if again and self.previous_states is not None:
            changes = np.array([(phase.phase1_rad - before.phase1_rad, phase.phase2_rad - before.phase2_rad)
                                for _, phase, before in again])
            rows = model.range_change_log_likelihoods_at(model.antennas(self.previous_states), antennas,
                                                         tags.rows([index for index, _, _ in again]), changes)
            for row in rows:
                result.add("ceiling_range_rate", row)
        return result

    def end_round(self, reading: Sequence[PhaseReading] | None, particles: Particles) -> None:
        self.previous = {phase.tag_id: phase for phase in reading or ()}
        self.previous_states = particles.states.copy() if self.previous else None

    def restart(self) -> None:
        self.previous, self.previous_states = {}, None


class WallTags(Measurement[Sequence[tuple[int, str]]]):
    """(side antenna port, tag id) of each wall tag read: inside that antenna's induction area, up to a soft edge."""
    name = "wall_tag_ids"
    kinds = ("wall_tag",)
    reset_memory = {"wall_tag": 1.0}
    proposal_rank = 0

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.areas = settings.wall_areas
        self.models = {port: WallTagModel(area, settings.wall_softness_m, settings.eps)
                       for port, area in settings.wall_areas.items()}
        self.map = fused_map

    def log_likelihoods(self, reading: Sequence[tuple[int, str]], particles: Particles) -> Likelihoods:
        result = Likelihoods()
        for port, tag_id in reading:
            wall_tag = self.map.wall_tags.get(tag_id)
            model = self.models.get(port)
            if wall_tag is None or model is None:
                result.ignored.append(tag_id)
                continue
            result.add("wall_tag", model.log_likelihood(particles.states, wall_tag))
        return result

    def poses(self, reading: Sequence[tuple[int, str]], yaw: np.ndarray, rng: np.random.Generator) \
            -> np.ndarray | None:
        """The antenna somewhere in front of the first known plate read, within its area's depth and half its
        width."""
        count = len(yaw)
        for port, tag_id in reading:
            tag, area = self.map.wall_tags.get(tag_id), self.areas.get(port)
            if tag is not None and area is not None:
                depth = rng.uniform(0.0, area.depth_m, count)
                across = rng.uniform(-area.width_m / 2.0, area.width_m / 2.0, count)
                bearing = yaw + area.bearing_rad
                antenna_x = tag.position[0] - depth * np.cos(bearing) + across * np.sin(bearing)
                antenna_y = tag.position[1] - depth * np.sin(bearing) - across * np.cos(bearing)
                return _centres(antenna_x, antenna_y, yaw, area.position)
        return None


class WifiFixes(Measurement[WifiFix]):
    """The location server's fix with its uncertainty, weighed only after the robot has travelled
    ``wifi_min_travel_m`` since the last one weighed: their errors are spatially correlated (the building's
    shadowing) and would otherwise be counted again and again, making the filter overconfident."""
    name = "wifi_fix"
    kinds = ("wifi",)
    reset_memory = {"wifi": 0.5}            # its errors run to metres: it resets only after several fixes
    proposal_rank = 2

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.model = settings.wifi
        self.min_travel_m = settings.wifi_min_travel_m
        self.travel_m = math.inf            # since the last fix weighed

    def log_likelihoods(self, reading: WifiFix, particles: Particles) -> Likelihoods:
        result = Likelihoods()
        if self.travel_m >= self.min_travel_m:
            fix, uncertainty = reading
            result.add("wifi", self.model.log_likelihood(particles.states, fix, uncertainty))
            self.travel_m = 0.0
        return result

    def poses(self, reading: WifiFix, yaw: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """About the fix, by its sd (whether or not this round weighed it)."""
        count = len(yaw)
        (fix_x, fix_y), uncertainty = reading
        sd = self.model.sd_m(uncertainty)
        return np.vstack((fix_x + sd * rng.standard_normal(count), fix_y + sd * rng.standard_normal(count), yaw))

    def moved(self, distance_m: float) -> None:
        self.travel_m += distance_m


class CompassHeadings(Measurement[float]):
    """The compass heading [rad], against each particle's heading plus its compass bias."""
    name = "compass_yaw_rad"
    kinds = ("compass",)

    def __init__(self, settings: FusedSettings, fused_map: FusedMap) -> None:
        self.model = settings.compass

    def log_likelihoods(self, reading: float, particles: Particles) -> Likelihoods:
        result = Likelihoods()
        result.add("compass", self.model.log_likelihood(particles.states, particles.biases, reading))
        return result

    def headings(self, reading: float, biases: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """The reading less each new particle's bias, with the compass's noise."""
        return reading - biases + self.model.sd_rad * rng.standard_normal(len(biases))


# The kinds the filter weighs, in the order it weighs them and the status names their likelihoods.
MEASUREMENTS: tuple[MeasurementFactory, ...] = (FloorTags, CeilingPhases, WallTags, WifiFixes, CompassHeadings)


def _within_reach(tags: np.ndarray, antennas: np.ndarray, reach_m: float) -> np.ndarray:
    """The rows of ``tags`` (k x 2) within ``reach_m`` of at least one of the ``antennas`` (2 x n)."""
    if len(tags) == 0:
        return tags
    distance, _ = cKDTree(antennas.T).query(tags, distance_upper_bound=reach_m)
    return tags[np.isfinite(distance)]


def _centres(antenna_x: np.ndarray, antenna_y: np.ndarray, yaw: np.ndarray,
             offset: tuple[float, float]) -> np.ndarray:
    """Robot poses (3 x n) whose antenna mounted at ``offset`` is at (antenna_x, antenna_y) with heading ``yaw``."""
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    return np.vstack((antenna_x - cos_yaw * offset[0] + sin_yaw * offset[1],
                      antenna_y - sin_yaw * offset[0] - cos_yaw * offset[1], yaw))
