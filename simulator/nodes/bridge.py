"""rosbridge's side of the graph: rosapi's services and parameters, connected clients, /rosout chatter,
and rosapi's view of the graph (the nodes, who publishes and subscribes to what, each node's details).

The graph is answered from what the simulator really does, so it agrees with ``/rosapi/topics`` and
``/rosapi/nodes``: a topic's publishers are the node that declares it in ``publishes`` (or, for
topics no node declares, such as action servers' and the costmaps', the node whose name is the
topic's namespace), every node for ``/rosout``, and ``/rosbridge_websocket`` for what clients
advertise and for rosbridge's own topics; rosbridge subscribes on behalf of its clients.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable, Sequence
from typing import Any

from .. import messages
from ..bus import Bus, NoAnswer, ServiceError, SimNode

BRIDGE = "/rosbridge_websocket"

NODES = ("/rosapi", BRIDGE, "/web_video_server", "/rosout")
CHATTER = (
    ("/amcl", "Laser scan received, updating particle filter"),
    ("/move_base", "Got new plan"),
    ("/cyborg_eventscheduler", "No scheduled events right now"),
    ("/RosAria", "Battery check ok"),
    ("/cyborg_controller", "Motivator tick"),
)


class BridgeNode(SimNode):
    names = NODES
    publishes = ("client_count",)
    answers = ("rosapi_topics", "rosapi_topic_type", "rosapi_services", "rosapi_get_time", "rosapi_nodes",
               "rosapi_publishers", "rosapi_subscribers", "rosapi_node_details")

    def __init__(self, rng: random.Random, nodes: Callable[[], Sequence[SimNode]]) -> None:
        self.rng = rng
        self.nodes = nodes
        self.params: dict[str, Any] = {"/rosdistro": "noetic", "/use_sim_time": False,
                                       "/robot_description": "Pioneer LX (simulated)"}

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.declare("/connected_clients", "rosbridge_msgs/ConnectedClients")
        bus.answer("rosapi_topics", lambda r: {"topics": sorted(bus.types),
                                              "types": [bus.types[n] for n in sorted(bus.types)]})
        bus.answer_name("/rosapi/topics_and_raw_types", "rosapi/TopicsAndRawTypes", lambda r: {
            "topics": sorted(bus.types), "types": [bus.types[n] for n in sorted(bus.types)],
            "typedefs_full_text": [bus.dialect.full_text(bus.types[n]) for n in sorted(bus.types)]})
        bus.answer("rosapi_topic_type", lambda r: {"type": bus.types.get(r["topic"], "")})
        bus.answer("rosapi_services", lambda r: {"services": sorted(bus.services)})
        bus.answer("rosapi_get_time", lambda r: {"time": messages.stamp()})
        bus.answer_name("/rosapi/topics_for_type", "rosapi/TopicsForType", lambda r: {
            "topics": sorted(t for t, ty in bus.types.items() if ty == r["type"])})
        bus.answer_name("/rosapi/service_type", "rosapi/ServiceType", lambda r: {
            "type": bus.services.get(r["service"], ("",))[0]})
        bus.answer_name("/rosapi/get_param", "rosapi/GetParam", lambda r: {
            "value": json.dumps(self.params[r["name"]]) if r["name"] in self.params else r["default"]})
        bus.answer_name("/rosapi/has_param", "rosapi/HasParam", lambda r: {"exists": r["name"] in self.params})
        bus.answer_name("/rosapi/get_param_names", "rosapi/GetParamNames", lambda r: {"names": sorted(self.params)})
        bus.answer_name("/rosapi/message_details", "rosapi/MessageDetails", self._message_details)
        bus.answer("rosapi_nodes", lambda r: {"nodes": self._graph_nodes()})
        bus.answer("rosapi_publishers", lambda r: {"publishers": self.publishers(r["topic"])})
        bus.answer("rosapi_subscribers", lambda r: {"subscribers": self.subscribers(r["topic"])})
        bus.answer("rosapi_node_details", lambda r: self.node_details(r["node"]))
        if bus.dialect.ros2:
            bus.answer_name("/rosapi/get_ros_version", "rosapi/GetROSVersion",
                            lambda r: {"version": 2, "distro": "jazzy"})
            # rosbridge 2.1.0's rosapi dies on these (upstream bugs): its services vanish, the call is never answered
            for name in ("/rosapi/get_param_names", "/rosapi/message_details"):
                bus.services[name] = (bus.services[name][0], self._crash_rosapi)
        bus.every(8.0, lambda: bus.rosout(2, *self.rng.choice(CHATTER)))
        self.publish_client_count()

    def _crash_rosapi(self, request: dict[str, Any]) -> dict[str, Any]:
        services = self.bus.services
        for name in [n for n in services if n.startswith("/rosapi/")]:
            del services[name]
        self.bus.rosout(16, "/rosapi", "rosapi_node crashed")
        raise NoAnswer

    def publish_client_count(self) -> None:
        clients = self.bus.clients
        self.bus.publish("client_count", {"data": len(clients)})
        self.bus.publish_name("/connected_clients", {"clients": [
            {"ip_address": c.address, "connection_time": messages.stamp(c.connected_at)}
            for c in clients.values()]}, latch=True)

    def _message_details(self, r: dict[str, Any]) -> dict[str, Any]:
        if not messages.known(r["type"]):
            raise ServiceError(f"Unable to load the manifest for message type {r['type']}")
        return {"typedefs": messages.typedefs(r["type"])}

    # --- the graph -----------------------------------------------------------------------

    def _graph_nodes(self) -> list[str]:
        return [name for node in self.nodes() for name in node.names]

    def _owner(self, topic: str) -> str | None:
        """The node whose name is the longest namespace prefix of ``topic``."""
        found = [n for n in self._graph_nodes() if topic.startswith(n + "/")]
        return max(found, key=len) if found else None

    def publishers(self, topic: str) -> list[str]:
        if topic not in self.bus.types:
            return []
        if topic == self.bus.topic("rosout").name:
            return sorted(set(self._graph_nodes()))
        if topic in (self.bus.topic("client_count").name, "/connected_clients"):
            return [BRIDGE]
        found: set[str] = set()
        for node in self.nodes():
            if any(self.bus.topic(key).name == topic for key in node.publishes):
                found.add(self._owner(topic) or (node.names[0] if node.names else ""))
        if self.bus.publishers.get(topic):
            found.add(BRIDGE)
        if not found and topic not in self.bus.handlers:
            found.add(self._owner(topic) or "")
        found.discard("")  # no node to name
        return sorted(found)

    def subscribers(self, topic: str) -> list[str]:
        found: set[str] = set()
        if self.bus.subs.get(topic):
            found.add(BRIDGE)
        if self.bus.handlers.get(topic):
            found.add(self._owner(topic) or "/cyborg_controller")
        return sorted(found)

    def node_details(self, node: str) -> dict[str, Any]:
        topics = sorted(self.bus.types)
        return {
            "publishing": [t for t in topics if node in self.publishers(t)],
            "subscribing": [t for t in topics if node in self.subscribers(t)],
            "services": sorted(s for s in self.bus.services if s.startswith(node + "/")),
        }
