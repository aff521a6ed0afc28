"""The agent's own deadman: the last process before the robot stops it when the server goes quiet.

``Deadman`` watches the drive commands passing through to the robot. While they say "move", each
must be followed by another within ``deadman_s``; when none comes (the server stalled, the uplink
froze) or the uplink drops, ``LocalGuard`` publishes a zero Twist on a rosbridge session of the
agent's own, which does not depend on the uplink or on the sessions it carries. When a frozen
uplink thaws, TCP delivers what waited in one burst: a drive command that arrives later than
``deadman_s`` after the server sent it (``Lateness``) is dropped, so the robot does not replay it.
"""

import asyncio
import json
import logging
import time
from urllib.parse import urlsplit

from . import ws

log = logging.getLogger("uplink_agent.safety")
ZERO_TWIST = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
RETRY_S = 0.5
REPEAT_S = 0.1  # the zero is sent twice, this far apart
# When the robot's rosapi cannot say; ROS 2 names it geometry_msgs/msg/Twist and takes this spelling too.
DEFAULT_TWIST_TYPE = "geometry_msgs/Twist"


async def topic_type(socket, topic, default=DEFAULT_TWIST_TYPE):
    """The type the robot gives ``topic`` (rosapi), so the stop is advertised as the robot spells it."""
    socket.send_frame(ws.TEXT, json.dumps({"op": "call_service", "id": "agent_topic_type",
                                           "service": "/rosapi/topic_type", "args": {"topic": topic}}).encode())
    while True:
        kind, payload = await socket.recv()
        if kind != ws.TEXT:
            continue
        try:
            frame = json.loads(payload.decode("utf-8"))
        except ValueError:
            continue
        if frame.get("op") == "service_response" and frame.get("id") == "agent_topic_type":
            values = frame.get("values")
            found = values.get("type") if frame.get("result") and isinstance(values, dict) else ""
            return found or default


def moving(twist):
    try:
        return any(float(part.get(axis) or 0.0) != 0.0
                   for part in (twist.get("linear") or {}, twist.get("angular") or {}) for axis in "xyz")
    except (AttributeError, TypeError, ValueError):
        return True  # a malformed drive command is treated as motion: it still needs its stop


class LocalGuard:
    """A rosbridge session of the agent's own with the drive topic advertised, reopened when it drops."""

    def __init__(self, rosbridge_url, topic):
        self.rosbridge_url = rosbridge_url
        self.topic = topic
        self.socket = None
        self.stops = 0
        self.twist_type = DEFAULT_TWIST_TYPE

    async def run(self):
        parts = urlsplit(self.rosbridge_url)
        host, port = parts.hostname or "127.0.0.1", parts.port or 9090
        while True:
            try:
                reader, writer = await asyncio.wait_for(asyncio.open_connection(host, port), 3)
                socket = await asyncio.wait_for(ws.handshake(reader, writer, parts.netloc, parts.path or "/"), 3)
                try:
                    twist_type = await asyncio.wait_for(topic_type(socket, self.topic), 3)
                except asyncio.TimeoutError:
                    twist_type = DEFAULT_TWIST_TYPE
                self.twist_type = twist_type
                socket.send_frame(ws.TEXT, json.dumps({"op": "advertise", "topic": self.topic,
                                                       "type": twist_type}).encode())
                self.socket = socket
                log.info("safety session open on %s", self.rosbridge_url)
                while True:
                    await socket.recv()
            except asyncio.CancelledError:
                raise
            except (OSError, asyncio.TimeoutError, ws.Closed, ws.HandshakeError) as exc:
                if self.socket is not None:
                    log.warning("safety session lost: %s", exc)
            finally:
                if self.socket is not None:
                    self.socket.close()
                self.socket = None
            await asyncio.sleep(RETRY_S)

    def publish_zero(self):
        frame = json.dumps({"op": "publish", "topic": self.topic, "msg": ZERO_TWIST}).encode()
        if self.socket is None:
            log.error("cannot send the zero Twist: the robot's rosbridge is not there")
            return False
        try:
            self.socket.send_frame(ws.TEXT, frame)
        except (ws.Closed, OSError):
            log.error("cannot send the zero Twist: the safety session just closed")
            return False
        self.stops += 1
        return True


class Lateness:
    """How much later than usual a server-stamped message arrives, without synchronised clocks.

    Arrival minus stamp is the clocks' offset plus the message's delay; its smallest value over the
    last ``window_s`` (the fastest trip lately, which also follows the clocks' slow drift) stands
    for the offset plus the usual delay, and each message's excess over it is how long it waited."""

    BUCKET_S = 5.0

    def __init__(self, window_s=60.0, clock=time.monotonic):
        self.clock = clock
        self.keep = max(1, int(window_s / self.BUCKET_S))
        self.buckets = []  # [bucket number, smallest arrival - stamp in it], oldest first
        self.baseline = None

    def late(self, stamp):
        now = self.clock()
        gap = now - stamp
        number = int(now / self.BUCKET_S)
        if self.buckets and self.buckets[-1][0] == number:
            self.buckets[-1][1] = min(self.buckets[-1][1], gap)
        else:
            self.buckets.append([number, gap])
            del self.buckets[:-self.keep]
        self.baseline = min(minimum for _, minimum in self.buckets)
        return gap - self.baseline


class Deadman:
    """Stops the robot when drive commands stop arriving while it was told to move."""

    def __init__(self, topic, deadman_s, guard, loop=None):
        self.topic = topic
        self.deadman_s = deadman_s
        self.guard = guard
        self.loop = loop or asyncio.get_event_loop()
        self.needle = json.dumps(topic).encode()
        self.driving = False
        self.last_drive = 0.0
        self.stale_dropped = 0
        self._timer = None

    def passes(self, frame, late=0.0):
        """Whether a rosbridge frame on its way to the robot goes on to it (``late``: seconds it waited
        beyond the usual, ``Lateness``). Only a stale drive command that says "move" is held back."""
        if self.needle not in frame:
            return True
        try:
            message = json.loads(frame.decode())
        except ValueError:
            return True
        if not isinstance(message, dict) or message.get("op") != "publish" or message.get("topic") != self.topic:
            return True
        go = moving(message.get("msg") or {})
        if go and late > self.deadman_s:
            if not self.stale_dropped % 50:
                log.warning("dropped a drive command %.2f s late (held up in the uplink)", late)
            self.stale_dropped += 1
            return False
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if go:
            self.driving = True
            self.last_drive = time.monotonic()
            self._timer = self.loop.call_later(self.deadman_s, self.stop, "no drive command for %g s" % self.deadman_s)
        else:
            self.driving = False
        return True

    def stop(self, why):
        """Send zero now if the robot may be moving (``why`` goes to the log)."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if not self.driving:
            return
        self.driving = False
        log.warning("stopping the robot: %s", why)
        if self.guard.publish_zero():
            self.loop.call_later(REPEAT_S, self._repeat_zero)

    def _repeat_zero(self):
        if not self.driving:  # unless driving resumed meanwhile
            self.guard.publish_zero()
