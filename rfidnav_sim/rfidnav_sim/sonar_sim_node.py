"""sonar_sim: paper 004's seven ultrasonic rangefinders, each on /sonar/<name> (sensor_msgs/Range).

Sweeps are driven by /sim/ground_truth, like the reader's rounds: the first pose at or after each sweep's due time
(``1/rate_hz`` apart in sim time); the model (rfidnav_sim.sonar_model) casts each cone's rays against the world's
walls, vectorized, and reports the nearest echo with noise, +inf when nothing echoes within range.
"""

from __future__ import annotations

from typing import Any

from nav_msgs.msg import Odometry
from sensor_msgs.msg import Range

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, input_drops, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import publish_static_frames
from rfidnav_sim.conversions import ground_truth_pose
from rfidnav_sim.parameters import SonarParameters
from rfidnav_sim.sonar_model import PAPER_LAYOUT
from rfidnav_sim.world import load_world


class SonarSimNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("sonar_sim", **node_options)
        self.params: SonarParameters = declare_parameters(self, SonarParameters)
        world = load_world(self.params.world_file)
        self.world_frame = world.frame_id
        self.drops = input_drops(self)
        self.sonar = self.params.sensor(world)
        publish_static_frames(self, self.params.frames())
        self.publishers_by_name = {r.name: self.create_publisher(Range, f"sonar/{r.name}", SENSOR_QOS)
                                   for r in PAPER_LAYOUT}
        self.create_subscription(Odometry, "sim/ground_truth", self.on_ground_truth, SENSOR_QOS)
        self.get_logger().info(f"{len(PAPER_LAYOUT)} rangefinders, {len(world.walls)} walls, "
                               f"{self.params.rate_hz:g} sweeps/s")

    def on_ground_truth(self, msg: Odometry) -> None:
        pose = ground_truth_pose(msg, self.world_frame, self.drops)
        if pose is None:
            return
        readings = self.sonar.sample(pose, seconds_of(msg.header.stamp))
        if readings is None:
            return
        for rangefinder in PAPER_LAYOUT:
            reading = Range(radiation_type=Range.ULTRASOUND, field_of_view=2.0 * rangefinder.beam_half_angle_rad,
                            min_range=rangefinder.min_range_m, max_range=rangefinder.max_range_m,
                            range=readings[rangefinder.name])
            reading.header.stamp = msg.header.stamp
            reading.header.frame_id = self.params.frame_prefix + rangefinder.name
            self.publishers_by_name[rangefinder.name].publish(reading)


def main(args: list[str] | None = None) -> int:
    return run_node(SonarSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
