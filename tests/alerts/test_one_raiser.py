"""Scaled: two web processes and two robot links (one active, one standby) on a private Redis raise
each alert once; when the active link dies, the standby takes the open alert over with its id and start."""

from __future__ import annotations

import os
import signal
import time

import pytest
import roslibpy

from robot import interface as ri
from tests.stack import Stack
from tests.support_processes import Client, PrivateRedis

pytestmark = pytest.mark.redis


def wait_for(fetch, predicate, timeout: float = 20.0):
    deadline = time.monotonic() + timeout
    while True:
        value = fetch()
        if predicate(value):
            return value
        assert time.monotonic() < deadline, f"not within {timeout} s: {value}"
        time.sleep(0.1)


def alerts_on(client: Client) -> dict[str, dict]:
    return {a["key"]: a for a in client.get("/api/alerts/")[1]["on"]}


def test_one_alert_per_event_across_two_web_processes_and_two_links():
    redis = PrivateRedis().start()
    try:
        with Stack(redis_url=redis.url, webs=2, env={"ROBOT_LINK_LEASE_S": "1"}) as stack:
            links = [stack.link_proc, stack.start_link()]
            stack.wait_robot_online()
            ros = roslibpy.Ros("127.0.0.1", stack.sim_port)
            ros.run(timeout=10)
            rosout = roslibpy.Topic(ros, ri.topic("rosout").name, ri.topic("rosout").type)
            rosout.advertise()
            time.sleep(0.5)
            rosout.publish(roslibpy.Message({"level": 8, "name": "/twice", "msg": "seen once"}))

            webs = [Client(stack, "otto")]
            stack.web_port = stack.web_ports[1]
            webs.append(Client(stack, "otto"))

            def alerts(client: Client) -> dict:
                return client.get("/api/alerts/?kind=log")[1]

            on = [wait_for(lambda c=c: alerts(c), lambda a: any(x["key"] == "log:/twice" for x in a["on"]))
                  for c in webs]
            ids = {x["id"] for a in on for x in a["on"] if x["key"] == "log:/twice"}
            assert len(ids) == 1
            history = wait_for(lambda: alerts(webs[0]),
                               lambda a: any(x["key"] == "log:/twice" for x in a["history"]))["history"]
            assert [x["key"] for x in history].count("log:/twice") == 1

            # The active link dies; the other takes over the open alert, and a repeat counts on it.
            holder = wait_for(lambda: Client(stack, "ada").get("/healthz")[1].get("link_holder"), bool)
            active = next(p for p in links if holder.endswith(f"-{p.pid}"))
            standby = next(p for p in links if p is not active)
            os.killpg(active.pid, signal.SIGKILL)
            admin = Client(stack, "ada")
            wait_for(lambda: admin.get("/healthz")[1], lambda h: h.get("link_holder") not in (None, holder)
                     and h.get("connected"), timeout=30)

            def repeat_counted() -> dict:
                rosout.publish(roslibpy.Message({"level": 8, "name": "/twice", "msg": "seen again"}))
                return alerts(webs[1])

            # (Until the new link's subscriptions are up, a line is not heard: say it again.)
            after = wait_for(repeat_counted, lambda a: any(
                x["key"] == "log:/twice" and x["count"] >= 2 for x in a["on"]), timeout=30)
            assert {x["id"] for x in after["on"] if x["key"] == "log:/twice"} == ids
            assert [x["key"] for x in alerts(webs[0])["history"]].count("log:/twice") == 1
            assert standby.poll() is None
            ros.close()

            # The robot gone: the offline alert is acknowledged from a web process, shown by the link.
            stack.stop_sim()
            offline = wait_for(lambda: alerts_on(webs[0]), lambda on: "offline" in on, timeout=20)["offline"]
            status, body = webs[0].post(f"/api/alerts/{offline['id']}/ack/")
            assert status == 200, body
            acked = wait_for(lambda: alerts_on(webs[1]), lambda on: on.get("offline", {}).get("acked_by"))
            assert acked["offline"]["acked_by"] == "otto" and acked["offline"]["id"] == offline["id"]
    finally:
        redis.stop()
