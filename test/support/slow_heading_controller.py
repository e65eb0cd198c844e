"""heading_controller that takes 10 ms of wall time more over every round: a deliberately slow participant of the
stepped clock, run by the tests as a scenario ``command`` with ``stepped: true``. A round of line_follow_0 at
--rtf max takes about 4 ms on two idle cores: the controller is then what the clock waits for."""

from __future__ import annotations

import time

from rfidnav_common.ros import run_node
from rfidnav_control.heading_controller_node import HeadingControllerNode
from rfidnav_msgs.msg import TagReadArray

DELAY_S = 0.01


class SlowHeadingController(HeadingControllerNode):
    def on_reads(self, msg: TagReadArray) -> None:
        time.sleep(DELAY_S)   # the slowness under test, not a wait for anything
        super().on_reads(msg)


if __name__ == "__main__":
    raise SystemExit(run_node(SlowHeadingController))
