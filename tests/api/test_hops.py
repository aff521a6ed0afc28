"""A command through the API crosses from the event loop to a thread once, for its view."""

import json

import pytest
from asgiref import sync
from channels.testing import HttpCommunicator
from rest_framework.authtoken.models import Token

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
def hops(monkeypatch):
    """What crossed to a thread (sync_to_async) and back (async_to_sync), by function name."""
    crossed: dict[str, list[str]] = {"to_thread": [], "to_loop": []}
    to_thread, to_loop = sync.SyncToAsync.__call__, sync.AsyncToSync.__call__

    async def counting_to_thread(self, *args, **kwargs):
        crossed["to_thread"].append(getattr(self.func, "__qualname__", repr(self.func)))
        return await to_thread(self, *args, **kwargs)

    def counting_to_loop(self, *args, **kwargs):
        crossed["to_loop"].append(getattr(self.awaitable, "__qualname__", repr(self.awaitable)))
        return to_loop(self, *args, **kwargs)

    monkeypatch.setattr(sync.SyncToAsync, "__call__", counting_to_thread)
    monkeypatch.setattr(sync.AsyncToSync, "__call__", counting_to_loop)
    return crossed


async def test_a_speech_command_crosses_to_a_thread_once_for_its_view(robot, operator, hops):
    from asgiref.sync import sync_to_async

    from server.asgi import application

    key = (await sync_to_async(Token.objects.create)(user=operator)).key
    hops["to_thread"].clear()
    body = json.dumps({"text": "hops"}).encode()
    headers = [(b"host", b"127.0.0.1"), (b"authorization", f"Token {key}".encode()),
               (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    response = await HttpCommunicator(application, "POST", "/api/robot/speech/", body=body,
                                      headers=headers).get_response(timeout=15)
    assert response["status"] == 200, response["body"]
    # Django's request_started receivers, then the whole middleware chain and the view in one hop
    # (Django's own ASGI handler crossed for every middleware's request and response half).
    assert [name for name in hops["to_thread"] if "get_response" in name] == ["BaseHandler.get_response"]
    assert len(hops["to_thread"]) <= 3  # the third: closing the response once it is sent
    assert len(hops["to_loop"]) == 1  # the view hands the robot work to the event loop once

