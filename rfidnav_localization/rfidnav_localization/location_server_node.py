"""location_server: paper 003's location server, the robot's tier-one localization and tag map.

It holds the radio map (WiFi fingerprints) and the tag map (floor tag groups) in an SQLite database file and
answers three services:

* ``/location_server/locate`` (Locate): a WiFi scan -> position and uncertainty, by weighted k-nearest
  neighbours in signal space (rfidnav_localization.fingerprint). An empty scan, an empty radio map or a
  scan sharing no AP with it is a failure answer with the reason, never a crash.
* ``/location_server/tag_map`` (GetTagMap): the floor tags within a radius of a point.
* ``/location_server/add_fingerprint`` (AddFingerprint): a scan taken at a known position joins the radio
  map (paper 003's automatic radio map construction: the robot contributes samples at its tier-two fixes).

Every request is checked (rfidnav_common.inputs) and refused with success false and the reason, counted with a
throttled warning: a scan not in base_link (the WiFi antenna's frame), an RSS outside the physical range or an
empty BSSID; a point beyond any map; a fingerprint further than MAP_MARGIN_M outside what the map covers (its tag
groups, deployment area and fingerprints: a survey grows it a margin at a time).

A missing database (unless ``create_database``), a corrupt one or one of an unknown schema is one error at
start (exit 2). The tag groups of ``map_file`` are loaded into the tag map at start, once, and its radio map
file into an empty radio map unless ``load_radio_map`` is false (the robot's own survey builds it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rfidnav_common import inputs
from rfidnav_common.frames import WIFI_FRAME
from rfidnav_common.robot_map import RouteMap, load_route_map
from rfidnav_common.ros import declare_parameters, input_drops, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_localization.conversions import floor_tag_message
from rfidnav_localization.errors import LocateError, StoreError
from rfidnav_localization.fingerprint import MAP_MARGIN_M, Extent, Fingerprint, RadioMap
from rfidnav_localization.location_store import LocationStore, TagGroupRecord
from rfidnav_localization.parameters import LocationServerParameters
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_msgs.srv import AddFingerprint, GetTagMap, Locate


class LocationServerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("location_server", **node_options)
        self.params: LocationServerParameters = declare_parameters(self, LocationServerParameters)
        self.settings = self.params.locate_settings()
        self.drops = input_drops(self)
        self.store = LocationStore.open(self.params.database_path(), create=self.params.create_database)
        area: list[tuple[float, float]] = []
        if self.params.map_file != "unused":
            robot_map = load_route_map(Path(self.params.map_file))
            self.load_map(robot_map)
            if robot_map.deployment_area is not None:
                x_min, y_min, x_max, y_max = robot_map.deployment_area
                area = [(x_min, y_min), (x_max, y_max)]
        self.radio_map = RadioMap(self.store.fingerprints())
        # What the map covers: None while it has nothing (the first fingerprint may then be anywhere on Earth).
        self.extent = Extent.around(area + [tag[1] for group in self.store.tag_groups() for tag in group.tags]
                                    + [fingerprint.position for fingerprint in self.radio_map.fingerprints])
        self.create_service(Locate, "/location_server/locate", self.on_locate)
        self.create_service(GetTagMap, "/location_server/tag_map", self.on_tag_map)
        self.create_service(AddFingerprint, "/location_server/add_fingerprint", self.on_add_fingerprint)
        self.get_logger().info(f"{self.params.database_path()}: {len(self.radio_map)} fingerprints, "
                               f"{len(self.store.tag_groups())} tag groups")

    def load_map(self, robot_map: RouteMap) -> None:
        """The map's tag groups that the database does not hold yet (a restart finds them already there), and its
        radio map file when the database has no fingerprints (and ``load_radio_map``)."""
        if (self.params.load_radio_map and robot_map.radio_map_file is not None
                and self.store.fingerprint_count() == 0):
            self.store.add_fingerprints(load_radio_map(robot_map.radio_map_file))
        known = {group.group_id for group in self.store.tag_groups()}
        for group in robot_map.tag_groups:
            if group.group_id not in known:
                self.store.add_tag_group(TagGroupRecord(group.group_id, group.shape, group.centre, group.size_m,
                                                        group.rotation_rad, dict(group.tags())))

    def refuse(self, service: str, response: Any, problem: object) -> Any:
        """``response`` refusing the request (success false, the reason), counted and warned about."""
        self.drops.drop(service, problem)
        response.success, response.message = False, str(problem)
        return response

    def on_locate(self, request: Locate.Request, response: Locate.Response) -> Locate.Response:
        try:
            inputs.frame(request.scan.header.frame_id, WIFI_FRAME, "scan.header.frame_id")
            result = self.radio_map.locate(inputs.wifi_rss(request.scan), self.settings)
        except inputs.BadInput as error:
            return self.refuse("/location_server/locate", response, error)
        except LocateError as error:
            response.success, response.message = False, str(error)
            return response
        response.success = True
        response.x, response.y = result.position
        response.uncertainty_m = result.uncertainty_m
        response.known_aps = result.known_aps
        response.ignored_bssids = list(result.ignored_bssids)
        response.message = (f"{len(result.neighbours)} neighbours, nearest {result.signal_distance_db:.1f} dB away "
                            f"in signal space")
        return response

    def on_tag_map(self, request: GetTagMap.Request, response: GetTagMap.Response) -> GetTagMap.Response:
        try:
            x, y = inputs.point(request.x, request.y, "query")
            if not inputs.length(request.radius_m, "radius_m") > 0.0:
                raise inputs.BadInput("radius_m: must be positive, got 0")
        except inputs.BadInput as error:
            return self.refuse("/location_server/tag_map", response, f"bad query: {error}")
        tags = sorted(self.store.tags_near(x, y, request.radius_m), key=lambda tag: tag.tag_id)
        response.success, response.message = True, f"{len(tags)} tags"
        response.tags = [floor_tag_message(tag) for tag in tags]
        return response

    def on_add_fingerprint(self, request: AddFingerprint.Request,
                           response: AddFingerprint.Response) -> AddFingerprint.Response:
        response.fingerprint_count = len(self.radio_map)
        try:
            inputs.frame(request.scan.header.frame_id, WIFI_FRAME, "scan.header.frame_id")
            x, y = inputs.point(request.x, request.y, "position")
            if self.extent is not None and not self.extent.grown(MAP_MARGIN_M).contains(x, y):
                raise inputs.BadInput(f"position ({x:g}, {y:g}) is more than {MAP_MARGIN_M:g} m outside the map "
                                      f"({self.extent})")
            rss = inputs.wifi_rss(request.scan)
            if not rss:
                raise inputs.BadInput("scan: no access point heard")
            fingerprint = Fingerprint((x, y), rss, request.source or "robot")
        except (inputs.BadInput, ValueError) as error:
            return self.refuse("/location_server/add_fingerprint", response, f"not stored: {error}")
        try:
            self.store.add_fingerprint(fingerprint, created_s=seconds_of(request.scan.header.stamp))
        except StoreError as error:
            response.success, response.message = False, f"not stored: {error}"
            return response
        self.radio_map.add(fingerprint)
        self.extent = Extent(x, y, x, y) if self.extent is None else self.extent.including(x, y)
        response.success, response.message = True, "stored"
        response.fingerprint_count = len(self.radio_map)
        return response

    def destroy_node(self) -> None:
        self.store.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(LocationServerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
