"""One-field commands answered on the event loop for a token and roles the process already knows:
for every outcome the same status, body, headers and audit row as the DRF view gives, and
everything the fast path does not serve still goes to Django."""

import asyncio
import json
import re

import pytest
from asgiref.sync import sync_to_async
from channels.testing import HttpCommunicator
from rest_framework.authtoken.models import Token

from robot import interface as ri
from robot.api import fast_commands
from robot.models import AuditEntry
from tests.api.fastpaths import spy_on_passed_on
from tests.helpers import wait_until

pytestmark = [pytest.mark.django_db(transaction=True), pytest.mark.usefixtures("empty_token_cache")]

SPEECH = "/api/robot/speech/"


@pytest.fixture
def django_calls(monkeypatch):
    """Requests the fast command path passed on (to the state fast path, then Django)."""
    return spy_on_passed_on(monkeypatch, fast_commands.FastCommandApp, "app")


async def post(key: str, path: str = SPEECH, body: bytes | dict = b"", **extra: str) -> dict:
    from server.asgi import application

    raw = body if isinstance(body, bytes) else json.dumps(body).encode()
    headers = {"Host": "127.0.0.1", "Authorization": f"Token {key}", "Content-Type": "application/json",
               "Content-Length": str(len(raw)), **extra}
    encoded = [(k.lower().encode(), v.encode()) for k, v in headers.items()]
    return await HttpCommunicator(application, "POST", path, body=raw, headers=encoded).get_response(timeout=15)


async def trusted(user) -> str:
    """A token the process trusts, with the user's roles read: one command through Django."""
    key = (await sync_to_async(Token.objects.create)(user=user)).key
    assert (await post(key, body={"text": "warm up"}))["status"] in (200, 403, 503)
    return key


async def passed_on(self, scope, view) -> None:
    """FastCommandApp.eligible when every request must take Django's way."""
    return None


def answer(response: dict) -> tuple[int, dict, dict[bytes, bytes]]:
    headers = {name.lower(): value for name, value in response["headers"]}
    headers.pop(b"content-length")  # follows the body, compared with it
    return response["status"], json.loads(response["body"]), headers


async def last_entry() -> tuple:
    entry = await AuditEntry.objects.order_by("-id").afirst()
    assert entry is not None
    return entry.username, entry.source, entry.action, entry.params, entry.ok, entry.outcome, entry.error_code


async def both_ways(monkeypatch, django_calls, key: str, path: str, body: bytes | dict) -> dict:
    """The same request through Django, then on the fast path: equal answers and audit rows."""
    count = await AuditEntry.objects.acount()
    with monkeypatch.context() as forced:
        forced.setattr(fast_commands.FastCommandApp, "eligible", passed_on)
        through_django = await post(key, path, body)
    entry_django, written = await last_entry(), await AuditEntry.objects.acount() - count
    calls = len(django_calls)
    fast = await post(key, path, body)
    assert len(django_calls) == calls, "the fast path passed the request on"
    assert answer(fast) == answer(through_django)
    assert await last_entry() == entry_django
    assert await AuditEntry.objects.acount() - count == 2 * written
    return fast


BAD_INPUT = [
    (SPEECH, {"text": "   "}),
    (SPEECH, {"text": "a" * 501}),
    (SPEECH, {"text": 42}),
    (SPEECH, {"text": "bell\x07"}),
    (SPEECH, {"txt": "misspelt"}),
    (SPEECH, b""),
    (SPEECH, b"{nope"),
    (SPEECH, b"[1, 2]"),
    (SPEECH, b"[" * 100_000),
    (SPEECH, b'{"text": "\xff"}'),
    ("/api/robot/event/", {"event": "rm -rf"}),
    ("/api/robot/emotion-system/", {"on": "yes"}),
    ("/api/robot/motors/", {"enabled": 1}),
    ("/api/robot/mode/", b"{nope"),
]


@pytest.mark.parametrize("path, body", BAD_INPUT)
async def test_it_refuses_bad_input_as_the_view_does(operator, monkeypatch, django_calls, path, body):
    key = await trusted(operator)
    response = await both_ways(monkeypatch, django_calls, key, path, body)
    assert response["status"] == 400


async def test_it_sends_and_answers_as_the_view_does(operator, robot, monkeypatch, django_calls):
    key = await trusted(operator)
    response = await both_ways(monkeypatch, django_calls, key, SPEECH, {"text": "hello"})
    assert response["status"] == 200
    wait_until(lambda: robot.received_count(ri.topic("text_to_speech").name) >= 2, what="both commands")
    assert [m["data"] for m in robot.received(ri.topic("text_to_speech").name)][-2:] == ["hello", "hello"]


