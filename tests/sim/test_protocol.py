"""The simulator speaks rosbridge v2 the way the ROS 1 server does (ROBOT_INTERFACE.md, wire format)."""

from __future__ import annotations

import math
import time

from robot import interface as ri
from tests.sim.support import on_topic, wait_until

ROSOUT = ri.topic("rosout").name
CMD_VEL = ri.topic("cmd_vel").name
CHATTER = "/sim_test/chatter"  # a topic only the tests use


def _bridge_error(text: str):
    return lambda f: (f.get("op") == "publish" and f["topic"] == ROSOUT and f["msg"]["level"] == 8
                      and f["msg"]["name"] == "/rosbridge_websocket" and text in f["msg"]["msg"])


def _listen_rosout(raw):
    raw.send({"op": "subscribe", "id": "sub_rosout", "topic": ROSOUT, "type": "rosgraph_msgs/Log"})


def _inject(sim, topic, values):
    def run():
        for v in values:
            sim.robot.publish_external(topic, {"data": v})
    sim.call(run)


def test_it_drops_a_frame_with_an_unknown_op_logs_it_and_keeps_the_socket_open(sim, raw_client):
    raw = raw_client()
    _listen_rosout(raw)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    raw.send({"op": "frobnicate", "id": "x1"})
    err = raw.expect(_bridge_error("Unknown operation: frobnicate"))
    assert "[id: x1]" in err["msg"]["msg"]
    reply = raw.call("/rosapi/get_time", cid="after")
    assert reply["result"] is True
    assert abs(reply["values"]["time"]["secs"] - time.time()) < 5


def test_it_never_sends_status_frames_for_bad_frames(sim, raw_client):
    raw = raw_client()
    _listen_rosout(raw)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    raw.send("{not json")
    raw.send({"no_op": 1})
    raw.send({"op": "publish", "id": "pub_1", "topic": CMD_VEL, "msg": {"data": 1}})
    raw.send({"op": "subscribe", "id": "s1", "topic": CHATTER, "type": "std_msgs/String", "throttle_rate": 1.5})
    raw.expect(_bridge_error("Expected field throttle_rate"))
    frames = raw.collect(0.3)
    assert all(f["op"] != "status" for f in frames)
    assert not raw.closed.is_set()


def test_it_drops_a_publish_with_an_unknown_field_and_logs_it_like_rosbridge(sim, raw_client):
    raw = raw_client()
    _listen_rosout(raw)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    raw.send({"op": "publish", "id": "pub_1", "topic": CMD_VEL, "msg": {"data": 1}})
    err = raw.expect(_bridge_error("does not have a field"))
    assert err["msg"]["msg"].endswith(
        "[id: pub_1] publish: Message type geometry_msgs/Twist does not have a field data")
    assert err["msg"]["msg"].startswith("[Client ")
    assert sim.received_count(CMD_VEL) == 0


def test_it_rejects_a_float_for_an_int_field_but_takes_an_int_for_a_float(sim, raw_client):
    raw = raw_client()
    _listen_rosout(raw)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    topic = ri.topic("battery_recharge_state").name
    raw.send({"op": "publish", "id": "p_float", "topic": topic, "msg": {"data": 1.5}})
    raw.expect(_bridge_error("requires a int8"))
    assert sim.received_count(topic) == 0
    raw.send({"op": "publish", "id": "p_int", "topic": CMD_VEL,
              "msg": {"linear": {"x": 1}, "angular": {"z": 0}}})
    wait_until(lambda: sim.received_count(CMD_VEL) == 1)
    msg = sim.received(CMD_VEL)[0]
    assert msg["linear"] == {"x": 1.0, "y": 0.0, "z": 0.0}  # missing fields take defaults
    assert isinstance(msg["linear"]["x"], float)


def test_it_drops_a_float_throttle_rate_but_honours_an_int_one(sim, raw_client):
    raw = raw_client()
    raw.send({"op": "subscribe", "id": "bad", "topic": CHATTER, "type": "std_msgs/String", "throttle_rate": 10.5})
    raw.send({"op": "subscribe", "id": "good", "topic": "/other_chatter", "type": "std_msgs/String",
              "throttle_rate": 10})
    wait_until(lambda: sim.subscription_count("/other_chatter") == 1)
    assert sim.subscription_count(CHATTER) == 0


def test_it_throttles_a_subscription(sim, raw_client):
    fast, slow = raw_client(), raw_client()
    fast.send({"op": "subscribe", "id": "f", "topic": CHATTER, "type": "std_msgs/String"})
    slow.send({"op": "subscribe", "id": "s", "topic": CHATTER, "type": "std_msgs/String", "throttle_rate": 5000})
    wait_until(lambda: sim.subscription_count(CHATTER) == 2)
    _inject(sim, CHATTER, [str(i) for i in range(20)])
    assert len(fast.collect(0.5, on_topic(CHATTER))) == 20
    got = slow.collect(0.2, on_topic(CHATTER))
    assert [f["msg"]["data"] for f in got] == ["0"]


