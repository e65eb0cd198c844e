"""The topological mission's simulator cores as they were before issue 19's third faster core (commit 249c210),
kept as the references the faster ones must equal to the last bit: the sonar cast at every wall with numpy
arrays, the base's step, and the wall-tag reader testing every tag."""

from __future__ import annotations

import math

import numpy as np

from rfidnav_common.base_safety import BaseEventRecord, gate_motion
from rfidnav_common.geometry import nearest_on_segments
from rfidnav_sim.kinematics import CONTACT_MARGIN_M, DiffDriveBase, Pose2D, moves_into_wall
from rfidnav_sim.sonar_model import ON_WALL_TOLERANCE_M, SonarModel
from rfidnav_sim.wall_tag_model import WallTagReader


def cast_rays(origins: np.ndarray, directions: np.ndarray, walls: np.ndarray,
              specular_angle_rad: float = math.pi / 2.0) -> np.ndarray:
    """rfidnav_sim.sonar_model.cast_rays at commit 249c210."""
    origins = np.asarray(origins, dtype=float).reshape(-1, 2)
    directions = np.asarray(directions, dtype=float).reshape(-1, 2)
    walls = np.asarray(walls, dtype=float).reshape(-1, 4)
    if len(walls) == 0:
        return np.full(len(origins), np.inf)
    ax, ay = walls[:, 0], walls[:, 1]                                         # N
    wx, wy = walls[:, 2] - ax, walls[:, 3] - ay                               # N
    ox, oy = origins[:, 0:1] - ax, origins[:, 1:2] - ay                       # K x N: o - a
    dx, dy = directions[:, 0:1], directions[:, 1:2]                           # K x 1
    denominator = dx * wy - dy * wx                                           # K x N: d x w
    parallel = denominator == 0.0
    safe = np.where(parallel, 1.0, denominator)
    t = (wx * oy - wy * ox) / safe                                            # (a - o) x w / (d x w)
    s = (dx * oy - dy * ox) / safe                                            # (a - o) x d / (d x w)
    hit = ~parallel & (t >= -ON_WALL_TOLERANCE_M) & (s >= 0.0) & (s <= 1.0)
    distances = np.where(hit, np.maximum(t, 0.0), np.inf)
    if specular_angle_rad >= math.pi / 2.0:
        return distances.min(axis=1)
    nearest = distances.argmin(axis=1)
    rows = np.arange(len(origins))
    cos_incidence = np.abs(denominator[rows, nearest]) / np.hypot(wx, wy)[nearest]
    echoes = cos_incidence >= math.cos(specular_angle_rad)
    return np.where(echoes, distances[rows, nearest], np.inf)


def sonar_ranges(model: SonarModel, x: float, y: float, yaw: float, rng: np.random.Generator) -> dict[str, float]:
    """SonarModel.ranges at commit 249c210 (its echo_distances casting at every wall, as before the wall grid)."""
    rays = model.rays_per_beam
    spread = np.linspace(-1.0, 1.0, rays) if rays > 1 else np.zeros(1)
    local = np.repeat(np.array([r.position for r in model.rangefinders], dtype=float).reshape(-1, 2), rays, axis=0)
    ray_bearings = np.concatenate([r.bearing_rad + r.beam_half_angle_rad * spread for r in model.rangefinders])
    c, s = math.cos(yaw), math.sin(yaw)
    origins = np.column_stack((x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]))
    bearings = yaw + ray_bearings
    distances = cast_rays(origins, np.column_stack((np.cos(bearings), np.sin(bearings))), model.walls,
                          model.specular_angle_rad)
    echo = distances.reshape(len(model.rangefinders), rays).min(axis=1)
    min_range_m = np.array([r.min_range_m for r in model.rangefinders])
    max_range_m = np.array([r.max_range_m for r in model.rangefinders])
    in_range = echo <= max_range_m
    true_range = np.where(in_range, np.maximum(echo, min_range_m), max_range_m)
    noise = rng.standard_normal(len(echo)) * (model.noise_sd_m + model.noise_fraction * true_range)
    reading = np.where(in_range, np.clip(true_range + noise, min_range_m, max_range_m), np.inf)
    return {r.name: float(value) for r, value in zip(model.rangefinders, reading)}