async def test_it_forbids_viewers_as_the_view_does(viewer, monkeypatch, django_calls):
    key = await trusted(viewer)
    response = await both_ways(monkeypatch, django_calls, key, "/api/robot/event/", {"event": "aborted"})
    assert response["status"] == 403 and json.loads(response["body"])["code"] == "forbidden"


async def test_it_answers_offline_as_the_view_does(operator, monkeypatch, django_calls):
    key = await trusted(operator)  # no robot: nothing can be sent
    response = await both_ways(monkeypatch, django_calls, key, SPEECH, {"text": "anyone?"})
    assert response["status"] == 503 and json.loads(response["body"])["code"] == "offline"


async def test_it_refuses_an_event_while_the_estop_is_engaged(operator, robot, monkeypatch, django_calls):
    key = await trusted(operator)
    # Latched either way: on a loaded machine a step can answer after the report (502, still trying).
    assert (await post(key, "/api/robot/estop/"))["status"] in (200, 502)
    response = await both_ways(monkeypatch, django_calls, key, "/api/robot/event/", {"event": "aborted"})
    assert response["status"] == 409
    assert (await post(key, "/api/robot/estop/release/", {"confirm": True}))["status"] == 200


async def test_it_throttles_as_the_view_does(operator, monkeypatch, django_calls, settings):
    key = await trusted(operator)  # the warm-up is the first command of the minute
    settings.COMMAND_THROTTLE_RATE = "3/min"
    assert (await both_ways(monkeypatch, django_calls, key, SPEECH, b"{nope"))["status"] == 400
    with monkeypatch.context() as forced:
        forced.setattr(fast_commands.FastCommandApp, "eligible", passed_on)
        through_django = await post(key, SPEECH, {"text": "one too many"})
    fast = await post(key, SPEECH, {"text": "one too many"})  # throttled before its body counts
    seconds = re.compile(rb"\d+")
    assert fast["status"] == through_django["status"] == 429
    assert seconds.sub(b"N", fast["body"]) == seconds.sub(b"N", through_django["body"])
    assert answer(fast)[2].keys() == answer(through_django)[2].keys() >= {b"retry-after"}


@pytest.mark.parametrize("path, body, extra", [
    ("/api/robot/emotion/", {"emotion": "happy"}, {}),  # a preset: its check reads the database
    ("/api/robot/mode/", {"mode": "manual"}, {}),
    (SPEECH, {"text": "hi"}, {"Accept": "text/html"}),  # the browsable API
    (SPEECH, {"text": "hi"}, {"Content-Type": "application/x-www-form-urlencoded"}),
    (SPEECH, {"text": "hi"}, {"Host": "evil.example"}),
])
async def test_what_it_does_not_serve_goes_to_django_with_its_body(operator, monkeypatch, django_calls, path,
                                                                   body, extra):
    key = await trusted(operator)
    django_calls.clear()
    response = await post(key, path, body, **extra)
    assert django_calls == [path]
    assert response["status"] != 500 and response["status"] != 408, response


async def test_an_uncached_token_or_user_goes_to_django(operator, django_calls):
    key = (await sync_to_async(Token.objects.create)(user=operator)).key
    await post(key, body=b"{nope")  # a 400 through Django: the token is cached, the roles not read
    await post(key, body=b"{nope")
    assert django_calls == [SPEECH, SPEECH]


async def test_a_trust_renewed_for_a_request_serves_it_however_soon_it_runs_out(operator, monkeypatch, django_calls):
    from robot.api import tokens

    key = await trusted(operator)
    await asyncio.sleep(tokens.TOKEN_CACHE_S + 0.1)  # the trust the first request gave has run out
    monkeypatch.setattr(tokens, "TOKEN_CACHE_S", 0.0)  # each renewal runs out at once: a loop stalled past it
    django_calls.clear()
    through_fast = await post(key, SPEECH, {"text": "renewed"})
    assert django_calls == [] and through_fast["status"] in (200, 503)


async def test_an_unexpected_failure_answers_500_as_the_view_does(operator, monkeypatch, django_calls):
    from robot.link import bus

    key = await trusted(operator)

    async def broken(*args, **kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(bus, "apublish", broken)
    response = await both_ways(monkeypatch, django_calls, key, SPEECH, {"text": "boom"})
    assert response["status"] == 500 and json.loads(response["body"])["code"] == "error"
