"""A slow tool keeps at most its ``queue_length`` of a topic's messages (the oldest dropped, as
rosbridge's queue does) and never holds back another tool: a real client that stops reading, beside
an unmodified roslibpy one, against the product driving the simulator."""

from __future__ import annotations

import json
import os
import socket
import urllib.request
from urllib.parse import urlsplit

import roslibpy
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from robot import interface as ri
from tests.frontdoor.conftest import ros_for, ticket_url
from tests.sim.support import Inbox

TOPIC = ri.topic("state_transitions").name  # every message (no pace), std_msgs/String
QUEUE = 5
COUNT = 1200
PAD = os.urandom(5000).hex()  # 10 kB: the kernel takes some MB for a stalled reader, a small part of the burst


def publish(stack, data: str) -> None:
    body = json.dumps({"topic": TOPIC, "msg": {"data": data}}).encode()
    request = urllib.request.Request(f"http://127.0.0.1:{stack.video_port}/sim/publish", data=body,
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=10) as res:
        res.read()


def numbered(data: str) -> int | None:
    return int(data[2:8]) if data.startswith("q-") else None


def test_a_slow_client_keeps_only_its_queue_length_and_never_holds_back_another(stack):
    url = ticket_url(stack, "vera")
    parts = urlsplit(url)
    raw = socket.socket()
    raw.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a client that reads little and late
    raw.connect((parts.hostname, parts.port))
    fast = ros_for(stack, "vera")
    try:
        with connect(url, sock=raw, open_timeout=20, max_size=None, compression=None, max_queue=1) as slow:
            slow.send(json.dumps({"op": "subscribe", "id": "s", "topic": TOPIC, "queue_length": QUEUE}))
            got = Inbox()
            roslibpy.Topic(fast, TOPIC, "std_msgs/String").subscribe(got)
            publish(stack, "warm-up")
            got.wait_for(lambda m: m["data"] == "warm-up", timeout=30, what="the subscription under way")
            for i in range(COUNT):
                publish(stack, f"q-{i:06d}{PAD}")
            # The other client has every message while the slow one has not read a single one.
            got.wait_for(lambda m: numbered(m["data"]) == COUNT - 1, timeout=60, what="the last message, fast")
            seen: list[int] = []
            try:
                while True:
                    frame = json.loads(slow.recv(timeout=3))
                    if frame.get("op") == "publish" and (n := numbered(frame["msg"]["data"])) is not None:
                        seen.append(n)
            except (TimeoutError, ConnectionClosed):
                pass
    finally:
        fast.close()
    fast_seen = [n for m in got.items if (n := numbered(m["data"])) is not None]
    assert fast_seen == list(range(COUNT))  # the other client lost nothing and waited for nobody
    # What the connection had taken before the client stalled arrives in order; of the rest, at most
    # the one on its way out then and the newest QUEUE were kept.
    prefix = next((k for k, n in enumerate(seen) if n != k), len(seen))
    assert seen[-QUEUE:] == list(range(COUNT - QUEUE, COUNT)), seen[-QUEUE - 2:]
    assert len(seen) - prefix <= QUEUE + 1, (prefix, seen[prefix:prefix + 10])
    assert prefix < COUNT // 2  # it was really slow: most of the burst never reached it
