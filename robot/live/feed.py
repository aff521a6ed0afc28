"""How a live update reaches the watching sockets of every web process, serialised once: it is
published once on one Redis pub/sub channel, and each web process holds ONE subscription to it that
feeds its own hub (``run_subscriber``). The channel layer carries no topic updates.
"""

from __future__ import annotations

import asyncio
import logging
import os
import time
import weakref
from typing import Any

from robot import interface as ri
from robot.live import redis_clients
from robot.live.frames import status_text, update_fragment
from robot.live.groups import STATUS_KEY
from robot.live.hub import REDIS_GATHER_S, Hub, get_hub
from robot.live.state import get_store, redis_key
from robot.supervisor import spawn

log = logging.getLogger(__name__)

RETRY_S = 1.0
SUBSCRIBE_WAIT_S = 3.0
GAP_MARGIN_S = 1.0  # an update stamped this long before the subscription was lost may not have come through
SUBSCRIBER_NAME = f"cyborg-live-{os.getpid()}"  # in Redis's CLIENT LIST
_subscribers: weakref.WeakKeyDictionary[Hub, asyncio.Task] = weakref.WeakKeyDictionary()
_ready: weakref.WeakKeyDictionary[Hub, asyncio.Event] = weakref.WeakKeyDictionary()


def keeps_every_message(key: str) -> bool:
    """Event-like keys (logs, state changes) are never coalesced; for the rest the latest value wins."""
    try:
        return ri.topic(key).ui_rate_hz is None
    except KeyError:  # keys the server writes itself: one current value each
        return False


def channel() -> str:
    return redis_key("live")


async def announce(update: dict[str, Any]) -> None:
    """Send one update to every socket watching its key, in every web process."""
    key = update["key"]
    await _send(key, float(update["t"]), keeps_every_message(key), update_fragment(update))


async def announce_status(status: dict[str, Any]) -> None:
    """The link's status to every live socket, in every web process."""
    await _send(STATUS_KEY, 0, False, status_text(status))


async def _send(key: str, t: float, every: bool, text: str) -> None:
    await redis_clients.aclient().publish(channel(), f"{key}\n{t!r}\n{int(every)}\n{text}")


def _offer(hub: Hub, key: str, text: str, t: float, every: bool) -> None:
    if key == STATUS_KEY:
        hub.publish_status(text)
    else:
        hub.publish(key, text, t, every=every)


async def alocal_hub() -> Hub:
    """This process's hub, once its one Redis subscription is in place (started on first use):
    pub/sub keeps nothing for a late subscriber, so a page whose first snapshot was read before the
    subscription began could miss an update published in between (a latched topic's only message)."""
    hub = get_hub()
    hub.gather_s = REDIS_GATHER_S
    task = _subscribers.get(hub)
    if task is None or task.done():
        _ready[hub] = asyncio.Event()
        _subscribers[hub] = spawn(run_subscriber(hub), loop=hub.loop)
    try:
        async with asyncio.timeout(SUBSCRIBE_WAIT_S):
            await _ready[hub].wait()
    except TimeoutError:
        log.warning("live updates: no Redis subscription after %g s; the page gets updates once it is back",
                    SUBSCRIBE_WAIT_S)
    return hub


def deliver(hub: Hub, data: bytes | str) -> tuple[str, float]:
    """One message from the Redis channel into the hub; its key and time."""
    raw = data.decode() if isinstance(data, bytes) else data
    key, t, every, text = raw.split("\n", 3)
    _offer(hub, key, text, float(t), every == "1")
    return key, float(t)


async def run_subscriber(hub: Hub) -> None:
    """Feed ``hub`` from the Redis channel for as long as the process runs; resubscribe after errors.
    Each time the subscription is in place again, the sockets get every watched key's stored value
    that is newer than what came through before the gap: what was published meanwhile is not lost."""

    delivered: dict[str, float] = {}  # key -> time of the newest update that came through
    subscribed_before = False
    lost_at: float | None = None
    while True:
        # No socket timeout: the subscription waits as long as nothing is published.
        client = redis_clients.new_aclient(client_name=SUBSCRIBER_NAME, socket_timeout=None)
        try:
            async with client.pubsub() as pubsub:
                await pubsub.subscribe(channel())
                async for message in pubsub.listen():
                    kind = message.get("type")
                    if kind == "message":
                        try:
                            key, t = deliver(hub, message["data"])
                        except ValueError:
                            log.warning("malformed live update on %s", channel())
                            continue
                        delivered[key] = max(t, delivered.get(key, 0.0))
                    elif kind == "subscribe":
                        log.info("live updates: subscribed to %s", channel())
                        if subscribed_before:
                            await _refresh(hub, delivered, since=(lost_at or time.time()) - GAP_MARGIN_S)
                        subscribed_before, lost_at = True, None
                        _ready.setdefault(hub, asyncio.Event()).set()
        except Exception:
            lost_at = lost_at or time.time()
            log.warning("live update subscription lost; resubscribing in %g s", RETRY_S, exc_info=True)
            await asyncio.sleep(RETRY_S)
        finally:
            await client.aclose()


async def _refresh(hub: Hub, delivered: dict[str, float], *, since: float) -> None:
    """Offer each watched key's stored value when it is newer than the gap's start and than what came
    through (an event-like key gets its newest line, never one it already had)."""
    keys = hub.watched_keys()
    if not keys:
        return
    try:
        latest = await get_store().aget_many(keys)
    except Exception:
        log.warning("live updates: could not read the stored values after resubscribing", exc_info=True)
        return
    for key, entry in latest.items():
        t = float(entry["t"])
        if t > max(since, delivered.get(key, 0.0)):
            hub.publish(key, update_fragment(entry), t, every=keeps_every_message(key))
