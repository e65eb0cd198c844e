"""UHF RFID reader model: which tags each antenna reads, and their phase, I/Q and RSSI.

Phase (paper 001 section IV-A, and how LLRP readers report it): the backscattered carrier travels
the antenna-tag distance d twice, so

    phi = (4*pi*d/lambda + phi_tag + phi_antenna + noise) mod 2*pi,   lambda = c / f,

with I = A*cos(phi), Q = A*sin(phi) (so phi = atan2(Q, I)). The noise is Gaussian with a standard
deviation proportional to the distance (paper 001 section V: "magnitude proportional to the
distance between the transponder and the receiving antenna"). RSSI follows a two-way log-distance
path loss (exponent 4: 40 dB per decade) plus the antenna pattern on both ways. A tag is read by an
antenna when it lies within the antenna's range and beam cone, its RSSI is above the reader's
sensitivity, and the read does not miss (probability ``miss_probability``). Floor tags of a lattice
deployment (paper 000) are read by the downward antennas within the deployment's read range r,
measured horizontally: the read disc of paper 000 section 3.1 is the ground truth of those tags. Side antennas
(paper 004) read the world's wall tags in their induction area (rfidnav_sim.wall_tag_model). Both receiving antennas
of one round see the same backscatter (the paper's reader receives on two antennas at once), so the
phase difference is free of motion between antenna switches.

Reach (:func:`reach_m`) follows from that link budget: how far, horizontally, a tag at a given height is read by an
upward (or downward) antenna. ``max_range_m`` only caps the slant range below the budget's (a near-field floor
antenna's few centimetres); ReaderParameters refuses a cap beyond the budget's boresight range
(:func:`budget_range_m`), so no file can claim a reach its link budget does not give.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from rfidnav_common.polling import PollClock
from rfidnav_common.rf import round_trip_phase
from rfidnav_common.tag_lattice import Deployment
from rfidnav_common.wall_tags import InductionArea, WallTag
from rfidnav_sim.wall_tag_model import WallTagReader
from rfidnav_sim.world import World

TREE_FROM_TAGS = 256       # listed tags beyond which a round looks them up in a k-d tree


@dataclass(frozen=True)
class Antenna:
    port: int                                # 1-based, as the reader reports it
    position: tuple[float, float, float]     # in base_link [m]
    facing_up: bool                          # boresight +z (ceiling tags) or -z (floor tags)
    max_range_m: float
    half_angle_rad: float                    # beam cone half-angle about the boresight
    phase_offset_rad: float = 0.0            # cable and port delay, identical for every tag
    side_bearing_rad: float | None = None    # a side antenna (paper 004): reads wall tags in an induction area
                                             # along this bearing (CCW from forward), max_range_m deep


@dataclass(frozen=True)
class ReaderModel:
    antennas: tuple[Antenna, ...]
    channels_hz: tuple[float, ...]           # one channel = no hopping
    hop_dwell_s: float = 0.2                 # time on each channel when hopping
    phase_noise_rad_per_m: float = 0.02
    miss_probability: float = 0.0
    rssi_at_1m_dbm: float = -40.0
    sensitivity_dbm: float = -90.0
    max_rssi_dbm: float = -10.0              # the receiver saturates: no read is reported stronger
    pattern_exponent: float = 1.0            # one-way gain cos(theta)^n off boresight
    side_area_width_m: float = 0.40          # side antennas: the induction area's width (paper 004 Fig. 3)
    passage_miss_probability: float = 0.0    # side antennas: a wall tag missed for a whole passage
    unreadable_tags: tuple[str, ...] = ()    # side antennas: wall tags never read (forced read failures)


def link_rssi_dbm(model: ReaderModel, distance_m, cos_off_axis):
    """The link budget: RSSI of a tag ``distance_m`` away, ``cos_off_axis`` off the boresight (arrays or floats):
    two-way path loss of 40 dB per decade and the cos^n pattern on both ways."""
    return (model.rssi_at_1m_dbm - 40.0 * np.log10(distance_m)
            + 20.0 * model.pattern_exponent * np.log10(np.clip(cos_off_axis, 1e-6, 1.0)))


def budget_range_m(model: ReaderModel) -> float:
    """The farthest a tag is read on boresight by the link budget alone [m]: off the boresight it is less."""
    return float(10.0 ** ((model.rssi_at_1m_dbm - model.sensitivity_dbm) / 40.0))


def reach_m(model: ReaderModel, antenna: Antenna, tag_z_m: float) -> float:
    """How far from the antenna, horizontally, a tag at height ``tag_z_m`` (in the world, the floor at 0, the
    antenna at the robot's height for it) is read: the smallest of the three limits the simulator applies, each
    falling with the horizontal distance r at the tag's height h above (up) or below (down) the antenna:

    * the link budget: rssi_at_1m - 40 log d + 20 n log(h / d) >= sensitivity, d = sqrt(r^2 + h^2), so
      d <= 10^((rssi_at_1m - sensitivity + 20 n log h) / (40 + 20 n));
    * the beam cone: r <= h tan(half_angle);
    * the cap on the slant range: d <= max_range_m.

    0 for a tag the antenna does not face. Side antennas read wall tags in an induction area: no reach here."""
    if antenna.side_bearing_rad is not None:
        raise ValueError(f"antenna {antenna.port} is a side antenna: it reads wall tags in its induction area")
    height = (tag_z_m - antenna.position[2]) * (1.0 if antenna.facing_up else -1.0)
    if height <= 0.0:
        return 0.0
    n = model.pattern_exponent
    margin_db = model.rssi_at_1m_dbm - model.sensitivity_dbm + 20.0 * n * math.log10(height)
    budget = 10.0 ** (margin_db / (40.0 + 20.0 * n))
    slant = min(budget, antenna.max_range_m)
    if slant <= height:
        return 0.0
    cone = height * math.tan(antenna.half_angle_rad) if antenna.half_angle_rad < math.pi / 2.0 else math.inf
    return min(math.sqrt(slant * slant - height * height), cone)


@dataclass(frozen=True)
class Read:
    tag_id: str
    antenna: int
    rssi_dbm: float
    phase_rad: float
    i: float
    q: float
    frequency_hz: float


class ReaderSimulator:
    """Simulates inventory rounds of one reader on a robot among fixed tags."""

    @classmethod
    def for_world(cls, model: ReaderModel, world: World, rng: np.random.Generator) -> ReaderSimulator:
        """A reader among the world's listed tags, its lattice floor deployments and its wall tags."""
        return cls(model, [t.tag_id for t in world.tags], world.tag_positions(),
                   np.array([t.phase_offset_rad for t in world.tags]), rng, world.deployments, world.wall_tags)

    def __init__(self, model: ReaderModel, tag_ids: list[str], tag_positions: np.ndarray,
                 tag_phase_offsets: np.ndarray, rng: np.random.Generator,
                 floor_deployments: tuple[Deployment, ...] = (), wall_tags: tuple[WallTag, ...] = ()) -> None:
        self.model = model
        self.floor_deployments = floor_deployments
        self.down_antennas = [index for index, antenna in enumerate(model.antennas)
                              if not antenna.facing_up and antenna.side_bearing_rad is None]
        # Side antennas read only wall tags, in their induction areas (rfidnav_sim.wall_tag_model).
        self.wall_readers = [(index, WallTagReader(InductionArea(antenna.position[:2], antenna.side_bearing_rad,
                                                                 model.side_area_width_m, antenna.max_range_m),
                                                   wall_tags, model.miss_probability,
                                                   model.passage_miss_probability, model.unreadable_tags))
                             for index, antenna in enumerate(model.antennas)
                             if antenna.side_bearing_rad is not None and wall_tags]
        self.tag_ids = list(tag_ids)
        self.tag_positions = np.asarray(tag_positions, dtype=float).reshape(-1, 3)
        self.tag_phase_offsets = np.asarray(tag_phase_offsets, dtype=float)
        self.rng = rng
        self.antenna_offsets = np.array([a.position for a in model.antennas], dtype=float).reshape(-1, 3)
        self.antenna_facing = np.array([1.0 if a.facing_up else -1.0 for a in model.antennas])
        self.antenna_max_range = np.array([a.max_range_m for a in model.antennas])
        self.antenna_min_cos = np.cos(np.array([a.half_angle_rad for a in model.antennas]))
        self.antenna_phase_offsets = np.array([a.phase_offset_rad for a in model.antennas])
        # Side antennas read wall tags only (their induction areas); the others the listed tags, by a k-d tree.
        self.listing_antennas = [index for index, antenna in enumerate(model.antennas)
                                 if antenna.side_bearing_rad is None]
        # A few tags are faster taken all than looked up in a tree.
        self.tag_tree = cKDTree(self.tag_positions) if len(self.tag_positions) > TREE_FROM_TAGS else None

    def channel_at(self, time_s: float) -> float:
        channels = self.model.channels_hz
        if len(channels) == 1:
            return channels[0]
        return channels[int(time_s // self.model.hop_dwell_s) % len(channels)]

    def antenna_positions(self, x: float, y: float, yaw: float) -> np.ndarray:
        """World positions of the antennas for a robot pose (planar robot, antenna z is height)."""
        c, s = math.cos(yaw), math.sin(yaw)
        local = self.antenna_offsets
        return np.column_stack((x + c * local[:, 0] - s * local[:, 1],
                                y + s * local[:, 0] + c * local[:, 1],
                                local[:, 2]))

    def inventory(self, x: float, y: float, yaw: float, time_s: float) -> list[Read]:
        """All reads of one inventory round with the robot at (x, y, yaw)."""
        frequency = self.channel_at(time_s)
        antenna_world = self.antenna_positions(x, y, yaw)
        reads = self.listed_tag_reads(antenna_world, frequency) if self.tag_ids else []
        if self.floor_deployments:
            reads += self.lattice_reads(antenna_world, frequency)
        for index, reader in self.wall_readers:
            reads += self.wall_reads(index, reader, x, y, yaw, frequency)
        return reads

    def wall_reads(self, index: int, reader: WallTagReader, x: float, y: float, yaw: float,
                   frequency: float) -> list[Read]:
        """Reads of the wall tags in one side antenna's induction area (misses drawn by the area's reader)."""
        tag_ids = reader.read(x, y, yaw, self.rng)
        if not tag_ids:
            return []
        antenna_x, antenna_y, _ = reader.antenna_pose(x, y, yaw)
        by_id = {tag.tag_id: tag for tag in reader.tags}
        positions = np.array([by_id[tag_id].position for tag_id in tag_ids])
        distance = np.maximum(np.hypot(positions[:, 0] - antenna_x, positions[:, 1] - antenna_y), 1e-3)
        rssi = self.model.rssi_at_1m_dbm - 40.0 * np.log10(distance)
        return self.reads_of(tag_ids, np.full(len(tag_ids), index), distance,
                             np.full(len(tag_ids), self.model.antennas[index].phase_offset_rad), rssi, frequency)

    def lattice_reads(self, antenna_world: np.ndarray, frequency: float) -> list[Read]:
        """Reads of the lattice floor tags within r (horizontally) of each downward antenna."""
        reads: list[Read] = []
        for a in self.down_antennas:
            ax, ay, az = antenna_world[a]
            for deployment in self.floor_deployments:
                coordinates = deployment.tags_reading(ax, ay)
                if not coordinates:
                    continue
                if self.model.miss_probability > 0.0:
                    kept = self.rng.random(len(coordinates)) >= self.model.miss_probability
                    coordinates = [c for c, keep in zip(coordinates, kept) if keep]
                positions = deployment.lattice.positions(np.array(coordinates, dtype=float).reshape(-1, 2))
                distance = np.maximum(np.sqrt(np.sum((positions - (ax, ay)) ** 2, axis=1) + az * az), 1e-3)
                rssi = link_rssi_dbm(self.model, distance, abs(az) / distance)
                reads += self.reads_of([deployment.lattice.tag_id(c) for c in coordinates],
                                       np.full(len(coordinates), a), distance,
                                       np.full(len(coordinates), self.model.antennas[a].phase_offset_rad),
                                       rssi, frequency)
        return reads

    def reads_of(self, tag_ids: list[str], antenna_indices: np.ndarray, distance: np.ndarray,
                 phase_offsets: np.ndarray, rssi: np.ndarray, frequency: float) -> list[Read]:
        """One Read per (tag, antenna, distance): phase with distance-proportional noise, I/Q from RSSI (saturated at
        the receiver's ``max_rssi_dbm``: the link budget grows without bound as a tag nears the antenna)."""
        rssi = np.minimum(rssi, self.model.max_rssi_dbm)
        noise = self.rng.normal(0.0, 1.0, distance.size) * self.model.phase_noise_rad_per_m * distance
        phase = round_trip_phase(distance, frequency, phase_offsets + noise)
        amplitude = 10.0 ** (rssi / 20.0)
        return [Read(tag_id=tag_id, antenna=self.model.antennas[a].port, rssi_dbm=float(r), phase_rad=float(p),
                     i=float(amp * math.cos(p)), q=float(amp * math.sin(p)), frequency_hz=frequency)
                for tag_id, a, r, p, amp in zip(tag_ids, antenna_indices, rssi, phase, amplitude)]

    def listed_tag_reads(self, antenna_world: np.ndarray, frequency: float) -> list[Read]:
        """Reads of the tags listed in the world: within each antenna's range, beam cone and sensitivity.

        Only the tags the k-d tree finds within an antenna's range are looked at, so a round costs what the tags
        near the robot cost, not every tag of a building. The reads come in the order they would from the whole
        antennas x tags matrix (antenna by antenna, then the world's tag order); with ``miss_probability`` a miss
        is drawn for each tag within range, not for every tag of the world."""
        model = self.model
        antenna_index, tag_index = self.tags_in_range(antenna_world)
        if tag_index.size == 0:
            return []
        offsets = self.tag_positions[tag_index] - antenna_world[antenna_index]
        distance = np.maximum(np.linalg.norm(offsets, axis=1), 1e-3)
        cos_off_axis = self.antenna_facing[antenna_index] * offsets[:, 2] / distance
        rssi = link_rssi_dbm(model, distance, cos_off_axis)
        readable = ((distance <= self.antenna_max_range[antenna_index])
                    & (cos_off_axis >= self.antenna_min_cos[antenna_index]) & (rssi >= model.sensitivity_dbm))
        if model.miss_probability > 0.0:
            readable &= self.rng.random(readable.shape) >= model.miss_probability
        antenna_index, tag_index, distance, rssi = (antenna_index[readable], tag_index[readable], distance[readable],
                                                    rssi[readable])
        if tag_index.size == 0:
            return []
        phase_offsets = self.tag_phase_offsets[tag_index] + self.antenna_phase_offsets[antenna_index]
        return self.reads_of([self.tag_ids[t] for t in tag_index], antenna_index, distance, phase_offsets, rssi,
                             frequency)

    def tags_in_range(self, antenna_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(antenna, tag) index pairs of the listed tags within each listing antenna's range (every tag, for a world
        of at most TREE_FROM_TAGS), antenna by antenna, tags in the world's order. The tree's radius is a hair wider
        than the range; the exact test follows."""
        tree = self.tag_tree
        if not self.listing_antennas:
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        if tree is None:
            every = np.arange(len(self.tag_positions), dtype=np.intp)
            return (np.repeat(np.array(self.listing_antennas, dtype=np.intp), len(every)),
                    np.tile(every, len(self.listing_antennas)))
        radius = self.antenna_max_range * (1.0 + 1e-9) + 1e-9
        pairs = [(a, np.sort(np.asarray(tree.query_ball_point(antenna_world[a], radius[a]), dtype=np.intp)))
                 for a in self.listing_antennas]
        return (np.concatenate([np.full(len(tags), a, dtype=np.intp) for a, tags in pairs]),
                np.concatenate([tags for _, tags in pairs]))


class PolledReader:
    """A simulated reader with its rounds: when they come and whether they read (rfidnav_common.polling), what
    each reads (:class:`ReaderSimulator`). The rfid_reader_sim node and the in-process runners read through it
    alike."""

    def __init__(self, simulator: ReaderSimulator, clock: PollClock) -> None:
        self.simulator = simulator
        self.clock = clock

    def sample(self, truth: tuple[float, float, float], now_s: float) -> list[Read] | None:
        """The reads of the round due at ``now_s`` with the robot at ``truth`` (x, y, yaw), empty for a failed
        one; None when no round is due (a sensor of rfidnav_sim.rig)."""
        if not self.clock.due(now_s):
            return None
        return self.simulator.inventory(*truth, now_s) if self.clock.reads() else []