def test_it_keeps_only_the_newest_messages_with_a_queue_length(sim, raw_client):
    raw = raw_client()
    raw.send({"op": "subscribe", "id": "q", "topic": CHATTER, "type": "std_msgs/String", "queue_length": 2,
              "throttle_rate": 100})
    wait_until(lambda: sim.subscription_count(CHATTER) == 1)
    _inject(sim, CHATTER, [str(i) for i in range(10)])
    got = raw.collect(0.6, on_topic(CHATTER))
    assert [f["msg"]["data"] for f in got] == ["8", "9"]


def test_it_resends_the_latched_map_to_each_new_subscriber(sim, raw_client):
    topic = ri.topic("map").name
    a, b = raw_client(), raw_client()
    a.send({"op": "subscribe", "id": "m1", "topic": topic, "type": "nav_msgs/OccupancyGrid"})
    first = a.expect(on_topic(topic))["msg"]
    b.send({"op": "subscribe", "id": "m2", "topic": topic, "type": "nav_msgs/OccupancyGrid"})
    b.expect(on_topic(topic))
    a.send({"op": "subscribe", "id": "m3", "topic": topic, "type": "nav_msgs/OccupancyGrid"})
    a.expect(on_topic(topic))
    assert len(first["data"]) == first["info"]["width"] * first["info"]["height"]
    assert not a.collect(0.3, on_topic(topic))  # latched, not periodic


def test_it_stops_sending_after_unsubscribe(sim, raw_client):
    raw = raw_client()
    for sid in ("a", "b"):
        raw.send({"op": "subscribe", "id": sid, "topic": CHATTER, "type": "std_msgs/String"})
    wait_until(lambda: sim.subscription_count(CHATTER) == 2)
    raw.send({"op": "unsubscribe", "id": "a", "topic": CHATTER})
    wait_until(lambda: sim.subscription_count(CHATTER) == 1)
    _inject(sim, CHATTER, ["still"])
    raw.expect(on_topic(CHATTER))
    raw.send({"op": "subscribe", "id": "c", "topic": CHATTER, "type": "std_msgs/String"})
    wait_until(lambda: sim.subscription_count(CHATTER) == 2)
    raw.send({"op": "unsubscribe", "topic": CHATTER})  # no id: all of this client's subscriptions
    wait_until(lambda: sim.subscription_count(CHATTER) == 0)
    _inject(sim, CHATTER, ["gone"])
    assert not raw.collect(0.3, on_topic(CHATTER))


def test_it_drops_a_clients_subscriptions_when_it_disconnects(sim, raw_client):
    raw = raw_client()
    raw.send({"op": "subscribe", "id": "p", "topic": ri.topic("robot_pose").name, "type": "geometry_msgs/Pose"})
    wait_until(lambda: sim.subscription_count(ri.topic("robot_pose").name) == 1)
    raw.close()
    wait_until(lambda: sim.subscription_count(ri.topic("robot_pose").name) == 0)


def test_it_publishes_a_latched_client_count(sim, raw_client):
    topic = ri.topic("client_count").name
    a = raw_client()
    a.send({"op": "subscribe", "id": "cc", "topic": topic, "type": "std_msgs/Int32"})
    assert a.expect(on_topic(topic))["msg"]["data"] == 1
    b = raw_client()
    assert a.expect(on_topic(topic))["msg"]["data"] == 2
    b.close()
    assert a.expect(on_topic(topic))["msg"]["data"] == 1


def test_it_answers_a_missing_service_with_result_false_and_the_error_text(sim, raw_client):
    raw = raw_client()
    reply = raw.call("/x", {}, cid="call_1")
    assert reply == {"op": "service_response", "service": "/x", "values": "Service /x does not exist",
                     "result": False, "id": "call_1"}
    bad = raw.call("/rosapi/topic_type", {"topic": "/cmd_vel", "bogus": 1}, cid="call_2")
    assert bad["result"] is False and "bogus" in bad["values"]


def test_it_takes_service_args_as_a_positional_list(sim, raw_client):
    reply = raw_client().call("/rosapi/topic_type", [CMD_VEL])
    assert reply["result"] is True
    assert reply["values"] == {"type": ri.topic("cmd_vel").type}


def test_it_drops_an_advertise_with_a_conflicting_type(sim, raw_client):
    raw = raw_client()
    _listen_rosout(raw)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    raw.send({"op": "advertise", "id": "adv", "topic": CMD_VEL, "type": "std_msgs/String"})
    err = raw.expect(_bridge_error("Tried to register topic /cmd_vel with type std_msgs/String"))
    assert "already established with type geometry_msgs/Twist" in err["msg"]["msg"]
    reply = raw.call("/rosapi/topic_type", {"topic": CMD_VEL})
    assert reply["values"]["type"] == "geometry_msgs/Twist"


