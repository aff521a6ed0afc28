"""rosbridge's side of the graph: rosapi's services and parameters, connected clients, and /rosout chatter."""

from __future__ import annotations

import json
import random
from typing import Any

from .. import messages
from ..bus import Bus, SimNode
from ..protocol import ServiceError

NODES = ("/rosapi", "/rosbridge_websocket", "/web_video_server", "/rosout")
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
    answers = ("rosapi_topics", "rosapi_topic_type", "rosapi_services", "rosapi_get_time")

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.params: dict[str, Any] = {"/rosdistro": "noetic", "/use_sim_time": False,
                                       "/robot_description": "Pioneer LX (simulated)"}

    def start(self, bus: Bus) -> None:
        super().start(bus)
        broker = bus.broker
        bus.declare("/connected_clients", "rosbridge_msgs/ConnectedClients")
        bus.answer("rosapi_topics", lambda r: {"topics": sorted(broker.types),
                                              "types": [broker.types[n] for n in sorted(broker.types)]})
        bus.answer("rosapi_topic_type", lambda r: {"type": broker.types.get(r["topic"], "")})
        bus.answer("rosapi_services", lambda r: {"services": sorted(broker.services)})
        bus.answer("rosapi_get_time", lambda r: {"time": messages.stamp()})
        bus.answer_name("/rosapi/topics_for_type", "rosapi/TopicsForType", lambda r: {
            "topics": sorted(t for t, ty in broker.types.items() if ty == r["type"])})
        bus.answer_name("/rosapi/service_type", "rosapi/ServiceType", lambda r: {
            "type": broker.services.get(r["service"], ("",))[0]})
        bus.answer_name("/rosapi/get_param", "rosapi/GetParam", lambda r: {
            "value": json.dumps(self.params[r["name"]]) if r["name"] in self.params else r["default"]})
        bus.answer_name("/rosapi/has_param", "rosapi/HasParam", lambda r: {"exists": r["name"] in self.params})
        bus.answer_name("/rosapi/get_param_names", "rosapi/GetParamNames", lambda r: {"names": sorted(self.params)})
        bus.answer_name("/rosapi/message_details", "rosapi/MessageDetails", self._message_details)
        bus.every(8.0, lambda: bus.rosout(2, *self.rng.choice(CHATTER)))
        self.publish_client_count()

    def publish_client_count(self) -> None:
        clients = self.bus.broker.clients
        self.bus.publish("client_count", {"data": len(clients)})
        self.bus.publish_name("/connected_clients", {"clients": [
            {"ip_address": c.address, "connection_time": messages.stamp(c.connected_at)}
            for c in clients.values()]}, latch=True)

    def _message_details(self, r: dict[str, Any]) -> dict[str, Any]:
        if not messages.known(r["type"]):
            raise ServiceError(f"Unable to load the manifest for message type {r['type']}")
        return {"typedefs": messages.typedefs(r["type"])}
