"""``./rfidnav view RUN_OR_BAG``: a recorded bag in Foxglove over the WebSocket protocol, with its timeline.

foxglove-sdk's server with the PlaybackControl capability (its ``playback_time_range``: the bag's first and last
message) and the Time capability: Foxglove shows the bag's time span in its playback bar, and its play, pause,
seek and speed controls arrive here as PlaybackControlRequests, answered with the resulting PlaybackState.
Messages go out in log-time order, paced at the playback speed, as the CDR bytes the bag holds on channels
whose schemas are the ros2msg definitions of the bag's MCAP schema records (``live_view.cdr_channel``); the
server's time is broadcast about 30 times a wall second while playing, so the timeline moves through gaps too.

Playback starts at the bag's beginning when a client first subscribes to a channel (a viewer that sends no
playback requests still sees the run), and otherwise follows the client: a seek re-reads the bag from the time
asked and first re-sends, for each latched topic (markers, maps), its last message before that time, which a
viewer that cleared its panels on the seek would otherwise never see again. Play at the end starts over.

No rclpy: the bag is read with ``bags.read_raw``, so this runs without a ROS graph.
"""

from __future__ import annotations

import math
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import foxglove
from foxglove.websocket import (
    Capability,
    ChannelView,
    Client,
    PlaybackCommand,
    PlaybackControlRequest,
    PlaybackState,
    PlaybackStatus,
    ServerListener,
    WebSocketServer,
)

from rfidnav_bag.bags import BagInfo, RawMessage, bag_info, read_raw
from rfidnav_bag.errors import BagError
from rfidnav_bag.live_view import DEFAULT_HOST, cdr_channel, ws_url

__all__ = ["BagPlayer", "PlaybackClock", "serve_bag"]

TIME_BROADCAST_S = 1.0 / 30.0   # how often the server's time goes out while playing (wall seconds)
IDLE_WAIT_S = 0.1               # longest wait between looks at the playback state
MIN_SPEED = 0.01                # Foxglove's slowest is 0.01x; a speed <= 0 or NaN would stall the clock
REQUEST_TIMEOUT_S = 5.0         # a playback request the loop has not answered by then gets no answer


@dataclass
class PlaybackClock:
    """Bag time as a function of wall time (seconds of ``time.monotonic``) while playing, at a speed; pure.

    ``position_ns`` is the bag time at wall time ``anchor_s``; paused, the clock holds ``position_ns``."""

    start_ns: int
    end_ns: int
    speed: float = 1.0
    position_ns: int = 0
    anchor_s: float | None = None   # None: paused

    def __post_init__(self) -> None:
        self.speed = clamped_speed(self.speed)
        self.position_ns = min(max(self.position_ns, self.start_ns), self.end_ns)

    @property
    def playing(self) -> bool:
        return self.anchor_s is not None

    def now_ns(self, wall_s: float) -> int:
        if self.anchor_s is None:
            return self.position_ns
        return min(self.end_ns, self.position_ns + round((wall_s - self.anchor_s) * self.speed * 1e9))

    def play(self, wall_s: float) -> None:
        if self.anchor_s is None:
            self.anchor_s = wall_s

    def pause(self, wall_s: float) -> None:
        self.position_ns, self.anchor_s = self.now_ns(wall_s), None

    def seek(self, bag_ns: int, wall_s: float) -> None:
        self.position_ns = min(max(bag_ns, self.start_ns), self.end_ns)
        if self.anchor_s is not None:
            self.anchor_s = wall_s

    def set_speed(self, speed: float, wall_s: float) -> None:
        if self.anchor_s is not None:   # what played so far at the old speed stays played
            self.position_ns, self.anchor_s = self.now_ns(wall_s), wall_s
        self.speed = clamped_speed(speed)

    def wall_until(self, bag_ns: int, wall_s: float) -> float:
        """Wall seconds until the clock reaches ``bag_ns`` (0 if it has; infinite while paused)."""
        ahead_ns = bag_ns - self.now_ns(wall_s)
        if ahead_ns <= 0:
            return 0.0
        return math.inf if self.anchor_s is None else ahead_ns / (self.speed * 1e9)


def clamped_speed(speed: float) -> float:
    return speed if math.isfinite(speed) and speed >= MIN_SPEED else MIN_SPEED


