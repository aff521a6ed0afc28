"""The link's roslibpy connection: a new connection does not make Twisted's log lines reach
Python logging once more (roslibpy adds an observer per connection and never removes it), and a
wss:// robot's certificate is checked."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import ssl
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from roslibpy.core import RosTimeoutError
from twisted.python import log as twisted_log

from robot import interface as ri
from robot.link.rosclient import LinkRos
from tests.helpers import wait_until
from tests.uplink.netns import TestCA


def _times_logged(caplog, line: str) -> int:
    caplog.clear()
    with caplog.at_level(logging.INFO):
        twisted_log.msg(line)
    return [r.getMessage() for r in caplog.records].count(line)


def test_twisted_lines_are_not_logged_once_more_per_connection(sim, caplog):
    before = _times_logged(caplog, "a line from twisted")
    connections = [LinkRos(sim.url) for _ in range(3)]
    try:
        for ros in connections:
            ros.run()
        wait_until(lambda: all(ros.is_connected for ros in connections), timeout=10, what="connected")
        # The first link connection in a process may bring the one observer logging needs.
        assert _times_logged(caplog, "a line from twisted") <= max(before, 1)
    finally:
        for ros in connections:
            ros.factory.stopTrying()
            ros.close(timeout=2)


@contextlib.contextmanager
def tls_in_front_of(port: int, cert: Path, key: Path) -> Iterator[int]:
    """A TLS-terminating relay to ``port`` (a robot's rosbridge behind wss://); yields its own port."""
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(cert, key)
    loop = asyncio.new_event_loop()

    async def pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(OSError):
            while data := await reader.read(65536):
                writer.write(data)
                await writer.drain()
        writer.close()

    async def relay(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", port)
        await asyncio.gather(pipe(reader, up_writer), pipe(up_reader, writer))

    server = loop.run_until_complete(asyncio.start_server(relay, "127.0.0.1", 0, ssl=context))
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield server.sockets[0].getsockname()[1]
    finally:
        async def shut() -> None:
            server.close()
            relays = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            for task in relays:
                task.cancel()
            await asyncio.gather(*relays, return_exceptions=True)

        asyncio.run_coroutine_threadsafe(shut(), loop).result(5)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)
        loop.close()


def test_a_wss_robot_is_reached_only_when_its_certificate_checks_out(sim, settings, caplog):
    ours, theirs = TestCA("127.0.0.1"), TestCA("127.0.0.1")
    try:
        with tls_in_front_of(sim.port, ours.cert, ours.key) as port:
            for ca_file, reached in (("", False), (str(theirs.ca), False), (str(ours.ca), True)):
                settings.ROSBRIDGE_CA_FILE = ca_file
                caplog.clear()
                ros = LinkRos(f"wss://127.0.0.1:{port}")
                try:
                    if reached:
                        ros.run(timeout=10)
                        assert ri.topic("odom").name in ros.get_topics()
                    else:
                        with pytest.raises(RosTimeoutError):
                            ros.run(timeout=3)
                        assert "certificate verify failed" in caplog.text, ca_file
                finally:
                    ros.factory.stopTrying()
                    ros.close(timeout=2)
    finally:
        ours.remove()
        theirs.remove()
