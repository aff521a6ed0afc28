"""The replay and incident API on a recorded session: the state at a moment is the latest value of each
topic at or before it, a window lists every change after it, frames and maps are served, a marked
moment is an incident, and its MCAP opens with the mcap reader."""

from __future__ import annotations

import io
import json
import math

import pytest
from mcap.reader import make_reader

from history.defaults import ensure_default_policies
from history.frames import write_frames
from history.incidents import incident_open
from history.models import Incident, Mode, TopicPolicy
from history.replay_modes import reached_mode
from history.storage import write_rows
from robot import interface as ri
from robot.models import AuditEntry

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

T0 = 1_780_000_000.0
MAP = {"info": {"width": 4, "height": 3, "resolution": 0.5,
                "origin": {"position": {"x": -1.0, "y": -1.0, "z": 0},
                           "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}},
       "data": [0, 0, 100, -1] * 3}


def pose(x: float, y: float, yaw: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def row(key: str, t: float, msg: dict) -> tuple[str, str, float, str]:
    topic = ri.topic(key)
    return (topic.name, topic.type, t, json.dumps(msg))


@pytest.fixture
def session(db, settings, tmp_path):
    """Ten minutes: the pose twice a second along x, states, a mode, battery, log lines, commands, frames."""
    settings.CAMERA_RECORD_DIR = tmp_path / "camera"
    settings.VAR_DIR = tmp_path
    rows = [row("map", T0, MAP)]
    rows += [row("robot_pose", T0 + i / 2, pose(i / 20, 1.0, 0.1)) for i in range(1200)]
    rows += [row("state_change", T0 + at, {"event": e, "from_system_state": "", "to_system_state": s})
             for at, e, s in ((1, "", "startup"), (100, "succeeded", "suspension"), (300, "manual_start", "manual"))]
    rows += [row("robot_mode", T0 + 299, {"data": "manual control"})]
    rows += [row("battery_soc", T0 + i * 10, {"data": 1 - i / 1000}) for i in range(60)]
    rows += [row("rosout", T0 + 200, {"level": 8, "name": "/motor", "msg": "overheated"})]
    write_rows(rows)
    AuditEntry.objects.create(username="olga", source="page", action="mode", params={"mode": "manual"}, ok=True)
    AuditEntry.objects.filter(username="olga").update(created=_utc(T0 + 298))
    write_frames([(T0 + i / 2, b"\xff\xd8frame%d\xff\xd9" % i, None) for i in range(1200)])


def _utc(t: float):
    from history.storage import utc

    return utc(t)


@pytest.mark.parametrize(("at", "state", "mode"), [
    (50.2, "startup", None), (250.0, "suspension", None), (450.9, "manual", "manual control")])
def test_the_state_at_a_moment_is_what_was_recorded_at_or_before_it(viewer_api, session, at, state, mode):
    body = viewer_api.get("/api/history/replay/state/", {"t": T0 + at}).json()
    # The pose moves 0.05 m along x every half second: the one recorded at or before the moment, not after.
    assert body["pose"][1] == pytest.approx(math.floor(at * 2) / 20, abs=1e-6)
    assert body["pose"][3] == pytest.approx(0.1, abs=1e-3)
    assert body["topics"]["state_change"]["msg"]["to_system_state"] == state
    assert (body["topics"].get("robot_mode") or {}).get("msg", {}).get("data") == mode
    assert body["frame"]["t"] <= T0 + at and T0 + at - body["frame"]["t"] < 0.5
    assert len(body["trail"]) == 120 or at < 60
    assert body["map"]["width"] == 4 and body["map"]["origin"]["x"] == -1.0
    if at > 300:
        assert [(c["who"], c["action"]) for c in body["commands"]] == [("olga", "mode")]
    if at > 200:
        assert body["log"][-1]["msg"] == "overheated" and body["log"][-1]["level"] == "ERROR"


def test_a_window_lists_every_change_in_order_with_its_frames(viewer_api, session):
    body = viewer_api.get("/api/history/replay/window/", {"start": T0 + 290, "end": T0 + 310}).json()
    assert len(body["poses"]) == 40 and body["poses"][0][0] > T0 + 290
    keys = [key for _, key, _ in body["changes"]]
    assert keys.index("robot_mode") < keys.index("state_change")
    assert len(body["frames"]) == 40
    assert [c["action"] for c in body["commands"]] == ["mode"]


def test_frames_and_maps_are_served(viewer_api, session):
    state = viewer_api.get("/api/history/replay/state/", {"t": T0 + 10.2}).json()
    frame = viewer_api.get(state["frame"]["url"])
    assert frame.status_code == 200 and b"".join(frame.streaming_content) == b"\xff\xd8frame20\xff\xd9"
    image = viewer_api.get(state["map"]["url"])
    assert image.status_code == 200 and b"".join(image.streaming_content)[:4] == b"\x89PNG"
    assert viewer_api.get("/api/history/frames/999999.jpg").status_code == 404


def test_a_sensitive_topic_is_left_out_for_a_viewer_but_not_an_operator(viewer_api, operator_api, session):
    TopicPolicy.objects.create(topic=ri.topic("robot_pose").name, mode=Mode.OFF, sensitive=True)
    seen = viewer_api.get("/api/history/replay/state/", {"t": T0 + 100}).json()
    assert seen["pose"] is None and "robot_pose" not in seen["topics"] and seen["trail"] == []
    assert operator_api.get("/api/history/replay/state/", {"t": T0 + 100}).json()["pose"] is not None


def test_a_bad_moment_is_refused(viewer_api, db):
    assert viewer_api.get("/api/history/replay/state/", {"t": "soon"}).status_code == 400
    for beyond in ("6.8e16", "1e400", "NaN", "-5"):  # past any date a datetime holds, not a number, before 1970
        assert viewer_api.get("/api/history/replay/state/", {"t": beyond}).status_code == 400, beyond
    assert viewer_api.get("/api/history/replay/window/", {"start": 10, "end": 5}).status_code == 400


def test_operators_mark_a_moment_viewers_may_not_and_only_admins_release(viewer_api, operator_api, admin_api, db):
    assert viewer_api.post("/api/history/incidents/", {"note": "x"}, format="json").status_code == 403
    marked = operator_api.post("/api/history/incidents/", {"note": "odd noise"}, format="json")
    assert marked.status_code == 201
    incident = marked.json()
    assert incident["kind"] == "manual" and incident["summary"] == "odd noise" and incident["held"]
    assert incident["end"] - incident["start"] == pytest.approx(90.0)
    listed = viewer_api.get("/api/history/incidents/").json()["incidents"]
    assert [i["id"] for i in listed] == [incident["id"]]
    url = f"/api/history/incidents/{incident['id']}/release/"
    assert operator_api.post(url).status_code == 403
    released = admin_api.post(url).json()
    assert not released["held"] and released["released_by"] == "ada"


def test_an_incident_exports_as_one_mcap_with_camera_and_pose(viewer_api, session):
    incident = incident_open(kind=Incident.Kind.ESTOP, t=T0 + 200, summary="E-STOP pressed", by="olga")
    response = viewer_api.get(f"/api/history/incidents/{incident.pk}/mcap/")
    assert response.status_code == 200

    reader = make_reader(io.BytesIO(response.content))
    summary = reader.get_summary()
    topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert topics["/camera"] == "foxglove.CompressedImage"
    assert topics["/pose"] == "foxglove.PoseInFrame"
    assert topics[ri.topic("robot_pose").name] == "geometry_msgs/Pose"
    times: dict[str, list[float]] = {}
    for _, channel, message in reader.iter_messages(log_time_order=True):
        times.setdefault(channel.topic, []).append(message.log_time / 1e9)
    for topic in ("/camera", "/pose"):
        assert times[topic][0] == pytest.approx(incident.start, abs=0.5)
        assert times[topic][-1] == pytest.approx(incident.end, abs=0.5)
    assert len(times["/camera"]) == 181  # every frame in the 90 s, two a second
    first = next(m for _, c, m in reader.iter_messages(topics=["/camera"]))
    assert json.loads(first.data)["format"] == "jpeg"


def test_replay_shows_the_mode_requested_here_and_the_one_reached_in_a_default_setup(viewer_api, db, settings):
    """The default MODE_COMMANDER=server publishes nothing on robot_mode: the request is the audited one."""
    settings.MODE_COMMANDER = "server"
    ensure_default_policies()
    recorded = set(TopicPolicy.objects.exclude(mode=Mode.OFF).values_list("topic", flat=True))
    assert {ri.topic("robot_mode").name, ri.topic("state_change").name} <= recorded
    changes = ((1, "succeeded", "startup", "suspension"), (10, "aborted", "suspension", "suspension"),
               (11, "behaviour_start", "suspension", "idle"), (40, "manual_start", "suspension", "manual"))
    write_rows([row("state_change", T0 + at, {"event": e, "from_system_state": a, "to_system_state": b})
                for at, e, a, b in changes])
    for at, action, params, ok in ((11.5, "mode", {"mode": "behaviour"}, True), (30, "mode", {"mode": "manual"}, False),
                                   (60, "estop", {}, True)):
        entry = AuditEntry.objects.create(username="otto", source="page", action=action, params=params, ok=ok,
                                          outcome="" if ok else "step 2 failed")
        AuditEntry.objects.filter(pk=entry.pk).update(created=_utc(T0 + at))

    def mode_at(at: float) -> tuple:
        topics = viewer_api.get("/api/history/replay/state/", {"t": T0 + at}).json()["topics"]
        request, reached = topics.get("mode_request"), topics.get("mode_reached")
        return ((request["msg"]["mode"], request["msg"]["by"], request["msg"]["ok"]) if request else None,
                (reached["msg"]["mode"], reached["msg"]["state"]) if reached else None)

    assert mode_at(5) == (None, (ri.Mode.STOP.short, "suspension"))
    assert mode_at(20) == (("behaviour", "otto", True), ("behaviour", "idle"))
    assert mode_at(35) == (("manual", "otto", False), ("behaviour", "idle"))
    assert mode_at(50) == (("manual", "otto", False), ("manual", "manual"))
    assert mode_at(70) == (("stop", "otto", True), ("manual", "manual"))

    # A player runs through the same, in time order.
    changes = viewer_api.get("/api/history/replay/window/", {"start": T0 + 5, "end": T0 + 65}).json()["changes"]
    modes = [(round(t - T0, 1), key, msg.get("mode")) for t, key, msg in changes if key.startswith("mode_")]
    assert modes == [(10, "mode_reached", "stop"), (11, "mode_reached", "behaviour"),
                     (11.5, "mode_request", "behaviour"), (30, "mode_request", "manual"),
                     (40, "mode_reached", "manual"), (60, "mode_request", "stop")]


@pytest.mark.parametrize(("state", "mode"), [
    ("suspension", "stop"), ("demo", "demo"), ("manual", "manual"), ("idle", "behaviour"), ("sleeping", "behaviour"),
    ("navigation_planning", "behaviour"), ("startup", None), ("", None)])
def test_the_mode_reached_is_the_mode_whose_state_the_robot_is_in(state, mode):
    assert reached_mode(state) == mode