@dataclass
class _Request:
    """What a server callback asks of the loop: a playback request (answered through ``answer``), or None for
    a client's subscription."""

    control: PlaybackControlRequest | None
    answer: queue.Queue[PlaybackState] = field(default_factory=lambda: queue.Queue(maxsize=1))


class BagPlayer:
    """Plays a bag's messages on their channels as the clock passes their log times, on the caller's thread
    (:meth:`run`). The server's callbacks only queue requests and wait for the answer: the loop takes them
    between two messages, so a fast playback never keeps a request waiting and no state is shared."""

    def __init__(self, bag: Path, info: BagInfo, channels: dict[str, foxglove.Channel], speed: float) -> None:
        self.bag = bag
        self.channels = channels
        self.latched = tuple(t.name for t in info.topics if t.latched and t.name in channels)
        self.clock = PlaybackClock(info.start_ns, info.end_ns, speed, info.start_ns)
        self.status = PlaybackStatus.Paused
        self.requests: queue.Queue[_Request] = queue.Queue()
        self.started = False          # playback starts once, when a client first subscribes
        self.time_due = True          # the server's time changed without being broadcast (seek, pause)
        self.last_time_broadcast = -math.inf
        self.messages: Iterator[RawMessage] = iter(())
        self.pending: RawMessage | None = None
        self.played = 0
        self.rewind(info.start_ns)

    # -- reading -------------------------------------------------------------------------------------

    def rewind(self, bag_ns: int) -> None:
        """Read on from ``bag_ns``; re-send each latched topic's last message before it."""
        self.messages = read_raw(self.bag, self.channels.keys(), start_ns=bag_ns)
        self.pending = None
        if bag_ns <= self.clock.start_ns or not self.latched:
            return
        last: dict[str, RawMessage] = {}
        for message in read_raw(self.bag, self.latched):
            if message.timestamp_ns >= bag_ns:
                break
            last[message.topic] = message
        for message in sorted(last.values(), key=lambda m: m.timestamp_ns):
            self.channels[message.topic].log(message.data, log_time=message.timestamp_ns)

    # -- the server's callbacks (its threads) ---------------------------------------------------------

    def on_subscribe(self) -> None:
        self.requests.put(_Request(None))

    def on_control(self, control: PlaybackControlRequest) -> PlaybackState | None:
        request = _Request(control)
        self.requests.put(request)
        try:
            return request.answer.get(timeout=REQUEST_TIMEOUT_S)
        except queue.Empty:   # the loop has stopped: the client gets no answer, as from a server gone
            return None

    # -- the loop (the caller's thread) ---------------------------------------------------------------

    def run(self, server: WebSocketServer, stop: threading.Event) -> None:
        while not stop.is_set():
            now = time.monotonic()
            if self.status != PlaybackStatus.Playing:
                self.broadcast_time(server, now)
                self.take_requests(server, IDLE_WAIT_S)
                continue
            message = self.pending if self.pending is not None else next(self.messages, None)
            if message is None:
                self.end(server, now)
                continue
            wait_s = self.clock.wall_until(message.timestamp_ns, now)
            if wait_s > 0.0:
                self.pending = message
                self.broadcast_time(server, now)
                self.take_requests(server, min(wait_s, TIME_BROADCAST_S))
                continue
            self.pending = None
            self.channels[message.topic].log(message.data, log_time=message.timestamp_ns)
            self.played += 1
            self.broadcast_time(server, now)
            self.take_requests(server, 0.0)

    def take_requests(self, server: WebSocketServer, wait_s: float) -> None:
        """Handle the queued requests, waiting up to ``wait_s`` for the first."""
        try:
            request = self.requests.get(timeout=wait_s) if wait_s > 0.0 else self.requests.get_nowait()
        except queue.Empty:
            return
        while True:
            now = time.monotonic()
            if request.control is not None:
                request.answer.put(self.control(request.control, now))
            elif not self.started:
                self.play(now)
                server.broadcast_playback_state(self.state(now))
            try:
                request = self.requests.get_nowait()
            except queue.Empty:
                return

    def control(self, request: PlaybackControlRequest, now: float) -> PlaybackState:
        did_seek = request.seek_time is not None
        if request.seek_time is not None:
            self.seek(request.seek_time, now)
        self.clock.set_speed(request.playback_speed, now)
        if request.playback_command == PlaybackCommand.Play:
            if self.status == PlaybackStatus.Ended and not did_seek:
                self.seek(self.clock.start_ns, now)   # play at the end: from the beginning again
                did_seek = True
            self.play(now)
        elif request.playback_command == PlaybackCommand.Pause:
            self.pause(now)
        return self.state(now, did_seek, request.request_id)

    # -- state changes --------------------------------------------------------------------------------

    def play(self, now: float) -> None:
        self.started = True
        self.clock.play(now)
        self.status = PlaybackStatus.Playing

    def pause(self, now: float) -> None:
        self.clock.pause(now)
        if self.status != PlaybackStatus.Ended:
            self.status = PlaybackStatus.Paused
        self.time_due = True

    def seek(self, bag_ns: int, now: float) -> None:
        self.clock.seek(bag_ns, now)
        if self.status == PlaybackStatus.Ended:
            self.status = PlaybackStatus.Paused
        self.rewind(self.clock.position_ns)
        self.time_due = True

    def end(self, server: WebSocketServer, now: float) -> None:
        self.clock.seek(self.clock.end_ns, now)
        self.pause(now)
        self.status = PlaybackStatus.Ended
        self.broadcast_time(server, now)
        server.broadcast_playback_state(self.state(now))

    def state(self, now: float, did_seek: bool = False, request_id: str | None = None) -> PlaybackState:
        return PlaybackState(status=self.status, current_time=self.clock.now_ns(now),
                             playback_speed=self.clock.speed, did_seek=did_seek, request_id=request_id)

    def broadcast_time(self, server: WebSocketServer, now: float) -> None:
        if self.time_due or (self.status == PlaybackStatus.Playing
                             and now - self.last_time_broadcast >= TIME_BROADCAST_S):
            server.broadcast_time(self.clock.now_ns(now))
            self.last_time_broadcast, self.time_due = now, False


