"""A web process told to stop (SIGTERM: a rolling restart) finishes the requests it has started.

Daphne on its own cancels every running request when it stops, so a command in flight gets a 502
from nginx although it may already be on its way to the robot. Instead, on SIGTERM this process
stops listening at once (nginx then sends new requests to another web process: a refused connection
is retried there, even for a POST), lets the HTTP requests it is serving finish for at most
``DRAIN_S``, then stops as Daphne would (a second SIGTERM stops it at once). Websockets are not
waited for: the pages reconnect through another web process.
"""

from __future__ import annotations

import logging
import signal
import sys
import time
from typing import Any

log = logging.getLogger(__name__)

DRAIN_S = 5.0  # well inside systemd's TimeoutStopSec (deploy/systemd) and stack.sh's wait

_in_flight = 0
_draining = False


class CountRequests:
    """ASGI middleware: how many HTTP requests this process is serving right now."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        global _in_flight
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        _in_flight += 1
        try:
            await self.app(scope, receive, send)
        finally:
            _in_flight -= 1


def daphne_reactor() -> Any | None:
    """Twisted's reactor when this process is the Daphne server on asyncio, else None."""
    # Importing Daphne installs its reactor everywhere (tests too); only its server entry
    # points mean this process is the web server.
    if not any(name in sys.modules for name in ("daphne.cli", "daphne.management.commands.runserver")):
        return None
    from twisted.internet import reactor
    from twisted.internet.asyncioreactor import AsyncioSelectorReactor

    return reactor if isinstance(reactor, AsyncioSelectorReactor) else None


def install_in_daphne() -> None:
    """Take over SIGTERM once the reactor runs (Twisted's own handler would stop it at once)."""
    reactor = daphne_reactor()
    if reactor is None:
        return

    def on_sigterm(signum: int, frame: Any) -> None:
        reactor.callFromThread(_drain, reactor)

    reactor.callWhenRunning(signal.signal, signal.SIGTERM, on_sigterm)


def _drain(reactor: Any) -> None:
    global _draining
    from twisted.internet import tcp

    if _draining:
        reactor.stop()
        return
    _draining = True
    for reader in reactor.getReaders():
        if isinstance(reader, tcp.Port):  # the listening sockets (unix ones are Ports too)
            reader.stopListening()
    log.warning("stopping: no longer listening; finishing %d request(s) in flight", _in_flight)
    _stop_when_idle(reactor, time.monotonic() + DRAIN_S)


def _stop_when_idle(reactor: Any, deadline: float) -> None:
    if _in_flight and time.monotonic() < deadline:
        reactor.callLater(0.02, _stop_when_idle, reactor, deadline)
        return
    if _in_flight:
        log.warning("stopping: %d request(s) still running after %g s are cancelled", _in_flight, DRAIN_S)
    if reactor.running:
        reactor.stop()
