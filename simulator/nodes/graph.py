"""rosapi's view of the graph: the nodes, who publishes and subscribes to what, and each node's details.

Answered from what the simulator really does, so it agrees with ``/rosapi/topics`` and
``/rosapi/nodes``: a topic's publishers are the node that declares it in ``publishes`` (or, for
topics no node declares, such as action servers' and the costmaps', the node whose name is the
topic's namespace), every node for ``/rosout``, and ``/rosbridge_websocket`` for what clients
advertise and for rosbridge's own topics; rosbridge subscribes on behalf of its clients.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from robot import interface as ri

from ..bus import Bus, SimNode

BRIDGE = "/rosbridge_websocket"


class GraphNode(SimNode):
    names: tuple[str, ...] = ()  # part of /rosapi (the bridge node names it)
    answers = ("rosapi_nodes", "rosapi_publishers", "rosapi_subscribers", "rosapi_node_details")

    def __init__(self, nodes: Callable[[], Sequence[SimNode]]) -> None:
        self.nodes = nodes

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.answer("rosapi_nodes", lambda r: {"nodes": self._graph_nodes()})
        bus.answer("rosapi_publishers", lambda r: {"publishers": self.publishers(r["topic"])})
        bus.answer("rosapi_subscribers", lambda r: {"subscribers": self.subscribers(r["topic"])})
        bus.answer("rosapi_node_details", lambda r: self.node_details(r["node"]))

    def _graph_nodes(self) -> list[str]:
        return [name for node in self.nodes() for name in node.names]

    def _owner(self, topic: str) -> str | None:
        """The node whose name is the longest namespace prefix of ``topic``."""
        found = [n for n in self._graph_nodes() if topic.startswith(n + "/")]
        return max(found, key=len) if found else None

    def publishers(self, topic: str) -> list[str]:
        broker = self.bus.broker
        if topic not in broker.types:
            return []
        if topic == ri.topic("rosout").name:
            return sorted(set(self._graph_nodes()))
        if topic in (ri.topic("client_count").name, "/connected_clients"):
            return [BRIDGE]
        found: set[str] = set()
        for node in self.nodes():
            if any(ri.topic(key).name == topic for key in node.publishes):
                found.add(self._owner(topic) or (node.names[0] if node.names else ""))
        if broker.publishers.get(topic):
            found.add(BRIDGE)
        if not found and topic not in broker.handlers:
            found.add(self._owner(topic) or "")
        found.discard("")  # no node to name
        return sorted(found)

    def subscribers(self, topic: str) -> list[str]:
        broker = self.bus.broker
        found: set[str] = set()
        if broker.subs.get(topic):
            found.add(BRIDGE)
        if broker.handlers.get(topic):
            found.add(self._owner(topic) or "/cyborg_controller")
        return sorted(found)

    def node_details(self, node: str) -> dict[str, Any]:
        broker = self.bus.broker
        topics = sorted(broker.types)
        return {
            "publishing": [t for t in topics if node in self.publishers(t)],
            "subscribing": [t for t in topics if node in self.subscribers(t)],
            "services": sorted(s for s in broker.services if s.startswith(node + "/")),
        }
