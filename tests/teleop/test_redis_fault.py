"""Redis goes away and comes back, for real (a private redis-server stopped and started on
its port): meanwhile health is red and commands fail with a clear error; within 2 s of its
return commands, E-STOP included, reach the robot again without restarting any process."""

from __future__ import annotations

import time
import urllib.error
import urllib.request

import pytest
from django.conf import settings

from tests.helpers import wait_until
from tests.stack import Stack
from tests.support_processes import Client, PrivateRedis

pytestmark = [pytest.mark.redis, pytest.mark.skipif(settings.EMBEDDED, reason="scaled wiring: services pass")]
RECOVERY_S = 2.0


def healthz(stack: Stack) -> tuple[int, dict]:
    import json

    try:
        with urllib.request.urlopen(f"{stack.url}/healthz", timeout=5) as res:
            return res.status, json.loads(res.read())
    except urllib.error.HTTPError as err:
        return err.code, json.loads(err.read())


def test_commands_and_estop_work_within_2_s_of_redis_returning():
    redis = PrivateRedis().start()
    stack = Stack(redis_url=redis.url)
    try:
        stack.start()
        stack.wait_robot_online(timeout=40)
        operator = Client(stack, "otto")
        status, body = operator.post("/api/robot/speech/", {"text": "before the outage"})
        assert status == 200, body
        assert healthz(stack)[1]["command_path"] is True

        redis.stop()
        wait_until(lambda: healthz(stack)[0] == 503, timeout=10, what="health to go red")
        _, health = healthz(stack)
        assert health["command_path"] is False and "redis" in health["down"], health
        status, body = operator.post("/api/robot/speech/", {"text": "during the outage"}, timeout=15)
        assert status in (503, 504), (status, body)  # a clear refusal, never a silent success

        redis.start()  # the same port, empty, like a restarted server without persistence
        back = time.monotonic()
        time.sleep(max(0.0, RECOVERY_S - (time.monotonic() - back)))
        status, body = operator.post("/api/robot/estop/", timeout=5)
        if status != 200:
            open("/tmp/redisfault_link.log", "w").write(stack.log("link") + "\n\nWEB\n" + stack.log("web"))
        assert status == 200, (status, [s for s in body.get("steps", []) if not s["ok"]], body.get("detail"))
        assert all(step["ok"] for step in body["steps"]), body
        status, body = operator.post("/api/robot/speech/", {"text": "after the outage"}, timeout=5)
        assert status == 200, (status, body)
        wait_until(lambda: healthz(stack)[0] == 200 and healthz(stack)[1]["command_path"], timeout=5,
                   what="health to turn green")
        # The latch held through it all: the stop pressed after the outage is still engaged.
        assert operator.get("/api/robot/estop/")[1]["latched"] is True
        assert "link.requests failed" in stack.log("link")  # the request loop died and was restarted
    finally:
        stack.stop()
        redis.stop()
