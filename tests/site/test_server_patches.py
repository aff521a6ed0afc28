"""The server patches are made for exact Daphne, Twisted and autobahn releases: the server refuses
others, and each private part of theirs a patch uses has a canary here that fails when a release
renames or drops it (then the patch is checked, and the pins in server/patches/releases.py
move with the lock)."""

from __future__ import annotations

import inspect

import pytest
from django.core import checks

from server.patches.releases import SERVER_PATCHES


def test_the_installed_releases_are_the_patched_ones():
    assert SERVER_PATCHES.others() == {}
    SERVER_PATCHES.refuse_others()


def test_another_release_is_refused_at_start_and_by_the_checks(monkeypatch):
    monkeypatch.setitem(SERVER_PATCHES.releases, "twisted", "1.0")
    with pytest.raises(RuntimeError, match=r"twisted 26\.10\.0 is installed, but the server patches are for 1\.0"):
        SERVER_PATCHES.refuse_others()
    assert [e.id for e in checks.run_checks() if e.id == "server.E001"] == ["server.E001"]


def test_direct_frames_canaries():
    """server.patches.direct_frames writes to Twisted's transport and reads autobahn's state."""
    from autobahn.websocket.protocol import WebSocketProtocol
    from twisted.internet import abstract, reactor

    descriptor = abstract.FileDescriptor(reactor)
    for name in ("dataBuffer", "offset", "_tempDataLen", "_writeDisconnected", "connected", "disconnecting"):
        assert hasattr(descriptor, name), name
    assert WebSocketProtocol.STATE_OPEN == 3
    assert "self._perMessageCompress = None" in inspect.getsource(WebSocketProtocol)


def test_reaping_and_frame_writer_canaries():
    """cyborg_site.reaping and direct_frames wrap two of Daphne's Server methods and read its connections."""
    from daphne.server import Server

    assert list(inspect.signature(Server.create_application).parameters) == ["self", "protocol", "scope"]
    assert list(inspect.signature(Server.protocol_disconnected).parameters) == ["self", "protocol"]
    source = inspect.getsource(Server)
    assert "self.connections = {}" in source and '"application_instance"' in source
    assert '"disconnected"' in source and "def application_checker" in source


def test_asgi_line_canaries():
    """server.asgi: WebRequest's form parsing switched off, HTTPFactory's own log line dropped,
    Nagle off for Daphne's websockets; refused_handshakes wraps onClose."""
    from daphne.http_protocol import HTTPFactory, WebRequest
    from daphne.ws_protocol import WebSocketProtocol
    from twisted.web.http import Request

    assert "parsePOSTFormSubmission" in inspect.signature(Request.__init__).parameters
    assert issubclass(WebRequest, Request)
    assert callable(HTTPFactory.log)
    from autobahn.twisted import websocket

    assert "self.transport.setTcpNoDelay(self.tcpNoDelay)" in inspect.getsource(websocket)
    assert callable(WebSocketProtocol.onClose)
