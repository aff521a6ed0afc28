"""When no robot link runs, the worker's check raises link_down once per outage, sends it to whoever
chose it (a real local webhook), shows it among the alerts on, and ends it when a link runs again."""

from __future__ import annotations

import json
import time

import pytest
from asgiref.sync import async_to_sync

from robot.alerts import records, watchdog
from robot.alerts.models import Alert, Webhook
from robot.alerts.selectors import alerts_on
from robot.live.announce import aget_state
from robot.live.groups import ALERTS_KEY
from robot.live.state import link_status
from tests.conftest import LinkThread
from tests.helpers import wait_until

pytestmark = pytest.mark.django_db(transaction=True)


def strip() -> list[dict]:
    return async_to_sync(aget_state)(ALERTS_KEY).get(ALERTS_KEY, {}).get("alerts", [])


def test_no_link_running_is_sent_once_per_outage_and_ended_by_a_link_that_runs(sim, settings, http_server):
    settings.ROSBRIDGE_URL = sim.url
    settings.LINK_DOWN_ALERT_S = 10.0
    Webhook.objects.create(name="chat", url=f"http://127.0.0.1:{http_server.server_address[1]}/hook",
                           kinds=["link_down"])
    first = LinkThread()
    first.start()
    assert watchdog.check_links() is None  # a link runs: nothing to say
    first.stop()
    wait_until(lambda: not link_status().get("link_running"), timeout=10, what="the link's heartbeat going stale")

    last_heard = float(link_status()["link_alive"])
    assert watchdog.check_links(now=last_heard + 9) is None  # not yet LINK_DOWN_ALERT_S
    assert watchdog.check_links(now=last_heard + 11) == "raised"
    assert watchdog.check_links(now=last_heard + 12) is None  # the same outage: once
    wait_until(lambda: len(http_server.received) == 1, timeout=10, what="the webhook's POST")
    body = json.loads(http_server.received[0][2])
    assert body["alert"]["kind"] == "link_down" and body["alert"]["severity"] == "critical"
    (on,) = [a for a in async_to_sync(alerts_on)() if a["kind"] == "link_down"]
    assert on["ended_at"] is None
    assert [a["id"] for a in strip() if a["key"] == "link_down"] == [on["id"]]  # every page's strip too
    assert "link_down" not in {r.key for r in records.open_records()}  # no link takes it over

    second = LinkThread(background=True)  # with its raiser, which shows its own alerts
    second.start()
    try:
        wait_until(lambda: link_status().get("link_running"), timeout=10, what="a link running again")
        wait_until(lambda: not [a for a in strip() if a["key"] == "link_down"], timeout=10,
                   what="the raiser's own alerts on the strip")
        assert watchdog.check_links() == "ended"
        assert Alert.objects.get(id=on["id"]).ended_at is not None
        assert not [a for a in async_to_sync(alerts_on)() if a["kind"] == "link_down"]
        assert watchdog.check_links() is None
    finally:
        second.stop()
    time.sleep(0.5)
    assert len(http_server.received) == 1
