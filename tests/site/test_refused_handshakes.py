"""A websocket handshake with a malformed Host or Origin is refused quietly: a 400 or 403 and at
most one short warning line, never a CRITICAL traceback (anyone can send one, logged in or not)."""

from __future__ import annotations

import logging
import socket

import pytest
from channels.testing import WebsocketCommunicator
from daphne.ws_protocol import WebSocketProtocol
from django.conf import settings

from server.patches import refused_handshakes
from tests.helpers import wait_until
from tests.stack import Stack

# (Host, Origin) pairs: None leaves the header out; "{site}" is the server's own address.
MALFORMED = [
    ("[", "http://["),
    ("{site}", "http://["),
    ("[", "http://{site}"),
    ("[", None),
    ("{site}", "http://127.0.0.1:99999"),
    ("{site}", "http://127.0.0.1:abc"),
    ("127.0.0.1:abc", "http://127.0.0.1:abc"),
    ("[::1", "http://[::1"),
]


def handshake(port: int, host: str | None, origin: str | None) -> str:
    """A websocket opening handshake with these headers; the status line of the answer."""
    site = f"127.0.0.1:{port}"
    headers = [f"Host: {host.format(site=site)}" if host is not None else "",
               f"Origin: {origin.format(site=site)}" if origin is not None else "",
               "Upgrade: websocket", "Connection: Upgrade", "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
               "Sec-WebSocket-Version: 13"]
    request = "GET /ws/live/ HTTP/1.1\r\n" + "".join(f"{h}\r\n" for h in headers if h) + "\r\n"
    with socket.create_connection(("127.0.0.1", port), timeout=5) as conn:
        conn.sendall(request.encode("latin-1"))
        answer = b""
        while b"\r\n" not in answer:
            chunk = conn.recv(1024)
            if not chunk:
                break
            answer += chunk
    return answer.split(b"\r\n", 1)[0].decode("latin-1")


def test_daphne_still_fails_closing_a_handshake_autobahn_refused():
    """The canary: when a Daphne release closes such a connection itself, the refused_handshakes patch goes."""
    with pytest.raises(AttributeError, match="server"):
        refused_handshakes.daphne_on_close(WebSocketProtocol(), False, None, None)
    refused_handshakes.on_close_after_connect(WebSocketProtocol(), False, None, None)


@pytest.mark.skipif(not settings.EMBEDDED, reason="its own processes: runs in the embedded pass")
def test_a_real_daphne_refuses_malformed_hosts_and_origins_with_one_warning_line_each():
    with Stack(sim=False, users=False) as stack:
        # Twisted's log reaches Python logging once the embedded link has started (roslibpy's observer).
        wait_until(lambda: "Starting factory" in stack.log("web"), timeout=20, what="the link's first attempt")
        before = len(stack.log("web").splitlines())
        answers = [handshake(stack.web_port, host, origin) for host, origin in MALFORMED]
        # The last one's lines are written once its connection is closed: a well-formed refusal after it.
        assert handshake(stack.web_port, "{site}", "http://evil.example") == "HTTP/1.1 403 Access denied"
        wait_until(lambda: stack.log("web").count("Access denied") >= 2, timeout=5, what="the last refusal's log")
        logged = stack.log("web").splitlines()[before:]
    assert all(a.startswith(("HTTP/1.1 400 ", "HTTP/1.1 403 ")) for a in answers), answers
    text = "\n".join(logged)
    assert "CRITICAL" not in text and "Traceback" not in text and "ERROR" not in text, text
    warnings = [line for line in logged if " WARNING " in line]
    assert len(warnings) <= len(MALFORMED) + 1 and all(len(line) < 300 for line in warnings), text


@pytest.mark.parametrize(("host", "origin"), MALFORMED)
async def test_the_application_refuses_them_without_logging_an_error(operator, caplog, host, origin):
    from server.asgi import application

    site = "127.0.0.1:8200"
    headers = [(b"host", host.format(site=site).encode())] if host is not None else []
    headers += [(b"origin", origin.format(site=site).encode())] if origin is not None else []
    communicator = WebsocketCommunicator(application, "/ws/live/", headers=headers)
    communicator.scope["user"] = operator
    with caplog.at_level(logging.DEBUG):
        connected, _ = await communicator.connect()
        await communicator.disconnect()
    assert connected is False
    assert [r for r in caplog.records if r.levelno >= logging.ERROR or r.exc_info] == []
