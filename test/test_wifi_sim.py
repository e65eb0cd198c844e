"""wifi_sim (paper 003, tier one) and the world file's access points, WiFi settings and tag groups."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter

from rfidnav_common.errors import ConfigError
from rfidnav_common.ros import SENSOR_QOS
from rfidnav_msgs.msg import WifiScan
from rfidnav_sim.wifi_model import WifiModel
from rfidnav_sim.wifi_sim_node import WifiSimNode
from rfidnav_sim.world import load_world
from support.graph import Graph, ground_truth

pytestmark = pytest.mark.tier("unit")

WORLD = """name: flat
tag_groups:
  - {id: G1, shape: cross, centre: [1.0, 1.0], size_m: 0.3}
walls:
  - [4.0, -5.0, 4.0, 5.0]
access_points:
  - {bssid: "02:00:00:00:00:01", ssid: home, position: [0.0, 0.0], tx_power_dbm: 20.0, channel: 6}
  - {bssid: "02:00:00:00:00:02", ssid: home, position: [8.0, 0.0], tx_power_dbm: 20.0, channel: 36}
  - {bssid: "02:00:00:00:00:03", ssid: far, position: [900.0, 0.0], tx_power_dbm: 0.0, channel: 11}
wifi: {path_loss_exponent: 2.5, wall_loss_db: 6.0, shadowing_sd_db: 3.0, shadowing_seed: 9}
"""


@pytest.fixture
def world_file(tmp_path: Path) -> Path:
    path = tmp_path / "flat.yaml"
    path.write_text(WORLD)
    return path


def test_the_world_describes_the_building_and_its_tag_groups(world_file: Path) -> None:
    world = load_world(world_file)
    assert [ap.bssid for ap in world.access_points] == ["02:00:00:00:00:01", "02:00:00:00:00:02", "02:00:00:00:00:03"]
    assert world.wifi.wall_loss_db == 6.0 and world.wifi.path_loss_exponent == 2.5 and world.wifi_seed == 9
    floor = [tag for tag in world.tags if tag.tag_id.startswith("G1-")]
    assert len(floor) == 13 and all(tag.kind == "floor" and tag.position[2] == 0.0 for tag in floor)


@pytest.mark.parametrize("replace, where", [
    ('channel: 36}', "access_points[1]: channel"),
    ('ssid: far, position: [900.0, 0.0]', "access_points[2].position"),
    ('wall_loss_db: 6.0', "wifi.wall_loss_db"),
    ('shape: cross', "tag_groups[0]: tag group 'G1': shape"),
])
def test_a_bad_entry_names_its_field(tmp_path: Path, replace: str, where: str) -> None:
    broken = {'channel: 36}': 'channel: 200}', 'ssid: far, position: [900.0, 0.0]': 'ssid: far, position: [900.0]',
              'wall_loss_db: 6.0': 'wall_loss_db: -6.0', 'shape: cross': 'shape: star'}[replace]
    path = tmp_path / "broken.yaml"
    path.write_text(WORLD.replace(replace, broken))
    with pytest.raises(ConfigError, match=re.escape(f"broken.yaml: {where}")):
        load_world(path)


@pytest.mark.tier("node")
def test_wifi_sim_scans_at_its_period_with_the_worlds_radio_and_drops_what_it_cannot_hear(
        graph: Graph, world_file: Path) -> None:
    graph.add(WifiSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(world_file)), Parameter("seed", value=4),
        Parameter("scan_period_s", value=0.5), Parameter("scan_noise_sd_db", value=0.0)]))
    scans: list[WifiScan] = []
    truth_pub = graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    scan_sub = graph.probe.create_subscription(WifiScan, "/wifi/scan", scans.append, SENSOR_QOS)
    graph.spin_until(lambda: truth_pub.get_subscription_count() > 0 and scan_sub.get_publisher_count() > 0,
                     "wifi_sim's topics")
    for k in range(1, 61):                 # 1.2 s of ground truth at 50 Hz: scans at 0.02, 0.5 and 1.0 s
        truth_pub.publish(ground_truth(0.05 * k, 1.0, 0.0, round(0.02 * k, 2)))
    graph.spin_until(lambda: len(scans) >= 3, "3 scans on /wifi/scan")
    assert [round(s.header.stamp.sec + s.header.stamp.nanosec * 1e-9, 6) for s in scans] == [0.02, 0.5, 1.0]
    world = load_world(world_file)
    model = WifiModel(world.access_points, world.wall_segments(), world.wifi, world.wifi_seed)
    for scan, x in zip(scans, (0.05, 1.25, 2.5)):
        assert scan.interface == "sim"
        heard = {ap.bssid: ap.rssi_dbm for ap in scan.access_points}
        assert set(heard) == {"02:00:00:00:00:01", "02:00:00:00:00:02"}     # 900 m away at 0 dBm: below -90
        expected = model.mean_rss_dbm(np.array([[x, 1.0]]))[0]
        assert [heard["02:00:00:00:00:01"], heard["02:00:00:00:00:02"]] == pytest.approx(expected[:2])
    channel_36 = next(ap for ap in scans[0].access_points if ap.bssid.endswith("02"))
    assert channel_36.channel == 36 and channel_36.frequency_hz == pytest.approx(5.18e9)


def test_wall_tags_are_read_from_the_world_with_unit_normals_and_unique_ids(tmp_path: Path) -> None:
    path = tmp_path / "floor.yaml"
    path.write_text("name: floor\nwalls: [[0, 0.8, 8, 0.8]]\n"
                    "wall_tags:\n  - {id: 8, position: [7.0, 0.8], normal: [0, -2]}\n")
    world = load_world(path)
    assert world.wall_tags[0].tag_id == "8" and world.wall_tags[0].normal == (0.0, -1.0)
    path.write_text("name: floor\nwall_tags:\n  - {id: 8, position: [7.0, 0.8], normal: [0, 0]}\n")
    with pytest.raises(ConfigError, match=re.escape("wall_tags[0].normal")):
        load_world(path)
    path.write_text("name: floor\nwall_tags:\n  - {id: A, position: [1, 0], normal: [0, 1]}\n"
                    "  - {id: A, position: [2, 0], normal: [0, 1]}\n")
    with pytest.raises(ConfigError, match=re.escape("wall_tags[1].id: duplicate tag id 'A'")):
        load_world(path)
