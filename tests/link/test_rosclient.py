"""The link's roslibpy connection: a new connection does not make Twisted's log lines reach
Python logging once more (roslibpy adds an observer per connection and never removes it)."""

from __future__ import annotations

import logging

from twisted.python import log as twisted_log

from robot.link.rosclient import LinkRos
from tests.helpers import wait_until


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
