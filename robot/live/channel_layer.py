"""The channel layer: channels_redis's, on the configured Redis (the private server in the embedded
default, started here the first time a layer is made)."""

from __future__ import annotations

from typing import Any

from channels_redis.core import RedisChannelLayer as _RedisChannelLayer

from robot.live import private_server


class RedisChannelLayer(_RedisChannelLayer):
    def __init__(self, hosts: list[dict[str, Any]] | None = None, **kwargs: Any) -> None:
        for host in hosts or ():
            private_server.ensure(host["address"])
        super().__init__(hosts=hosts, **kwargs)
