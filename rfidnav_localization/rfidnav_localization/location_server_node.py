"""location_server: paper 003's location server, the robot's tier-one localization and tag map.

It holds the radio map (WiFi fingerprints) and the tag map (floor tag groups) in an SQLite database file and
answers three services:

* ``/location_server/locate`` (Locate): a WiFi scan -> position and uncertainty, by weighted k-nearest
  neighbours in signal space (rfidnav_localization.fingerprint). An empty scan, an empty radio map or a
  scan sharing no AP with it is a failure answer with the reason, never a crash.
* ``/location_server/tag_map`` (GetTagMap): the floor tags within a radius of a point.
* ``/location_server/add_fingerprint`` (AddFingerprint): a scan taken at a known position joins the radio
  map (paper 003's automatic radio map construction: the robot contributes samples at its tier-two fixes).

A missing database (unless ``create_database``), a corrupt one or one of an unknown schema is one error at
start (exit 2). The tag groups of ``map_file`` are loaded into the tag map at start, once, and its radio map
file into an empty radio map.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rfidnav_common.robot_map import RouteMap, load_route_map
from rfidnav_common.ros import declare_parameters, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_localization.conversions import floor_tag_message, scan_rss
from rfidnav_localization.errors import LocateError, StoreError
from rfidnav_localization.fingerprint import Fingerprint, RadioMap
from rfidnav_localization.location_store import LocationStore, TagGroupRecord
from rfidnav_localization.parameters import LocationServerParameters
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_msgs.srv import AddFingerprint, GetTagMap, Locate


class LocationServerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("location_server", **node_options)
        self.params: LocationServerParameters = declare_parameters(self, LocationServerParameters)
        self.settings = self.params.locate_settings()
        self.store = LocationStore.open(self.params.database_path(), create=self.params.create_database)
        if self.params.map_file != "unused":
            self.load_map(load_route_map(Path(self.params.map_file)))
        self.radio_map = RadioMap(self.store.fingerprints())
        self.create_service(Locate, "/location_server/locate", self.on_locate)
        self.create_service(GetTagMap, "/location_server/tag_map", self.on_tag_map)
        self.create_service(AddFingerprint, "/location_server/add_fingerprint", self.on_add_fingerprint)
        self.get_logger().info(f"{self.params.database_path()}: {len(self.radio_map)} fingerprints, "
                               f"{len(self.store.tag_groups())} tag groups")

    def load_map(self, robot_map: RouteMap) -> None:
        """The map's tag groups that the database does not hold yet (a restart finds them already there), and its
        radio map file when the database has no fingerprints."""
        if robot_map.radio_map_file is not None and self.store.fingerprint_count() == 0:
            self.store.add_fingerprints(load_radio_map(robot_map.radio_map_file))
        known = {group.group_id for group in self.store.tag_groups()}
        for group in robot_map.tag_groups:
            if group.group_id not in known:
                self.store.add_tag_group(TagGroupRecord(group.group_id, group.shape, group.centre, group.size_m,
                                                        group.rotation_rad, dict(group.tags())))

    def on_locate(self, request: Locate.Request, response: Locate.Response) -> Locate.Response:
        try:
            result = self.radio_map.locate(scan_rss(request.scan), self.settings)
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
        if not (math.isfinite(request.x) and math.isfinite(request.y) and math.isfinite(request.radius_m)
                and request.radius_m > 0.0):
            response.success = False
            response.message = f"bad query: ({request.x}, {request.y}) radius {request.radius_m} m"
            return response
        tags = sorted(self.store.tags_near(request.x, request.y, request.radius_m), key=lambda tag: tag.tag_id)
        response.success, response.message = True, f"{len(tags)} tags"
        response.tags = [floor_tag_message(tag) for tag in tags]
        return response

    def on_add_fingerprint(self, request: AddFingerprint.Request,
                           response: AddFingerprint.Response) -> AddFingerprint.Response:
        try:
            fingerprint = Fingerprint((request.x, request.y), scan_rss(request.scan), request.source or "robot")
            if not fingerprint.rss:
                raise ValueError("scan: no access point heard")
            self.store.add_fingerprint(fingerprint, created_s=seconds_of(request.scan.header.stamp))
        except (ValueError, LocateError, StoreError) as error:
            response.success, response.message = False, f"not stored: {error}"
        else:
            self.radio_map.add(fingerprint)
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
