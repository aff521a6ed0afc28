"""Text the robot sends may hold anything (a lone surrogate in a /rosout line): the live
websocket, the state API and the history store and export it, never a 500."""

from __future__ import annotations

import pytest
from asgiref.sync import sync_to_async

from history.models import Sample
from history.storage import encode, write_rows
from robot import interface as ri
from tests.helpers import receive_until, wait_until, ws_communicator
from tests.history.test_api import _content

pytestmark = pytest.mark.postgres  # text the engine refuses (NUL, lone surrogates) and rows an older engine kept

LONE = "\ud800"


def _rosout(text: str) -> dict:
    return {"level": 8, "name": "/cyborg_behavior", "msg": text, "file": "x.py", "function": "f", "line": 1,
            "topics": []}


@pytest.mark.django_db
def test_the_state_api_shows_robot_text_with_a_replacement_character(robot, viewer_api):
    topic = ri.topic("rosout").name
    robot.call(lambda: robot.robot.publish_external(topic, _rosout(f"broken {LONE} text")))

    def shown():
        res = viewer_api.get("/api/robot/state/")
        assert res.status_code == 200, res.content[:300]
        return "broken \ufffd text" in res.content.decode()

    wait_until(shown, timeout=10, what="the robot's line in the state API")


@pytest.mark.django_db(transaction=True)
async def test_the_live_websocket_forwards_robot_text_with_a_lone_surrogate(link, sim, viewer):
    communicator = ws_communicator(viewer)
    assert (await communicator.connect())[0]
    await communicator.send_json_to({"action": "watch", "keys": ["rosout"]})
    topic = ri.topic("rosout").name
    await sync_to_async(wait_until)(lambda: sim.subscription_count(topic) > 0, timeout=10, what="rosout subscribed")
    sim.call(lambda: sim.robot.publish_external(topic, _rosout(f"live {LONE}")))
    frame = await receive_until(communicator, lambda f: f.get("key") == "rosout" and "live" in str(f), timeout=10)
    assert frame["msg"]["msg"] == "live \ufffd"  # replaced where it arrives, so every wiring can carry it
    await communicator.disconnect()


@pytest.mark.django_db
def test_history_stores_and_exports_robot_text_with_a_lone_surrogate(viewer_api):
    rows, oversize = encode([("/rosout", "rosgraph_msgs/Log", _rosout(f"kept {LONE}"), 1_700_000_000.0)], {},
                            default_max=10_000)
    assert (len(rows), oversize) == (1, 0)
    assert write_rows(rows) == 1
    assert Sample.objects.get().data["msg"] == "kept \ufffd"
    for fmt in ("csv", "jsonl", "mcap"):
        res = viewer_api.get(f"/api/history/export/?topic=/rosout&start=1699999999&end=1700000001&format={fmt}")
        assert res.status_code == 200
        body = _content(res)
        assert body and (fmt == "mcap" or "kept \ufffd".encode() in body)
