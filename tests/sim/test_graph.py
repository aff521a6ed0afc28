"""rosapi's graph services agree with the topics and nodes the simulator reports."""

from robot import interface as ri


def _call(sim, key, **args):
    service = ri.service(key)
    robot = sim.robot
    return sim.call(lambda: robot.bus.services[service.name][1](args))


def test_publishers_are_nodes_rosapi_lists_and_every_named_nodes_topics_have_one(sim):
    topics = _call(sim, "rosapi_topics")["topics"]
    nodes = set(_call(sim, "rosapi_nodes")["nodes"])
    assert ri.topic("rosout").name in topics
    for name in topics:
        publishers = _call(sim, "rosapi_publishers", topic=name)["publishers"]
        assert set(publishers) <= nodes | {"/rosbridge_websocket"}, (name, publishers)
    for node in sim.robot.nodes:
        for key in node.publishes if node.names else ():
            assert _call(sim, "rosapi_publishers", topic=ri.topic(key).name)["publishers"], key


def test_publishers_name_the_node_that_publishes(sim):
    assert _call(sim, "rosapi_publishers", topic=ri.topic("battery_soc").name)["publishers"] == ["/RosAria"]
    assert "/cyborg_controller" in _call(sim, "rosapi_publishers", topic=ri.topic("state_change").name)["publishers"]
    assert "/move_base" in _call(sim, "rosapi_publishers", topic="/move_base/status")["publishers"]
    assert len(_call(sim, "rosapi_publishers", topic=ri.topic("rosout").name)["publishers"]) > 5
    assert _call(sim, "rosapi_publishers", topic="/no/such_topic")["publishers"] == []
    assert _call(sim, "rosapi_publishers", topic=ri.topic("client_count").name)["publishers"] == [
        "/rosbridge_websocket"]
    details = _call(sim, "rosapi_node_details", node="/RosAria")
    assert ri.topic("battery_soc").name in details["publishing"]
    assert ri.service("enable_motors").name in details["services"]
