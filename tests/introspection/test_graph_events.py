"""An event clicked in the graph takes the one command path: role-checked, refused while the
E-STOP holds (nothing reaches the robot), audited, and the graph follows the robot's new state."""

from __future__ import annotations

import asyncio

import pytest

from robot import interface as ri
from robot.introspection.tracking import track_smach
from robot.live.groups import SMACH_ACTIVE_KEY
from robot.models import AuditEntry
from tests.conftest import EITHER_ROS
from tests.helpers import wait_until
from tests.introspection.test_tracking import leaves, stored


@EITHER_ROS
@pytest.mark.django_db(transaction=True)
def test_an_event_offered_by_the_graph_goes_through_the_command_path(sim, link_thread, operator_api, viewer_api):
    tracker = asyncio.run_coroutine_threadsafe(track_smach(link_thread), link_thread.dial.loop)
    received = ri.topic("register_event").name
    try:
        wait_until(lambda: leaves() == ["/SM_ROOT/suspension"], timeout=20, what="suspension in the graph")
        offered = {t["event"]: t["to"] for t in stored(SMACH_ACTIVE_KEY)["transitions"]}
        assert offered["manual_start"] == "/SM_ROOT/manual"
        assert viewer_api.post("/api/robot/event/", {"event": "manual_start"}, format="json").status_code == 403
        # Latched either way: on a loaded machine a step can answer after the report (502, still trying).
        assert operator_api.post("/api/robot/estop/").status_code in (200, 502)
        assert operator_api.get("/api/robot/estop/").json()["latched"] is True
        refused = operator_api.post("/api/robot/event/", {"event": "manual_start"}, format="json")
        assert refused.status_code == 409
        assert operator_api.post("/api/robot/estop/release/", {"confirm": True}, format="json").status_code == 200
        assert sim.received(received) == []  # neither refusal reached the robot
        assert operator_api.post("/api/robot/event/", {"event": "manual_start"}, format="json").status_code == 200
        wait_until(lambda: leaves() == ["/SM_ROOT/manual"], timeout=10, what="manual in the graph")
        assert sim.received(received) == [{"data": "manual_start"}]
        outcomes = list(AuditEntry.objects.filter(action="event").order_by("id").values_list("username", "ok"))
        assert outcomes == [("vera", False), ("otto", False), ("otto", True)]
    finally:
        tracker.cancel()
