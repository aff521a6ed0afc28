"""Each connection's client address (as Daphne has it: behind the shipped nginx, the address nginx
saw) is the one its audit entries carry, whichever path the request takes (the fast paths, Django,
a websocket consumer)."""

from __future__ import annotations

from typing import Any

from robot.commands.audit import client_address


class ClientAddress:
    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        client = scope.get("client") or ("",)
        token = client_address.set(str(client[0] or ""))
        try:
            await self.app(scope, receive, send)
        finally:
            client_address.reset(token)
