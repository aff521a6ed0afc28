"""Daphne lets go of a finished request at once instead of at its next once-a-second sweep.

Daphne keeps every request's protocol object, application task, input queue and scope in
``Server.connections`` until ``application_checker`` (every second) finds the request both
answered and finished. Under load that is up to a second of requests, ~35 objects each: they
outlive two garbage collections, so they are promoted to the oldest generation, whose full
collections then come every second or so and scan all of them (a 70-100 ms pause of the event
loop, which made the state API's p99). Here a request is reaped the moment both are true — the
application has returned and the connection has let go of it — exactly as the sweep would:
an exception is logged, a cancelled application is not. An application that returns while its
connection still waits for an answer is still the sweep's to handle (it answers 500).
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from daphne import server as daphne_server

log = logging.getLogger(__name__)

_installed = False


def reap(server: Any, protocol: Any) -> None:
    """Forget ``protocol`` when its application is done and it is disconnected (else leave it)."""
    details = server.connections.get(protocol)
    if details is None or "disconnected" not in details:
        return
    instance = details.get("application_instance")
    if instance is None or not instance.done():
        return
    if not instance.cancelled() and (exception := instance.exception()) is not None:
        if isinstance(exception, KeyboardInterrupt):
            return  # the sweep stops the server for it
        # The sweep's own message, so logs read the same either way.
        daphne_server.logger.error("Exception inside application: %s", exception, exc_info=exception)
    del server.connections[protocol]


def install() -> None:
    """Patch Daphne's ``Server`` (once): reap on disconnection and on the application's completion."""
    global _installed
    if _installed:
        return
    _installed = True
    server_class = daphne_server.Server
    create_application = server_class.create_application
    protocol_disconnected = server_class.protocol_disconnected

    def create_application_reaped(self: Any, protocol: Any, scope: dict[str, Any]) -> Any:
        queue = create_application(self, protocol, scope)
        instance: asyncio.Future | None = self.connections.get(protocol, {}).get("application_instance")
        if instance is not None:
            instance.add_done_callback(lambda _: reap(self, protocol))
        return queue

    def protocol_disconnected_reaped(self: Any, protocol: Any) -> None:
        protocol_disconnected(self, protocol)
        reap(self, protocol)

    server_class.create_application = create_application_reaped
    server_class.protocol_disconnected = protocol_disconnected_reaped
