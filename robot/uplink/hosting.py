"""The uplink endpoint runs where the link runs (the active robotlink, or the embedded server), so the
link and its relays share a process and a standby link listens for no agent (nginx tries the next)."""

from __future__ import annotations

import asyncio
from typing import Any

from django.conf import settings

from robot.supervisor import holding
from robot.uplink.endpoint import UplinkEndpoint
from robot.uplink.relays import Relays


def make_endpoint() -> UplinkEndpoint:
    host, _, port = settings.UPLINK_LISTEN.rpartition(":")
    relays = Relays(rosbridge_port=settings.UPLINK_ROSBRIDGE_PORT, video_port=settings.UPLINK_VIDEO_PORT,
                    max_size=settings.UPLINK_MAX_FRAME_BYTES)
    return UplinkEndpoint(host=host.strip("[]") or "127.0.0.1", port=int(port), robot=settings.UPLINK_ROBOT,
                          relays=relays, max_frame_bytes=settings.UPLINK_MAX_FRAME_BYTES,
                          max_messages_per_s=settings.UPLINK_MAX_MESSAGES_PER_S,
                          auth_timeout_s=settings.UPLINK_AUTH_TIMEOUT_S, failure_limit=settings.UPLINK_FAILURE_LIMIT)


async def serve_uplink(link: Any) -> None:
    """A background service of the link: the endpoint, until cancelled (the link's status names it)."""
    endpoint = make_endpoint()
    await endpoint.start()
    try:
        with holding(endpoint):
            while True:  # (a timer the loop holds: the embedded server keeps no reference to this task)
                await asyncio.sleep(3600)
    finally:
        await asyncio.shield(endpoint.stop())

