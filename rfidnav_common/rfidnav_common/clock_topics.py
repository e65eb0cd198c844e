"""The stepped clock's topics for recovering lost messages (rfidnav_common.stepped_node), named here for pure code too:
the run plan leaves them out of the bag (no rclpy).

They are not under /sim: every participant subscribes to them, navigation nodes included, and no navigation node
may subscribe to anything under /sim (the simulator's ground truth; test_graph.py checks the graph)."""

RESEND_REQUEST_TOPIC = "/stepped_clock/resend_request"   # the clock source's requests (rfidnav_msgs/StepResend)
RESEND_TOPIC = "/stepped_clock/resend"                   # the producers' messages sent again
RESEND_TOPICS = (RESEND_REQUEST_TOPIC, RESEND_TOPIC)
