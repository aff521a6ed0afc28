"""Skip Channels' per-message database hop for handlers that never touch the database."""

from __future__ import annotations

from typing import Any

from channels.consumer import get_handler_name


class NoDatabaseHopMixin:
    """Channels runs close_old_connections on its one sync thread before every handler. For
    high-rate messages that never touch the database those serialised hops cost most of the
    latency (bench/live_latency.py, bench/teleop_latency.py) and queue behind unrelated DB work.
    Handlers that do need the database use database_sync_to_async themselves."""

    db_free_types: frozenset[str] = frozenset()

    async def dispatch(self, message: dict[str, Any]) -> None:
        if message["type"] in self.db_free_types:
            await getattr(self, get_handler_name(message))(message)
        else:
            await super().dispatch(message)  # type: ignore[misc]
