"""Reads per caller: a burst passes, a faster caller is paced, one that keeps too many waiting gets
429 (after the wait, in the API's error shape); commands, static files and other callers are not
held up."""

from __future__ import annotations

import asyncio

from channels.testing import HttpCommunicator
from django.test import override_settings

from cyborg_site.bucket import Bucket
from server.read_throttle import ReadThrottle, caller
from tests.helpers import DEADLINE_S


def test_a_bucket_gives_a_burst_then_paces_at_the_rate():
    bucket = Bucket(rate=10, burst=2, now=0.0)
    assert [bucket.take(0.0) for _ in range(4)] == [0.0, 0.0, 0.1, 0.2]
    assert bucket.take(1.0) == 0.0  # refilled, up to the burst
    assert bucket.take(1.0) == 0.0
    assert bucket.take(1.0) > 0


def test_the_caller_is_the_token_else_the_session_else_the_address():
    token = {"headers": [(b"authorization", b"Token abc"), (b"cookie", b"sessionid=s1")], "client": ("10.0.0.1", 1)}
    session = {"headers": [(b"cookie", b"csrftoken=x; sessionid=s1")], "client": ("10.0.0.1", 1)}
    anonymous = {"headers": [], "client": ("10.0.0.1", 1)}
    assert caller(token).startswith("token:") and "abc" not in caller(token)
    assert caller(session).startswith("session:") and caller(session) != caller(token)
    assert caller(anonymous) == "address:10.0.0.1"


async def _app(scope, receive, send):
    await send({"type": "http.response.start", "status": 200, "headers": []})
    await send({"type": "http.response.body", "body": b"ok"})


def _get(app, path: str = "/api/robot/state/", method: str = "GET", token: str = "a") -> HttpCommunicator:
    return HttpCommunicator(app, method, path, headers=[(b"authorization", f"Token {token}".encode())])


@override_settings(READ_THROTTLE_PER_S=2, READ_THROTTLE_BURST=1, READ_THROTTLE_WAIT_S=0.3)
async def test_too_many_waiting_reads_get_429_and_nothing_else_is_held_up():
    app = ReadThrottle(_app)
    answers = await asyncio.gather(*(_get(app).get_response(timeout=DEADLINE_S) for _ in range(3)))
    # One from the burst, one paced 0.5 s later (over the 0.3 s wait: 429 after it), and the last as well.
    statuses = sorted(a["status"] for a in answers)
    assert statuses == [200, 429, 429], statuses
    refused = next(a for a in answers if a["status"] == 429)
    assert b'"code": "throttled"' in refused["body"] and dict(refused["headers"])[b"retry-after"] == b"1"
    for other in (_get(app, method="POST"), _get(app, path="/static/css/site.css"), _get(app, token="b"),
                  _get(app, path="/healthz")):
        assert (await other.get_response(timeout=DEADLINE_S))["status"] == 200


@override_settings(READ_THROTTLE_PER_S=20, READ_THROTTLE_BURST=1, READ_THROTTLE_WAIT_S=1)
async def test_a_caller_asking_one_at_a_time_is_paced_never_refused():
    app = ReadThrottle(_app)
    for _ in range(5):
        assert (await _get(app).get_response(timeout=DEADLINE_S))["status"] == 200