def test_it_drops_a_publish_on_an_unknown_topic_until_it_is_advertised(sim, raw_client):
    pub, sub = raw_client(), raw_client()
    _listen_rosout(pub)
    wait_until(lambda: sim.subscription_count(ROSOUT) == 1)
    pub.send({"op": "publish", "id": "early", "topic": "/fresh", "msg": {"data": "x"}})
    pub.expect(_bridge_error("Cannot infer topic type for topic /fresh"))
    assert sim.received_count("/fresh") == 0
    pub.send({"op": "advertise", "id": "adv", "topic": "/fresh", "type": "std_msgs/String"})
    sub.send({"op": "subscribe", "id": "s", "topic": "/fresh"})  # type inferred from the advertise
    wait_until(lambda: sim.subscription_count("/fresh") == 1)
    pub.send({"op": "publish", "id": "late", "topic": "/fresh", "msg": {"data": "hello"}})
    assert sub.expect(on_topic("/fresh"))["msg"] == {"data": "hello"}
    assert sim.received_count("/fresh") == 1


def test_it_sends_nan_as_null(sim, raw_client):
    topic = ri.topic("battery_voltage").name
    raw = raw_client()
    raw.send({"op": "subscribe", "id": "v", "topic": topic, "type": "std_msgs/Float64"})
    wait_until(lambda: sim.subscription_count(topic) == 1)
    sim.call(lambda: sim.robot.publish_external(topic, {"data": math.nan}))
    assert raw.expect(lambda f: on_topic(topic)(f) and f["msg"]["data"] is None)


def test_it_stamps_a_header_only_when_the_client_gave_no_stamp(sim, raw_client):
    raw = raw_client()
    topic = ri.topic("initialpose").name
    raw.send({"op": "publish", "topic": topic, "msg": {"header": {"frame_id": "map"}}})
    raw.send({"op": "publish", "topic": topic,
              "msg": {"header": {"frame_id": "map", "stamp": {"secs": 7, "nsecs": 8}}}})
    wait_until(lambda: sim.received_count(topic) == 2)
    unstamped, stamped = sim.received(topic)
    assert unstamped["header"]["stamp"]["secs"] > 1_600_000_000
    assert stamped["header"]["stamp"] == {"secs": 7, "nsecs": 8}


def test_it_echoes_a_client_publish_to_other_subscribers_and_records_its_arrival_time(sim, raw_client):
    pub, sub = raw_client(), raw_client()
    sub.send({"op": "subscribe", "id": "echo", "topic": CMD_VEL, "type": "geometry_msgs/Twist"})
    wait_until(lambda: sim.subscription_count(CMD_VEL) == 1)
    before = time.time()
    pub.send({"op": "publish", "topic": CMD_VEL, "msg": {"linear": {"x": 0.1}}})
    assert sub.expect(on_topic(CMD_VEL))["msg"]["linear"]["x"] == 0.1
    stamped = sim.call(lambda: sim.robot.received_with_times(CMD_VEL, 1))
    assert before <= stamped[0]["t"] <= time.time()


def test_it_relays_calls_to_a_service_a_client_advertised(sim, raw_client):
    provider, caller = raw_client(), raw_client()
    provider.send({"op": "advertise_service", "service": "/ui/ping", "type": "std_srvs/Trigger"})
    wait_until(lambda: sim.call(lambda: "/ui/ping" in sim.robot.bus.client_services))
    caller.send({"op": "call_service", "service": "/ui/ping", "id": "ask", "args": {}})
    request = provider.expect(lambda f: f.get("op") == "call_service")
    provider.send({"op": "service_response", "service": "/ui/ping", "id": request["id"],
                   "values": {"success": True, "message": "pong"}, "result": True})
    reply = caller.expect(lambda f: f.get("op") == "service_response")
    assert reply == {"op": "service_response", "service": "/ui/ping", "values": {"success": True,
                                                                                  "message": "pong"},
                     "result": True, "id": "ask"}


def test_it_answers_the_rosapi_services(sim, raw_client):
    raw = raw_client()
    topics = raw.call(ri.service("rosapi_topics").name, cid="t")["values"]
    types = dict(zip(topics["topics"], topics["types"], strict=True))
    assert types[CMD_VEL] == "geometry_msgs/Twist"
    assert types[ri.topic("map").name] == "nav_msgs/OccupancyGrid"
    services = raw.call(ri.service("rosapi_services").name, cid="s")["values"]["services"]
    assert ri.service("enable_motors").name in services
    nodes = raw.call(ri.service("rosapi_nodes").name, cid="n")["values"]["nodes"]
    assert "/rosbridge_websocket" in nodes and "/move_base" in nodes
    details = raw.call("/rosapi/message_details", {"type": "geometry_msgs/Twist"}, cid="d")["values"]
    assert {d["type"] for d in details["typedefs"]} == {"geometry_msgs/Twist", "geometry_msgs/Vector3"}


def test_it_survives_a_frame_whose_id_is_not_hashable(sim, raw_client):
    raw = raw_client()
    raw.send({"op": "subscribe", "id": {"weird": 1}, "topic": CHATTER, "type": "std_msgs/String"})
    assert raw.call("/rosapi/get_time", cid="alive")["result"] is True
