"""location_server that takes 0.3 s of wall time over every answer: a deliberately slow server, run by the tests as
a scenario ``command``, to show that the stepped clock waits for its answers (SteppedNode.call_service)."""

from __future__ import annotations

import time

from rfidnav_common.ros import run_node
from rfidnav_localization.location_server_node import LocationServerNode
from rfidnav_msgs.srv import GetTagMap, Locate

DELAY_S = 0.3


class SlowLocationServer(LocationServerNode):
    def on_locate(self, request: Locate.Request, response: Locate.Response) -> Locate.Response:
        time.sleep(DELAY_S)   # the slowness under test, not a wait for anything
        return super().on_locate(request, response)

    def on_tag_map(self, request: GetTagMap.Request, response: GetTagMap.Response) -> GetTagMap.Response:
        time.sleep(DELAY_S)
        return super().on_tag_map(request, response)


if __name__ == "__main__":
    raise SystemExit(run_node(SlowLocationServer))
