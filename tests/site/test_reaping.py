"""Daphne forgets a finished request as soon as its application has returned and its connection
has let go, instead of at the next once-a-second sweep; everything else stays the sweep's."""

import asyncio
import logging

import pytest
from daphne.server import Server

from server.patches import reaping


@pytest.fixture
def server():
    reaping.install()
    server = Server(application=None, endpoints=["tcp:port=0:interface=127.0.0.1"], signal_handlers=False)
    server.connections = {}  # as Server.run() starts it
    return server


def serve(server: Server, app) -> object:
    protocol = object()
    server.application = app
    server.protocol_connected(protocol)
    server.create_application(protocol, {"type": "http"})
    return protocol


async def test_it_forgets_a_request_answered_before_the_connection_let_go(server):
    protocol = serve(server, lambda **_: asyncio.sleep(0))
    await asyncio.sleep(0.01)
    assert protocol in server.connections  # answered, connection not done with it yet
    server.protocol_disconnected(protocol)
    assert protocol not in server.connections


async def test_it_forgets_a_request_whose_application_returns_after_the_connection_let_go(server):
    release = asyncio.Event()

    async def app(**_):
        await release.wait()

    protocol = serve(server, app)
    server.protocol_disconnected(protocol)
    await asyncio.sleep(0.01)
    assert protocol in server.connections  # still running
    release.set()
    await asyncio.sleep(0.01)
    assert protocol not in server.connections


async def test_it_leaves_an_application_that_returned_without_an_answer_to_the_sweep(server):
    protocol = serve(server, lambda **_: asyncio.sleep(0))
    await asyncio.sleep(0.01)
    assert server.connections[protocol]["application_instance"].done()
    assert protocol in server.connections  # the sweep answers it with a 500


async def test_it_logs_an_application_error_as_the_sweep_does(server, caplog):
    async def app(**_):
        raise RuntimeError("boom")

    protocol = serve(server, app)
    server.protocol_disconnected(protocol)
    with caplog.at_level(logging.ERROR, logger="daphne.server"):
        await asyncio.sleep(0.01)
    assert protocol not in server.connections
    assert [r.getMessage() for r in caplog.records] == ["Exception inside application: boom"]


async def test_a_cancelled_application_is_forgotten_quietly(server, caplog):
    protocol = serve(server, lambda **_: asyncio.sleep(10))
    server.protocol_disconnected(protocol)
    server.connections[protocol]["application_instance"].cancel()
    with caplog.at_level(logging.ERROR, logger="daphne.server"):
        await asyncio.sleep(0.01)
    assert protocol not in server.connections
    assert caplog.records == []
