"""Websocket origins are checked like Django's CSRF origins: scheme, host and port of the
site, or an entry of CSRF_TRUSTED_ORIGINS; anything else is refused before any consumer runs."""

import pytest
from channels.testing import WebsocketCommunicator

from server.ws_origin import origin_allowed


def scope(host: str, *, scheme: str = "ws", extra: tuple = ()) -> dict:
    return {"type": "websocket", "scheme": scheme, "headers": [(b"host", host.encode()), *extra]}


async def connects(user, origin: str, host: str, path: str = "/ws/teleop/") -> bool:
    from server.asgi import application

    communicator = WebsocketCommunicator(application, path, headers=[(b"origin", origin.encode()),
                                                                     (b"host", host.encode())])
    communicator.scope["user"] = user
    connected, _ = await communicator.connect()
    await communicator.disconnect()
    return connected


@pytest.mark.parametrize("origin", [
    "http://127.0.0.1:8100",  # another port on the same host
    "http://localhost:1",
    "https://127.0.0.1:8200",  # another scheme
    "http://127.0.0.1",  # the default port is another port
    "http://evil.example:8200",
    "null",
])
async def test_it_refuses_the_operators_socket_from_another_origin(operator, origin):
    assert await connects(operator, origin, "127.0.0.1:8200") is False


async def test_it_accepts_the_sites_own_origin(operator):
    assert await connects(operator, "http://127.0.0.1:8200", "127.0.0.1:8200") is True
    assert await connects(operator, "http://127.0.0.1:8200", "127.0.0.1:8200", "/ws/live/") is True


async def test_it_refuses_a_socket_without_origin_or_with_a_host_not_allowed(operator):
    from server.asgi import application

    communicator = WebsocketCommunicator(application, "/ws/live/", headers=[(b"host", b"127.0.0.1:8200")])
    communicator.scope["user"] = operator
    assert (await communicator.connect())[0] is False
    assert await connects(operator, "http://evil.example:8200", "evil.example:8200") is False


async def test_it_accepts_trusted_origins_like_csrf_does(operator, settings):
    settings.CSRF_TRUSTED_ORIGINS = ["https://cyborg.example.org", "https://*.robots.example.org"]
    settings.ALLOWED_HOSTS = ["127.0.0.1"]
    assert await connects(operator, "https://cyborg.example.org", "127.0.0.1:8200") is True
    assert await connects(operator, "https://lab.robots.example.org", "127.0.0.1:8200") is True
    assert await connects(operator, "http://cyborg.example.org", "127.0.0.1:8200") is False
    assert await connects(operator, "https://cyborg.example.org:8443", "127.0.0.1:8200") is False


def test_it_follows_the_tls_proxy_header(settings):
    settings.SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
    settings.ALLOWED_HOSTS = ["cyborg.example.org"]
    behind_tls = scope("cyborg.example.org", extra=((b"x-forwarded-proto", b"https"),))
    assert origin_allowed("https://cyborg.example.org", behind_tls)
    assert not origin_allowed("http://cyborg.example.org", behind_tls)
    assert origin_allowed("http://cyborg.example.org", scope("cyborg.example.org"))
    assert origin_allowed("https://cyborg.example.org", scope("cyborg.example.org", scheme="wss"))