class ReferenceBase(DiffDriveBase):
    """DiffDriveBase with its step at commit 249c210."""

    def step(self, dt: float) -> list[BaseEventRecord]:
        limits = self.limits
        linear, angular = self.command if self.command_age_s <= limits.command_timeout_s else (0.0, 0.0)
        linear, angular = gate_motion(linear, angular, bumped=self.bumpers.bumped, halted=False)
        self.command_age_s += dt
        half_track = 0.5 * limits.track_width_m
        targets = (linear - angular * half_track, linear + angular * half_track)
        peak = max(abs(targets[0]), abs(targets[1]))
        if peak > limits.max_wheel_speed_mps:
            targets = tuple(t * limits.max_wheel_speed_mps / peak for t in targets)
        max_change = limits.max_wheel_accel_mps2 * dt
        left_before, right_before = self.left_speed, self.right_speed
        self.left_speed += min(max(targets[0] - self.left_speed, -max_change), max_change)
        self.right_speed += min(max(targets[1] - self.right_speed, -max_change), max_change)
        left_m = 0.5 * (left_before + self.left_speed) * dt
        right_m = 0.5 * (right_before + self.right_speed) * dt
        before = Pose2D(self.truth.x, self.truth.y, self.truth.yaw)
        self.truth.advance(left_m, right_m, limits.track_width_m)
        events: list[BaseEventRecord] = []
        moved = math.hypot(self.truth.x - before.x, self.truth.y - before.y)
        if len(self.walls) and (self.bumpers.bumped or moved >= self.clearance_m):
            if moves_into_wall(self.walls, (before.x, before.y), (self.truth.x, self.truth.y),
                               limits.footprint_radius_m):
                self.truth, self.left_speed, self.right_speed = before, 0.0, 0.0
                left_m = right_m = 0.0
            distance, point = nearest_on_segments((self.truth.x, self.truth.y), self.walls)
            self.clearance_m = distance - limits.footprint_radius_m - CONTACT_MARGIN_M
            events = self.update_bumpers(distance, point)
        else:
            self.clearance_m -= moved
        self.distance_travelled_m += abs(0.5 * (left_m + right_m))
        drift = self.drift
        slip = self.rng.normal(0.0, drift.slip_std, 2) if drift.slip_std > 0.0 else (0.0, 0.0)
        self.odom.advance(left_m * (1.0 + drift.left_scale_error + slip[0]),
                          right_m * (1.0 + drift.right_scale_error + slip[1]),
                          limits.track_width_m * (1.0 + drift.track_scale_error))
        return events


class ReferenceReader(WallTagReader):
    """WallTagReader with its in_reach and read at commit 249c210 (every tag tested, with numpy arrays)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.readable_tags = np.array(self.readable, dtype=bool)
        self.passage_was_read = np.ones(len(self.tags), dtype=bool)
        self.was_reached = np.zeros(len(self.tags), dtype=bool)
        self.positions = np.array([tag.position for tag in self.tags], dtype=float).reshape(-1, 2)
        self.normals = np.array([tag.normal for tag in self.tags], dtype=float).reshape(-1, 2)

    def in_reach(self, x: float, y: float, yaw: float) -> np.ndarray:
        antenna_x, antenna_y, bearing = self.antenna_pose(x, y, yaw)
        to_tag_x, to_tag_y = self.positions[:, 0] - antenna_x, self.positions[:, 1] - antenna_y
        c, s = math.cos(bearing), math.sin(bearing)
        depth = c * to_tag_x + s * to_tag_y
        across = -s * to_tag_x + c * to_tag_y
        facing = self.normals[:, 0] * -to_tag_x + self.normals[:, 1] * -to_tag_y > 0.0
        return (depth >= 0.0) & (depth <= self.area.depth_m) & (np.abs(across) <= self.area.width_m / 2.0) & facing

    def read(self, x: float, y: float, yaw: float, rng: np.random.Generator) -> list[str]:
        reach = self.in_reach(x, y, yaw)
        kept = rng.random(len(self.tags)) >= self.miss_probability
        passage = rng.random(len(self.tags)) >= self.passage_miss_probability
        arriving = reach & ~self.was_reached
        self.passage_was_read[arriving] = passage[arriving]
        self.was_reached = reach
        return [self.tags[i].tag_id
                for i in np.flatnonzero(reach & kept & self.passage_was_read & self.readable_tags)]
