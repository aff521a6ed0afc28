"""The video port: a web_video_server look-alike, plus the simulator's introspection endpoints."""

from __future__ import annotations

import http.client
import io
import json
import urllib.error
import urllib.request

import pytest
from PIL import Image

from robot import interface as ri
from tests.sim.support import on_topic, wait_until


def get(sim, path: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(f"{sim.video_url}{path}", timeout=5) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers.get("Content-Type", ""), e.read()


def post(sim, path: str, body: dict) -> tuple[int, dict]:
    req = urllib.request.Request(f"{sim.video_url}{path}", data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def test_it_serves_a_jpeg_snapshot(sim):
    status, ctype, body = get(sim, "/snapshot?topic=/videostream")
    assert (status, ctype) == (200, "image/jpeg")
    img = Image.open(io.BytesIO(body))
    assert img.format == "JPEG" and img.size == (640, 480)


def test_it_streams_mjpeg_frames_and_survives_a_client_hanging_up(sim):
    conn = http.client.HTTPConnection(sim.host, sim.video_port, timeout=5)
    conn.request("GET", "/stream?topic=/videostream&type=mjpeg&quality=80")
    resp = conn.getresponse()
    assert resp.status == 200
    assert resp.getheader("Content-Type") == "multipart/x-mixed-replace;boundary=boundarydonotcross"
    frames = []
    while len(frames) < 2:
        line = resp.fp.readline()
        if line.lower().startswith(b"content-length:"):
            length = int(line.split(b":")[1])
            resp.fp.readline()  # X-Timestamp
            resp.fp.readline()  # blank line
            frames.append(resp.fp.read(length))
    assert all(f[:2] == b"\xff\xd8" for f in frames)
    conn.close()
    status, _, _ = get(sim, "/snapshot?topic=/videostream")
    assert status == 200


def test_it_answers_404_for_an_unknown_path(sim):
    assert get(sim, "/nope")[0] == 404


def test_it_reports_subscriptions_received_messages_and_state_over_http(sim, raw_client):
    raw = raw_client()
    cmd_vel = ri.topic("cmd_vel").name
    raw.send({"op": "subscribe", "id": "p", "topic": ri.topic("robot_pose").name, "type": "geometry_msgs/Pose"})
    for x in (0.1, 0.2, 0.3):
        raw.send({"op": "publish", "topic": cmd_vel, "msg": {"linear": {"x": x}}})
    wait_until(lambda: sim.received_count(cmd_vel) == 3)
    status, ctype, body = get(sim, "/sim/introspect")
    snap = json.loads(body)
    assert status == 200 and ctype == "application/json"
    assert snap["subscriptions"][ri.topic("robot_pose").name] == 1
    assert snap["received_counts"][cmd_vel] == 3
    assert snap["clients"] == 1
    assert {"pose", "battery", "smach_state", "emotion", "motors", "tts_queue", "goal"} <= set(snap["state"])
    _, _, body = get(sim, f"/sim/received?topic={cmd_vel}&last=2")
    received = json.loads(body)
    assert received["count"] == 3
    assert [m["msg"]["linear"]["x"] for m in received["messages"]] == [0.2, 0.3]
    assert all(m["t"] > 1_600_000_000 for m in received["messages"])


def test_it_publishes_injected_bursts_to_subscribers(sim, raw_client):
    raw = raw_client()
    raw.send({"op": "subscribe", "id": "c", "topic": "/bench/chatter", "type": "std_msgs/String"})
    wait_until(lambda: sim.subscription_count("/bench/chatter") == 1)
    status, reply = post(sim, "/sim/publish", {"topic": "/bench/chatter", "msg": {"data": "x"}, "count": 5})
    assert (status, reply) == (200, {"published": 5})
    assert len(raw.collect(0.5, on_topic("/bench/chatter"))) == 5


@pytest.mark.parametrize("body", [{"msg": {}}, {"topic": ri.topic("cmd_vel").name, "msg": {"data": 1}}])
def test_it_refuses_a_malformed_injection(sim, body):
    status, reply = post(sim, "/sim/publish", body)
    assert status == 400 and reply["error"]