class _Listener(ServerListener):
    def __init__(self, player: BagPlayer) -> None:
        self.player = player

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.player.on_subscribe()

    def on_playback_control_request(self, playback_control_request: PlaybackControlRequest) -> PlaybackState | None:
        return self.player.on_control(playback_control_request)


def serve_bag(bag: Path, port: int, host: str = DEFAULT_HOST, speed: float = 1.0,
              announce: Callable[[str], None] = print, stop: threading.Event | None = None) -> int:
    """Serve ``bag`` (a rosbag2 directory) until ``stop`` is set or Ctrl-C; 0 then. A missing, unreadable or
    empty bag is a BagError; a port it cannot bind a BagError naming it."""
    info = bag_info(bag)
    for note in info.notes:   # a bag that was not finalised: what was lost
        print(f"rfidnav view: {bag}: {note}", file=sys.stderr)
    if info.message_count == 0:
        raise BagError(f"{bag}: the bag holds no messages: nothing to play")
    context = foxglove.Context()
    channels: dict[str, foxglove.Channel] = {}
    for topic in info.topics:
        try:
            channels[topic.name] = cdr_channel(topic.name, topic.msgtype, context)
        except BagError as error:
            print(f"rfidnav view: not serving {topic.name}: {error}", file=sys.stderr)
    player = BagPlayer(bag, info, channels, speed)
    try:
        server = foxglove.start_server(
            name=f"rfidnav view {bag}", host=host, port=port, capabilities=[Capability.Time],
            playback_time_range=(info.start_ns, info.end_ns), server_listener=_Listener(player), context=context)
    except RuntimeError as error:   # the SDK's error for an address it cannot bind
        raise BagError(f"cannot serve {bag} on {host}:{port}: {error}") from error
    announce(f"serving {bag} ({len(channels)} topics, {info.duration_s:.1f} s) at {ws_url(host, server.port)} "
             "(Foxglove: Open connection -> Foxglove WebSocket); Ctrl-C to stop")
    stop = stop or threading.Event()
    # Ctrl-C sets the event the loop looks at between messages (at least every IDLE_WAIT_S) instead of raising
    # wherever the main thread is: an interrupt inside a request hand-over or the SDK's call could leave the
    # server's callback thread waiting, and server.stop() with it (a view that would not end after SIGINT).
    interrupted = signal.signal(signal.SIGINT, lambda _signum, _frame: stop.set()) \
        if threading.current_thread() is threading.main_thread() else None
    try:
        player.run(server, stop)
    finally:
        if interrupted is not None:
            signal.signal(signal.SIGINT, interrupted)
        server.stop()
    return 0
