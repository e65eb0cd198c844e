"""reproduce fused: what a run's localizers are and read. The fused localizers riding beside a run (``fused``, the
single-evidence ones, ``kidnap`` and ``late``) or driving it, the scenario's localizer and reader parameters, its
mission and map, and the figures of a run's tracks."""

from __future__ import annotations

import dataclasses
import math

from rfidnav_common.seeding import rng_for
from rfidnav_experiments.reproduce.fused.conditions import (
    HF_FLOOR_LOCALIZER,
    MIXED,
    SINGLE_EVIDENCE,
    kidnap_times_of,
    localizers_of,
)
from rfidnav_experiments.reproduce.fused.summary import FusedRun, TrackFigures
from rfidnav_experiments.reproduce.two_tier import Home
from rfidnav_experiments.runners.fused import Rider, Track
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_localization.fused.filter import FusedSettings
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_sim.parameters import ReaderParameters, WifiSimParameters


def localizer_parameters(place: Home) -> RfidLocalizerParameters:
    """The scenario's rfid_localizer parameters, or paper 003's robot's file for a scenario without one."""
    spec = place.scenario.nodes.get("rfid_localizer")
    path = spec.param_files[0] if spec is not None else HF_FLOOR_LOCALIZER
    return file_parameters(RfidLocalizerParameters, path, "rfid_localizer", map_file=str(place.scenario.map_file))


def reader_parameters(place: Home) -> ReaderParameters:
    """The reader of the scenario's rfid_reader role: the robot's sensors, as the DDS run has them."""
    return file_parameters(ReaderParameters, place.scenario.nodes["rfid_reader"].param_files[0], "rfid_reader_sim",
                           world_file=str(place.scenario.world_file))


def riders_for(world: str, run: int, seed: int, settings: FusedSettings, fused_map: FusedMap) -> dict[str, Rider]:
    """The fused localizers of one run: ``fused``, on the mixed floor the single-evidence ones, ``kidnap`` and
    ``late``; each with its own copy of the map (it learns the lattice from the first id read) and random stream."""
    late_s, kidnap_s = kidnap_times_of(world)

    def localizer(label: str) -> FusedLocalizer:
        return FusedLocalizer(settings, dataclasses.replace(fused_map), rng_for(seed, f"fused:{world}:{run}:{label}"))

    riders = {"fused": Rider(localizer("fused"))}
    if world == MIXED:
        riders.update({label: Rider(localizer(label), kinds) for label, kinds in SINGLE_EVIDENCE.items()})
    riders["kidnap"] = Rider(localizer("kidnap"), kidnap_at_s=kidnap_s, extent=fused_map.extent)
    riders["late"] = Rider(localizer("late"), joins_at_s=late_s)
    return riders


def fused_run(world: str, run: int, success: bool, riders: dict[str, Rider], paper: Track,
              duration_s: float) -> FusedRun:
    """The figures of one run's tracks."""
    late_s, kidnap_s = kidnap_times_of(world)
    figures = {label: TrackFigures.of(riders[label].track, paper.heading_times_s)
               for label in localizers_of(world) if label != "paper"}
    figures["paper"] = TrackFigures.of(paper, paper.heading_times_s)
    recovery = riders["kidnap"].track.settled_after(kidnap_s) if duration_s > kidnap_s else None
    found = riders["late"].track.settled_after(late_s) if duration_s > late_s else None
    return FusedRun(world, run, success, figures, riders["fused"].track.settled_after(0.0), found, recovery,
                    duration_s)


def mission_of(place: Home) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """The scenario's start pose (x, y, yaw [rad]) and its point goal."""
    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    return (x, y, math.radians(yaw_deg)), (target["x"], target["y"])


def home_map(place: Home) -> FusedMap:
    """What the fused localizer knows of a home: its robot map and its radio map."""
    robot_map = place.scenario.route_map
    assert robot_map is not None                       # home() refuses a home without its map
    return FusedMap.of_route_map(robot_map, place.site.radio_map)


def driving_rider(place: Home, name: str, run: int, seed: int) -> Rider:
    """The fused localizer of a run where it is in the loop: the scenario's rfid_localizer settings, its own
    random stream, starting knowing only the map as the node does."""
    return Rider(FusedLocalizer(localizer_parameters(place).settings(), home_map(place),
                                rng_for(seed, f"fused:{name}:{run}:fused")))


def scan_period_s(place: Home) -> float:
    """The scenario's WiFi scan period: how often the in-loop localizer asks the server to locate a scan."""
    return file_parameters(WifiSimParameters, place.scenario.nodes["wifi"].param_files[0], "wifi_sim",
                           world_file=str(place.scenario.world_file)).scan_period_s


def paired_figures(fused: Track, paper: Track) -> dict[str, TrackFigures]:
    """The figures of the fused localizer in the loop and of the paper's beside it, headings also on the paper's
    rounds."""
    return {"fused": TrackFigures.of(fused, paper.heading_times_s),
            "paper": TrackFigures.of(paper, paper.heading_times_s)}
